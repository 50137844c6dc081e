"""Node health without ROS: level rules, the rate meter, each node's statuses, the message converters."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from bike_rig.diagnostics import Level, RateMeter, Status, age_level, level_above, level_below, worst
from bike_rig.messages import MessageError
from bike_rig.messages.diagnostics import fill_diagnostic_array, statuses_from_msg
from bike_rig.pipeline.health import (
    DriverHealth,
    FitterHealth,
    ModelHealth,
    ParameterHealth,
    RecorderHealth,
    driver_statuses,
    fitter_statuses,
    model_statuses,
    parameter_statuses,
    recorder_statuses,
)


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_level_rules() -> None:
    assert [level_above(x, 1.0, 2.0) for x in (0.5, 1.0, 1.9, 2.0)] == [Level.OK, Level.WARN, Level.WARN, Level.ERROR]
    assert [level_below(x, 10.0, 0.0) for x in (11.0, 10.0, 0.0)] == [Level.OK, Level.WARN, Level.ERROR]
    assert age_level(math.inf, 1.0, 3.0) == Level.ERROR
    assert worst([]) == Level.OK
    assert worst([Status("a", Level.WARN, "w"), Status("b", Level.STALE, "s")]) == Level.STALE


def test_rate_meter_counts_over_its_window_from_a_restart() -> None:
    clock = Clock()
    meter = RateMeter(2.0, clock)
    assert meter.age() == math.inf and meter.rate() == 0.0
    clock.t += 1.0
    meter.add(500)
    assert meter.rate() == pytest.approx(500.0)  # 500 in the 1 s since the start
    clock.t += 1.0
    meter.add(1000)
    assert meter.rate() == pytest.approx(750.0)  # 1500 in 2 s
    clock.t += 2.5
    assert meter.rate() == pytest.approx(0.0) and meter.age() == pytest.approx(2.5)
    meter.restart()
    clock.t += 0.5
    meter.add(100)
    assert meter.rate() == pytest.approx(200.0) and meter.total == 1600
    with pytest.raises(ValueError, match="> 0 s"):
        RateMeter(0.0)


def driver(**changes: Any) -> DriverHealth:
    base = DriverHealth("sim", 0, ("t1",), 1000.0, 1000.0, 0.01, 1.0, 5000, 0, 0, 0.0)
    return dataclasses.replace(base, **changes)


def by_concern(statuses: list[Status]) -> dict[str, Status]:
    return {s.name.split(": ", 1)[1]: s for s in statuses}


def test_driver_levels() -> None:
    ok = by_concern(driver_statuses(driver()))
    assert set(ok) == {"source", "samples", "gyro range"} and worst(ok.values()) == Level.OK
    assert ok["samples"].value("sample rate (Hz)") == "1000"
    idle = by_concern(driver_statuses(driver(recording=(), expected_rate_hz=math.nan, since_sample_s=50.0)))
    assert idle["samples"].level == Level.OK and idle["samples"].message.startswith("idle")
    assert by_concern(driver_statuses(driver(since_sample_s=1.0)))["samples"].level == Level.WARN
    assert by_concern(driver_statuses(driver(since_sample_s=3.0)))["samples"].level == Level.ERROR
    slow = by_concern(driver_statuses(driver(measured_rate_hz=850.0)))["samples"]
    assert slow.level == Level.WARN and "expected 1000 Hz" in slow.message
    assert by_concern(driver_statuses(driver(samples_missing=3)))["samples"].level == Level.WARN
    late = by_concern(driver_statuses(driver(behind_s=1.2)))["samples"]
    assert late.level == Level.WARN and late.message == "samples late: 1.2 s behind the rate"
    assert by_concern(driver_statuses(driver(behind_s=0.3)))["samples"].level == Level.OK
    clipped = by_concern(driver_statuses(driver(range_rad_s=5.0, clipped=2)))["gyro range"]
    assert clipped.level == Level.WARN and clipped.message == "2 sample(s) clipped"
    assert by_concern(driver_statuses(driver(source_errors=1)))["source"].level == Level.ERROR


def test_fitter_parameter_model_recorder_levels() -> None:
    fitter = FitterHealth(1, 0, 700, 1000, 50_000_000, 3, 12.0, 0)
    assert worst(fitter_statuses(fitter)) == Level.OK
    for buffered, expected in ((800, Level.WARN), (1000, Level.ERROR)):
        full = dataclasses.replace(fitter, buffered_samples=buffered)
        assert by_concern(fitter_statuses(full))["buffer"].level == expected
    assert by_concern(fitter_statuses(dataclasses.replace(fitter, foreign_batches=2)))["fits"].level == Level.WARN

    params = ParameterHealth("Browser", True, False, 10, 13, ("TtB1", "TtB2", "TtB3"), ())
    (incomplete,) = parameter_statuses(params)
    assert incomplete.level == Level.WARN and incomplete.value("missing periods") == "TtB1, TtB2, TtB3"
    complete = dataclasses.replace(params, complete=True, periods=13, missing_periods=())
    assert parameter_statuses(complete)[0].level == Level.OK
    assert parameter_statuses(dataclasses.replace(params, error="singular"))[0].level == Level.ERROR

    waiting = ModelHealth("", 0, math.nan, math.nan, math.inf, 0, math.nan)
    assert [s.level for s in model_statuses(waiting)] == [Level.WARN, Level.OK]
    assert model_statuses(dataclasses.replace(waiting, bicycle="Browser", models=1))[0].level == Level.OK

    rec = RecorderHealth("bag", 1_000_000, 40, 0, 0.2, 10**10, 500 * 10**6)
    assert worst(recorder_statuses(rec)) == Level.OK
    assert by_concern(recorder_statuses(dataclasses.replace(rec, free_bytes=10**8)))["disk"].level == Level.WARN
    failed = by_concern(recorder_statuses(dataclasses.replace(rec, failed="No space left on device")))["bag"]
    assert failed.level == Level.ERROR and "No space left" in failed.message


@dataclasses.dataclass
class KeyValue:
    key: str = ""
    value: str = ""


@dataclasses.dataclass
class DiagnosticStatus:  # as rosbags holds it: level an int
    level: int = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: list[Any] = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class DiagnosticArray:
    status: list[Any] = dataclasses.field(default_factory=list)


def test_diagnostic_array_round_trip_rclpy_and_plain() -> None:
    from diagnostic_msgs import msg as diag

    statuses = driver_statuses(driver(since_sample_s=1.0, range_rad_s=5.0, clipped=1))
    for array, status, kv in ((diag.DiagnosticArray(), diag.DiagnosticStatus, diag.KeyValue),
                              (DiagnosticArray(), DiagnosticStatus, KeyValue)):  # fmt: skip
        assert statuses_from_msg(fill_diagnostic_array(array, statuses, status, kv)) == statuses
    bad = DiagnosticArray([DiagnosticStatus(level=7, name="driver: samples")])
    with pytest.raises(MessageError, match="'driver: samples': level 7 is not 0..3"):
        statuses_from_msg(bad)


def test_a_paused_recorder_warns_with_what_it_did_not_record() -> None:
    from bike_rig.pipeline.health import RecorderHealth, recorder_statuses

    h = RecorderHealth("bag", 10, 5, 0, 1.0, 10**10, 10**6, "", paused=True, dropped_paused=7)
    bag, _ = recorder_statuses(h)
    assert bag.level is Level.WARN and "7 message(s)" in bag.message
    assert recorder_statuses(RecorderHealth("bag", 10, 5, 0, 1.0, 10**10, 10**6))[0].level is Level.OK
