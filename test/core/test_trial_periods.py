"""Periods given as raw trial files in a measurement file are fitted and combined on load."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_dir
from bike_rig.core.errors import InputFileError
from bike_rig.core.loader import load_measurements
from bike_rig.core.period import combine_periods


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("session")
    code = main(
        [
            "simulate",
            "--bicycle",
            str(config_dir() / "bicycles" / "browser.yaml"),
            "--out",
            str(out),
            "--seed",
            "11",
            "--force",
        ]
    )
    assert code == 0
    return out / "session.yaml"


def test_every_period_comes_from_three_fitted_trials(session: Path) -> None:
    m = load_measurements(session)
    periods = [k for k in m.readings if k.startswith(("Tc", "Tt"))]
    assert len(periods) == 13  # 4 compound + 2 wheel + 3 + 3 orientations + rod
    assert set(m.evidence) == set(periods)
    for key in periods:
        ev = m.evidence[key]
        assert len(ev.files) == 3 and len(ev.fits) == 3
        again = combine_periods(ev.fits)
        assert (m.readings[key].value, m.readings[key].sigma) == (again.value, again.sigma)
        assert 0 < m.readings[key].sigma < 1e-3 * m.readings[key].value


def test_params_from_a_session_file(session: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", str(session), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["parameters"]) == 26 and doc["bicycle"] == "Browser"


def _copy_with(session: Path, tmp_path: Path, old: str, new: str) -> Path:
    text = session.read_text()
    assert old in text
    dest = tmp_path / "session.yaml"
    dest.write_text(text.replace(old, new, 1))
    (tmp_path / "trials").symlink_to(session.parent / "trials")
    return dest


def test_no_usable_trial_is_an_error_naming_the_trials(session: Path, tmp_path: Path) -> None:
    flat = tmp_path / "flat.npy"
    t = np.arange(0, 10, 1e-3)
    np.save(flat, np.column_stack([t, np.zeros_like(t)]))
    text = session.read_text()
    start = text.index("  compound_period: {trials: [trials/frame_compound_t1.npy")
    end = text.index("]}", start) + 2
    dest = tmp_path / "session.yaml"
    dest.write_text(text[:start] + f"  compound_period: {{trials: [{flat}, {flat}]}}" + text[end:])
    (tmp_path / "trials").symlink_to(session.parent / "trials")
    with pytest.raises(InputFileError, match="no usable trial, redo the measurement") as err:
        load_measurements(dest)
    assert err.value.key == "frame.compound_period" and "flat.npy" in str(err.value)


def test_malformed_trial_lists(session: Path, tmp_path: Path) -> None:
    dest = _copy_with(
        session,
        tmp_path,
        "compound_period: {trials: [trials/frame_compound_t1.npy",
        "compound_period: {trials: 7, x: [trials/frame_compound_t1.npy",
    )
    with pytest.raises(InputFileError, match=r"\{trials: \[file, \.\.\.\]"):
        load_measurements(dest)


def test_missing_trial_file(session: Path, tmp_path: Path) -> None:
    dest = _copy_with(session, tmp_path, "trials/frame_compound_t2.npy", "trials/nowhere.npy")
    with pytest.raises(InputFileError, match="nowhere.npy"):
        load_measurements(dest)
