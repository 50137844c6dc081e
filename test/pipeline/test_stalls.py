"""The stall watch without ROS: heartbeats and input-lag statuses in, one line per change of a node's standing out."""

from __future__ import annotations

from bike_rig.cli.run_cmd import HEARD_S
from bike_rig.pipeline.diagnostics import Level, Status
from bike_rig.pipeline.health import InputLag, input_lag_statuses
from bike_rig.pipeline.stalls import NEVER_HEARD_S, RESUMED_S, SILENT_S, StallWatch, Standing
from test.support.fakes import ManualClock


def array(node: str, lag_s: float | None = None) -> list[Status]:
    """One ``/diagnostics`` array of ``node``: a status, and its input lag when given, s."""
    out = [Status.of(node, "fits", Level.OK, "fine")]
    if lag_s is not None:
        out += input_lag_statuses(InputLag(lag_s, lag_s, 10), node)
    return out


def beat(watch: StallWatch, clock: ManualClock, node: str, seconds: int, lag_s: float | None = None) -> list[str]:
    """``node`` publishes once a second for ``seconds``; every line the watch says meanwhile."""
    lines = []
    for _ in range(seconds):
        clock.now += 1.0
        watch.heard(array(node, lag_s))
        lines += [c.text for c in watch.check()]
    return lines


def wait(watch: StallWatch, clock: ManualClock, seconds: float, ended: tuple[str, ...] = ()) -> list[str]:
    """Nothing arrives for ``seconds`` (checked every 0.1 s); every line said meanwhile."""
    lines = []
    for _ in range(round(seconds * 10)):
        clock.now += 0.1
        lines += [c.text for c in watch.check(ended)]
    return lines


def test_a_stalled_node_is_said_once_and_caught_up_once_it_publishes_again() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(clock=clock)
    assert beat(watch, clock, "fitter", 5, lag_s=0.01) == []  # every second: nothing to say
    assert wait(watch, clock, SILENT_S - 0.2) == []
    lines = wait(watch, clock, 10.0)  # SIGSTOP: one line, not one a second
    assert lines == ["fitter silent for 4 s (stalled?): results will follow"]
    assert watch.troubled() == {"fitter": Standing.SILENT}
    assert watch.troubles() == ["fitter silent for 14 s"]
    # SIGCONT: its first arrays are published before it has handled its backlog: not caught up yet
    clock.now += 1.0
    for _ in range(2):  # (an overdue timer: two arrays at once)
        watch.heard(array("fitter", 0.01))
    assert watch.check() == []
    assert watch.troubles() == ["fitter catching up after 15 s"]  # (silent from its last array to this one)
    assert beat(watch, clock, "fitter", round(RESUMED_S) - 1, lag_s=0.02) == []
    assert beat(watch, clock, "fitter", 1, lag_s=0.02) == ["fitter caught up"]  # on time for RESUMED_S
    assert watch.troubled() == {} and beat(watch, clock, "fitter", 3, lag_s=0.01) == []


def test_a_node_behind_its_input_is_said_once_until_it_has_caught_up() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(clock=clock)
    beat(watch, clock, "fitter", 2, lag_s=0.01)
    clock.now += 1.0
    watch.heard(array("fitter", 20.4))
    (change,) = watch.check()
    assert (change.node, change.standing, change.level) == ("fitter", Standing.BEHIND, Level.WARN)
    assert change.text == "fitter 20 s behind: results will follow" and change.seconds == 20.4
    assert beat(watch, clock, "fitter", 3, lag_s=12.0) == []  # still behind, by less: no new line
    assert watch.troubles() == ["fitter 12 s behind"]
    assert beat(watch, clock, "fitter", 1, lag_s=0.1) == []  # one array on time is not yet caught up
    assert beat(watch, clock, "fitter", 1, lag_s=3.0) == []  # (behind again: still the same standing)
    clock.now += 1.0
    watch.heard(array("fitter", 0.1))
    watch.heard(array("fitter", 0.1))  # two at once: not yet
    assert watch.check() == []
    assert beat(watch, clock, "fitter", 1, lag_s=0.1) == ["fitter caught up"]


def test_a_stalled_node_back_with_a_backlog_is_behind_then_caught_up() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(clock=clock)
    beat(watch, clock, "parameter", 2, lag_s=0.01)
    assert wait(watch, clock, 10.0) == ["parameter silent for 4 s (stalled?): results will follow"]
    assert beat(watch, clock, "parameter", 1, lag_s=10.3) == ["parameter 10 s behind: results will follow"]
    assert watch.troubles() == ["parameter 10 s behind"]
    assert beat(watch, clock, "parameter", 1, lag_s=0.05) == []  # (its backlog reached it: as after a lag)
    assert watch.troubles() == ["parameter catching up after 12 s"]
    clock.now += 1.0
    watch.heard(array("parameter", 0.05))
    (change,) = watch.check()
    assert (change.text, change.standing, change.level) == ("parameter caught up", Standing.OK, Level.OK)
    assert change.seconds > 10.0  # behind or silent since it stopped


def test_a_node_behind_that_stalls_is_said_silent_and_a_node_without_lag_status_is_followed_too() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(clock=clock)
    beat(watch, clock, "recorder", 1)  # (no input lag status: not late)
    assert beat(watch, clock, "model", 1, lag_s=5.0) == ["model 5 s behind: results will follow"]
    lines = wait(watch, clock, 5.0)
    assert lines == [
        "recorder silent for 4 s (stalled?): results will follow",
        "model silent for 4 s (stalled?): results will follow",
    ]


def test_an_ended_or_forgotten_node_is_gone_not_stalled_and_other_nodes_are_not_followed() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(nodes={"driver", "fitter"}, clock=clock)
    beat(watch, clock, "driver", 2)
    beat(watch, clock, "fitter", 2)
    beat(watch, clock, "foxglove", 2)  # not one of the graph's nodes
    assert watch.longest_silence() == 4.0  # (the driver's last array: before the fitter's and foxglove's)
    assert wait(watch, clock, 10.0, ended=("driver",)) == ["fitter silent for 4 s (stalled?): results will follow"]
    watch.forget("fitter")  # restarted: its new process starts afresh
    assert watch.troubled() == {}
    assert wait(watch, clock, 10.0) == []
    assert beat(watch, clock, "fitter", 1, lag_s=0.0) == []  # a restarted node first seen on time: nothing


def test_an_expected_node_stalled_before_its_first_heartbeat_is_said_and_waited_for() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(nodes={"fitter", "parameter", "bridge"}, clock=clock, expected={"fitter", "parameter"})
    assert beat(watch, clock, "fitter", round(NEVER_HEARD_S) - 2) == []  # (still being discovered: quiet)
    assert watch.longest_silence() >= HEARD_S  # (a give-up must wait for it)
    lines = beat(watch, clock, "fitter", 4)
    assert lines == [f"parameter silent for {NEVER_HEARD_S:.0f} s (stalled?): results will follow"]
    assert watch.troubled() == {"parameter": Standing.SILENT}  # ("bridge" has no heartbeat: never said)
    watch.heard(array("parameter"))
    assert watch.check() == []  # (back: caught up once on time for long enough)
    assert "parameter caught up" in beat(watch, clock, "parameter", round(RESUMED_S) + 1)


def test_an_expected_node_whose_process_ended_before_it_was_heard_is_gone_not_silent() -> None:
    clock = ManualClock(1000.0)
    watch = StallWatch(clock=clock, expected={"fitter", "parameter"})
    beat(watch, clock, "fitter", 2)
    lines = wait(watch, clock, NEVER_HEARD_S + 1, ended=("parameter",))
    assert lines == ["fitter silent for 4 s (stalled?): results will follow"]
    assert "parameter" not in watch.troubled()
