"""A session directory: the measurement file with trial lists, the trials and the truth."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.io_yaml import MEASUREMENTS_FORMAT, load_yaml_document, measurements_from_document
from bike_rig.core.sim.rig import RigConfig
from bike_rig.core.sim.session import SimulatedSession, simulate_session
from bike_rig.core.sim.writer import TRUTH_FORMAT, write_session
from bike_rig.core.trials import read_trial

PERIOD_KEYS = ("compound_period", "torsional_period")


def _period_entries(doc: Any, where: tuple[object, ...] = ()) -> list[tuple[tuple[object, ...], Any]]:
    """Every (path, value) of a period key in the document."""
    found = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            if k in PERIOD_KEYS:
                found.append((where + (k,), v))
            else:
                found += _period_entries(v, where + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            found += _period_entries(v, where + (i,))
    return found


@pytest.fixture(scope="module")
def session(rig: RigConfig, browser_truth: dict[str, float]) -> SimulatedSession:
    return simulate_session(browser_truth, rig, 12345, "Browser")


def test_session_directory_layout(session: SimulatedSession, tmp_path: Path) -> None:
    path = write_session(session, tmp_path / "s", volts=True)
    assert path == tmp_path / "s" / "session.yaml"
    trials = sorted((tmp_path / "s" / "trials").iterdir())
    assert [p.name for p in trials] == sorted(f"{t.name}.npy" for t in session.trials)
    for t in session.trials:
        data = np.load(tmp_path / "s" / "trials" / f"{t.name}.npy")
        assert data.dtype == np.float64 and data.shape == (len(t.rate), 2)
        assert np.array_equal(data, t.samples())
        assert np.array_equal(np.load(tmp_path / "s" / "volts" / f"{t.name}.npy"), t.volts)
    write_session(session, tmp_path / "t")
    assert not (tmp_path / "t" / "volts").exists()


def test_session_yaml_lists_the_trials_of_every_period(session: SimulatedSession, tmp_path: Path) -> None:
    path = write_session(session, tmp_path)
    doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert doc["format"] == MEASUREMENTS_FORMAT and doc["bicycle"] == "Browser"
    entries = _period_entries(doc)
    assert len(entries) == 13
    for where, entry in entries:
        assert set(entry) == {"trials"}, where
        assert len(entry["trials"]) == 3
        for rel in entry["trials"]:
            assert rel.startswith("trials/") and (path.parent / rel).is_file()
    assert doc["frame"]["orientations"][1]["torsional_period"]["trials"] == [
        f"trials/frame_torsional_o2_t{i}.npy" for i in (1, 2, 3)
    ]
    assert doc["calibration_rod"]["torsional_period"]["trials"][0] == "trials/calibration_rod_torsional_t1.npy"


def test_session_yaml_with_periods_filled_in_is_the_sessions_measurement_file(
    session: SimulatedSession, tmp_path: Path
) -> None:
    """Replacing each trial list by a [period, sigma] gives a measurement file the core reads.

    It has exactly the session's static readings (shortest round-trip floats).
    """
    path = write_session(session, tmp_path)
    data, lines = load_yaml_document(path)
    by_file = {f"trials/{t.name}.npy": t.key for t in session.trials}
    periods = {}
    for where, entry in _period_entries(data):
        key = by_file[entry["trials"][0]]
        assert {by_file[f] for f in entry["trials"]} == {key}
        node: Any = data
        for part in where[:-1]:
            node = node[part]
        node[where[-1]] = [session.truth.periods[key], 1e-5]
        periods[key] = (session.truth.periods[key], 1e-5)
    m = measurements_from_document(str(path), data, lines)
    want = session.measurements(periods)
    assert {k: (r.value, r.sigma) for k, r in m.readings.items()} == {
        k: (r.value, r.sigma) for k, r in want.readings.items()
    }
    assert compute_parameters(m).parameters.values == pytest.approx(
        compute_parameters(want).parameters.values, rel=1e-15
    )


def test_truth_yaml(session: SimulatedSession, tmp_path: Path) -> None:
    write_session(session, tmp_path)
    truth = yaml.safe_load((tmp_path / "truth.yaml").read_text(encoding="utf-8"))
    assert truth["format"] == TRUTH_FORMAT and truth["seed"] == 12345
    assert truth["parameters"] == dict(session.truth.parameters)
    assert truth["periods"] == dict(session.truth.periods)
    assert truth["static"] == dict(session.truth.static)
    assert [t["file"] for t in truth["trials"]] == [f"trials/{t.name}.npy" for t in session.trials]
    assert [t["beating"] for t in truth["trials"]] == [t.beating for t in session.trials]
    assert truth["trials"][0]["modes"][0]["period"] == session.trials[0].true_period


def test_trial_files_read_back_with_read_trial(session: SimulatedSession, tmp_path: Path) -> None:
    write_session(session, tmp_path)
    for t in session.trials:
        trial = read_trial(tmp_path / "trials" / f"{t.name}.npy")
        assert trial.name == t.name
        assert np.array_equal(trial.samples, t.rate)
        assert trial.times is not None and np.array_equal(trial.times, t.time)


def test_truth_yaml_records_each_trials_friction_and_swing(
    session: SimulatedSession, rig: RigConfig, browser_truth: dict[str, float], tmp_path: Path
) -> None:
    write_session(session, tmp_path / "off")
    off = yaml.safe_load((tmp_path / "off" / "truth.yaml").read_text(encoding="utf-8"))
    assert {(t["dry_friction"], t["dry_friction_fraction"], t["finite_swing"]) for t in off["trials"]} == {
        (0.0, 0.0, False)
    }
    trials = replace(rig.trials, durations=(1.0,), dry_friction=(0.01, 0.03), finite_swing=True)
    rubbing = simulate_session(browser_truth, replace(rig, trials=trials, coupled_swing=None), 7, "Browser")
    write_session(rubbing, tmp_path / "on")
    on = yaml.safe_load((tmp_path / "on" / "truth.yaml").read_text(encoding="utf-8"))
    for doc, t in zip(on["trials"], rubbing.trials, strict=True):
        assert doc["dry_friction"] == t.dry_friction > 0.0  # μ, rad/s²
        assert doc["dry_friction_fraction"] == t.dry_friction_fraction
        assert 0.01 <= doc["dry_friction_fraction"] <= 0.03
        mode = doc["modes"][0]
        w0 = 2.0 * np.pi / mode["period"]
        assert doc["dry_friction"] == pytest.approx(doc["dry_friction_fraction"] * mode["amplitude"] * w0**2 / 4)
        assert doc["finite_swing"] is t.finite_swing is ("compound" in t.name)
