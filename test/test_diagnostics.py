"""Node health without ROS: level rules, the rate meter, each node's statuses, the message converters."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from bike_rig.messages import MessageError
from bike_rig.messages.diagnostics import fill_diagnostic_array, statuses_from_msg
from bike_rig.pipeline.diagnostics import Level, RateMeter, Status, age_level, level_above, level_below, worst
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
from test.support.fakes import ManualClock


def test_level_rules() -> None:
    assert [level_above(x, 1.0, 2.0) for x in (0.5, 1.0, 1.9, 2.0)] == [Level.OK, Level.WARN, Level.WARN, Level.ERROR]
    assert [level_below(x, 10.0, 0.0) for x in (11.0, 10.0, 0.0)] == [Level.OK, Level.WARN, Level.ERROR]
    assert age_level(math.inf, 1.0, 3.0) == Level.ERROR
    assert worst([]) == Level.OK
    assert worst([Status("a", Level.WARN, "w"), Status("b", Level.STALE, "s")]) == Level.STALE


def test_rate_meter_counts_over_its_window_from_a_restart() -> None:
    clock = ManualClock(100.0)
    meter = RateMeter(2.0, clock)
    assert meter.age() == math.inf and meter.rate() == 0.0
    clock.now += 1.0
    meter.add(500)
    assert meter.rate() == pytest.approx(500.0)  # 500 in the 1 s since the start
    clock.now += 1.0
    meter.add(1000)
    assert meter.rate() == pytest.approx(750.0)  # 1500 in 2 s
    clock.now += 2.5
    assert meter.rate() == pytest.approx(0.0) and meter.age() == pytest.approx(2.5)
    meter.restart()
    clock.now += 0.5
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
    for array, status, kv in (
        (diag.DiagnosticArray(), diag.DiagnosticStatus, diag.KeyValue),
        (DiagnosticArray(), DiagnosticStatus, KeyValue),
    ):
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


# ------------------------------------------------------------------------------- input lag
class NsClock:
    """A host clock, ns since the epoch, moved by hand."""

    def __init__(self) -> None:
        self.ns = 1_700_000_000 * 10**9

    def __call__(self) -> int:
        return self.ns

    def step(self, seconds: float) -> None:
        self.ns += int(seconds * 1e9)


def test_the_lag_meter_reads_the_largest_lag_of_the_last_second_then_clears() -> None:
    from bike_rig.pipeline.diagnostics import LagMeter

    clock = NsClock()
    meter = LagMeter(1.0, clock)
    assert meter.lag() == 0.0 and meter.handled == 0
    meter.note(None)
    meter.note(0)  # no source time: nothing noted
    assert meter.handled == 0
    meter.note(clock.ns - 50_000_000)  # on time: 0.05 s
    assert meter.lag() == pytest.approx(0.05)
    # a stall: the backlog is handled 20 s late, then ever less late as it catches up
    for late_s in (20.0, 19.8, 19.6):
        clock.step(0.1)
        meter.note(clock.ns - int(late_s * 1e9))
    assert meter.lag() == pytest.approx(20.0) and meter.largest_s == pytest.approx(20.0)
    clock.step(0.5)
    meter.note(clock.ns - 10**7)  # caught up: a recent message
    assert meter.lag() == pytest.approx(20.0)  # the late ones are still within the last second
    clock.step(0.75)
    assert meter.lag() == pytest.approx(0.01)  # a second after the last late one: only the recent one
    clock.step(1.0)
    assert meter.lag() == 0.0 and meter.handled == 5  # idle: not behind anything
    meter.note(clock.ns + 3 * 10**9)  # a source clock ahead of ours counts as on time
    assert meter.lag() == 0.0
    with pytest.raises(ValueError, match="> 0 s"):
        LagMeter(0.0)


def test_input_lag_is_ok_below_the_threshold_and_warns_from_it() -> None:
    from bike_rig.pipeline.health import LAG_WARN_S, InputLag, input_lag_statuses

    (ok,) = input_lag_statuses(InputLag(0.012, 0.5, 40), "fitter")
    assert (ok.name, ok.level, ok.message) == ("fitter: input lag", Level.OK, "keeping up: 0.012 s behind its input")
    assert ok.value("lag (s)") == "0.012" and ok.value("messages") == "40"
    (late,) = input_lag_statuses(InputLag(3.2, 3.2, 41), "fitter")
    assert (late.level, late.message) == (Level.WARN, "3 s behind its input")
    assert input_lag_statuses(InputLag(LAG_WARN_S, 3.2, 41), "fitter")[0].level is Level.WARN
    assert input_lag_statuses(InputLag(0.99 * LAG_WARN_S, 3.2, 41), "fitter")[0].level is Level.OK


class _FakeNode:
    """What the diagnostics updater needs of an rclpy node (no ROS runtime)."""

    def __init__(self) -> None:
        self.arrays: list[Any] = []

    def create_publisher(self, *_args: Any) -> Any:
        return type("Pub", (), {"publish": lambda _self, msg: self.arrays.append(msg)})()

    def create_timer(self, *_args: Any) -> None:
        return None

    def get_name(self) -> str:
        return "parameter"

    def get_clock(self) -> Any:
        from builtin_interfaces.msg import Time

        now = type("Now", (), {"to_msg": lambda _self: Time()})()
        return type("Clock", (), {"now": lambda _self: now})()


def test_the_updater_adds_the_input_lag_from_the_first_message_noted() -> None:
    from bike_rig.pipeline.diagnostics import LagMeter
    from bike_rig.ros.nodes.diagnostics import DiagnosticsUpdater

    node = _FakeNode()
    clock = NsClock()
    updater = DiagnosticsUpdater(node, lambda: [Status.of("parameter", "completeness", Level.OK, "complete")])  # type: ignore[arg-type]
    updater.input_lag = LagMeter(1.0, clock)
    updater.publish()
    assert [s.name for s in statuses_from_msg(node.arrays[-1])] == ["parameter: completeness"]  # no input yet
    updater.note_input(None)
    updater.note_input({"source_timestamp": 0})  # rclpy's info without a source time
    updater.note_input("not an info")  # type: ignore[arg-type]
    updater.publish()
    assert len(statuses_from_msg(node.arrays[-1])) == 1
    updater.note_input({"source_timestamp": clock.ns - 12 * 10**9, "received_timestamp": clock.ns})
    updater.publish()
    lag = statuses_from_msg(node.arrays[-1])[1]
    assert (lag.name, lag.level, lag.message) == ("parameter: input lag", Level.WARN, "12 s behind its input")
    clock.step(1.5)
    updater.note_input({"source_timestamp": clock.ns - 10**6})
    updater.publish()
    assert statuses_from_msg(node.arrays[-1])[1].level is Level.OK


def test_the_health_board_leaves_the_input_lag_to_the_stall_watch() -> None:
    from bike_rig.pipeline.diagnostics import HealthBoard

    board = HealthBoard()
    ok = Status.of("fitter", "fits", Level.OK, "fine")
    assert board.update([ok, Status.of("fitter", "input lag", Level.OK, "keeping up")]) == []
    assert board.update([ok, Status.of("fitter", "input lag", Level.WARN, "20 s behind its input")]) == []
    assert board.node_level("fitter") is Level.WARN and board.line(reasons=False) == "fitter WARN"
    assert board.line(instead={"fitter": "SILENT"}) == "fitter SILENT"
    (change,) = board.update([Status.of("fitter", "fits", Level.WARN, "foreign batches")])
    assert change == ("fitter", Level.WARN, "fits: foreign batches")
