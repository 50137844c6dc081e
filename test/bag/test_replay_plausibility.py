"""``replay``: a file in a wrong unit warns, impossible results are refused, a bad bag reading blames the bag."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from bike_rig.bag.simulated import simulated_messages
from bike_rig.cli.main import main
from bike_rig.config import topics
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.core.sim import SimulatedSession
from bike_rig.messages.fields import set_floats
from test.support.entered import entries_bag, one_trial_session, session_static, write_messages


@pytest.fixture(scope="module")
def session() -> SimulatedSession:
    return one_trial_session()


@pytest.fixture(scope="module")
def entered(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return entries_bag(tmp_path_factory.mktemp("entered") / "bag", session)[0]


def readings_file(session: SimulatedSession, folder: Path, key: str, value: float) -> Path:
    static = session_static(session)
    readings = {**static.readings, key: Reading(value, static.readings[key].sigma)}
    path = folder / f"{key}.yaml"
    path.write_text(dump_measurements_yaml(Measurements(static.bicycle, readings, str(path))))
    return path


def test_a_wheelbase_in_mm_warns_and_strict_refuses_it(
    capsys: pytest.CaptureFixture[str], session: SimulatedSession, entered: Path, tmp_path: Path
) -> None:
    w = session_static(session).value("w")
    fixed = readings_file(session, tmp_path, "w", w * 1000.0)
    assert main(["replay", str(entered), "--readings", str(fixed)]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"bike-rig replay: warning: {fixed}:") and err.count("\n") == 1
    assert f"it looks like millimetres (w = {w:.6g} m)" in err
    assert main(["replay", str(entered), "--readings", str(fixed), "--strict"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith(f"bike-rig replay: error: {fixed}:") and "millimetres" in err


def test_an_arm_too_long_for_the_recorded_period_is_refused_naming_both(
    capsys: pytest.CaptureFixture[str], session: SimulatedSession, entered: Path, tmp_path: Path
) -> None:
    fixed = readings_file(session, tmp_path, "lR", 0.79)  # plausible alone, longer than the period allows
    assert main(["replay", str(entered), "--readings", str(fixed)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert err.startswith("bike-rig replay: error: ") and "is not physically possible: TcR1 = " in err
    assert "with lR = 0.79 m gives IRyy = -" in err and "a compound period of at least" in err


def nan_bag(path: Path, session: SimulatedSession, key: str = "mF") -> Path:
    """The session's bag with one static reading NaN in its StaticReadings, read live from a file elsewhere."""
    messages = list(simulated_messages(session, start_ns=1_800_000_000 * 10**9, pause_s=2.0))
    for m in messages:
        if m.topic == topics.STATIC_READINGS.name:
            values = [float(v) for v in m.message.values]
            values[list(m.message.keys).index(key)] = math.nan
            set_floats(m.message, "values", values)
            m.message.source = "/home/operator/browser.yaml"
    return write_messages(path, messages)


def test_a_nan_static_reading_in_a_bag_is_blamed_on_the_bag(
    capsys: pytest.CaptureFixture[str], session: SimulatedSession, tmp_path: Path
) -> None:
    bag = nan_bag(tmp_path / "bag", session)
    for cmd in ("replay", "budget"):
        assert main([cmd, str(bag)]) == 2
        out, err = capsys.readouterr()
        assert out == "" and err == (
            f"bike-rig {cmd}: error: {bag}: the recorded StaticReadings (from /home/operator/browser.yaml): "
            "key 'mF': value and sigma must be finite numbers, got nan ± 0.02\n"
        )
