"""A session bag is self-contained: readings entered during the session replay with no file.

``bike-rig replay BAG`` uses the bag's own last StaticReadings (the parameter node's merged
readings), ``--readings FILE`` swaps in a corrected file, and ``plot``/``budget`` (and the
report, through the same :func:`bike_rig.offline.subjects.load_subject`) need no file either.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import main
from bike_rig.core.benchmark import ParameterSet, compute_parameters
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.core.sim import SimulatedSession
from bike_rig.messages import reading_entry_from_msg
from bike_rig.offline.compare import relative_difference
from bike_rig.offline.replay import ReplaySettings, replay_bag
from bike_rig.offline.session import read_session
from bike_rig.offline.subjects import load_subject
from test.support.entered import MISTAKE_KEY, entries_bag, one_trial_session, session_static
from test.support.replay import core_periods, run_cli


@pytest.fixture(scope="module")
def session() -> SimulatedSession:
    return one_trial_session()


@pytest.fixture(scope="module")
def entered(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The session with every static reading entered (one mistake, then its correction)."""
    return entries_bag(tmp_path_factory.mktemp("entered") / "bag", session)[0]


def assert_close(ours: ParameterSet | None, core: ParameterSet) -> None:
    assert ours is not None
    assert list(ours.parameters.names) == list(core.parameters.names)
    for got, want in (
        (ours.parameters.values, core.parameters.values),
        (ours.parameters.covariance, core.parameters.covariance),
    ):
        assert relative_difference(got, want)[0] <= 1e-12


def test_entered_readings_replay_with_no_file_to_the_offline_core(session: SimulatedSession, entered: Path) -> None:
    recorded = read_session(entered)
    entries = [reading_entry_from_msg(m) for m in recorded.reading_entries]
    assert len(entries) == len(session.readings) + 1
    mistakes = [e for e in entries if e.key == MISTAKE_KEY]
    assert [e.note for e in mistakes] == ["", "correction"] and mistakes[0].value == 1000 * mistakes[1].value

    result = replay_bag(entered)
    assert result.complete and not result.readings_swapped
    assert result.readings == f"{len(entries)} reading entries"
    core = compute_parameters(session.measurements(core_periods(session)))
    assert_close(result.parameters, core)
    code, out, err = run_cli("replay", str(entered))
    assert (code, err) == (0, "")
    assert f"static readings: the bag's ({len(entries)} reading entries)" in out


def test_readings_swapped_from_a_corrected_file(session: SimulatedSession, entered: Path, tmp_path: Path) -> None:
    static = session_static(session)
    corrected = dict(static.readings)
    corrected["mF"] = Reading(static.value("mF") + 0.15, 0.01)
    periods = core_periods(session)
    # the file has periods too (deliberately wrong ones): they are ignored
    wrong = {k: Reading(v * 1.01, s) for k, (v, s) in periods.items()}
    text = dump_measurements_yaml(Measurements(static.bicycle, {**corrected, **wrong}, "corrected"))
    fixed = tmp_path / "corrected.yaml"
    fixed.write_text(text)

    result = replay_bag(entered, ReplaySettings(readings=fixed))
    assert result.readings_swapped and result.readings == str(fixed)
    assert any(f"static readings from {fixed} instead of the bag's" in n for n in result.notes)
    reference = session.measurements(periods)
    expected = compute_parameters(Measurements(static.bicycle, {**reference.readings, "mF": corrected["mF"]}, "x"))
    assert_close(result.parameters, expected)
    assert result.parameters is not None
    assert result.parameters.parameters.value("mF") == static.value("mF") + 0.15

    code, out, err = run_cli("replay", str(entered), "--readings", str(fixed))
    assert (code, err) == (0, "")
    assert f"static readings: from {fixed}, NOT the bag's (swapped with --readings)" in out
    assert f"note: static readings from {fixed} instead of the bag's" in out and "its periods ignored" in out
    data = json.loads(run_cli("replay", str(entered), "--readings", str(fixed), "--json")[1])
    assert data["settings"]["readings_swapped"] and data["settings"]["readings"] == str(fixed)
    assert data["parameters"]["mF"]["value"] == static.value("mF") + 0.15


def test_a_reading_never_entered_is_one_line_and_a_file_completes_it(session: SimulatedSession, tmp_path: Path) -> None:
    bag, _ = entries_bag(tmp_path / "bag", session, skip=("gamma", "aH2"))
    code, out, err = run_cli("replay", str(bag))
    assert code == 2 and out == ""
    assert err.strip().count("\n") == 0
    assert "static readings are incomplete (missing gamma, aH2)" in err and "--readings FILE" in err
    full = tmp_path / "full.yaml"
    full.write_text(dump_measurements_yaml(session_static(session)))
    code, out, err = run_cli("replay", str(bag), "--readings", str(full))
    assert (code, err) == (0, "")


def test_plot_budget_and_subjects_read_the_readings_from_the_bag(
    session: SimulatedSession, entered: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    subject = load_subject(entered)
    assert subject.kind == "bag" and subject.measurements is not None
    static = session_static(session)
    got = {k: (r.value, r.sigma) for k, r in subject.measurements.readings.items() if k in static.readings}
    assert got == {k: (r.value, r.sigma) for k, r in static.readings.items()}
    assert_close(subject.parameters, compute_parameters(session.measurements(core_periods(session))))

    assert main(["plot", "side", str(entered), "-o", str(tmp_path / "figs")]) == 0
    printed = capsys.readouterr().out.split()
    assert printed and all(Path(p).is_file() and Path(p).stat().st_size > 0 for p in printed)
    assert main(["budget", str(entered), "--json"]) == 0
    budget = json.loads(capsys.readouterr().out)
    assert "gamma" in budget["inputs"] and np.isclose(sum(s["share"] for s in budget["outputs"][0]["shares"]), 1.0)
