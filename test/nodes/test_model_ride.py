"""The model node's ride path as real processes: speed in, latched state space out.

The probe publishes speeds on ``/bike_rig/ride/speed`` (``std_msgs/Float64``) and receives
``/bike_rig/ride/state_space`` (``StateSpaceModel``): A, B and the eigenvalues equal the offline
core's :func:`~bike_rig.pipeline.model.state_space_at` at that speed, a change within the speed
step gives nothing, changes that come faster than the rate limit are published spaced by it
(the latest speed last), and a subscriber started late gets the current model.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.config import topics
from bike_rig.core.benchmark import ComMethod
from bike_rig.core.feedback import load_feedback
from bike_rig.messages import fill_ride_speed, state_space_model_from_msg
from bike_rig.pipeline.model import compute_model, state_space_at, state_space_with_sigma_at
from test.support.nodes import ASSIST, STAMP_NS, offline_set, publish_set, start_node
from test.support.probe import Probe
from test.support.wait import WAIT_TIMEOUT_S

pytestmark = pytest.mark.ros

STEP = 0.5  # m/s
RATE = 2.0  # 1/s
INTERVAL_NS = int(1e9 / RATE)


def stamp_of(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def publish_speed(pub: Any, speed: float) -> None:
    from std_msgs.msg import Float64

    pub.publish(fill_ride_speed(Float64(), speed))


def stream_until(probe: Probe, pub: Any, speed: float, condition: Any, what: str, node: Any) -> None:
    """Publish ``speed`` every 50 ms, as a speed sensor does (best effort), until ``condition()``."""
    deadline = time.monotonic() + WAIT_TIMEOUT_S
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}\n{node.describe()}"
        publish_speed(pub, speed)
        probe.executor.spin_once(timeout_sec=0.05)


def node_saw_speed(node: Any) -> bool:
    return "first ride speed 3 m/s" in node.stderr_path.read_text(encoding="utf-8")


def assert_equals_core(msg: Any, rider: str, feedback: Any) -> None:
    """The message is the offline core's state space (and σ) at its speed, for the node's rider and feedback."""
    ps = offline_set()
    model, _ = compute_model(ps, [0.0], rider)
    expected = state_space_at(model, msg.speed, feedback)
    got = state_space_model_from_msg(msg)
    assert np.array_equal(got.state.a, expected.a) and np.array_equal(got.state.b, expected.b)
    assert np.array_equal(got.state.eigenvalues, expected.eigenvalues)
    assert got.state.labels == expected.labels == ("weave", "weave", "capsize", "caster")
    with_sigma = state_space_with_sigma_at(ps, model, msg.speed, feedback)
    assert np.array_equal(got.a_sigma, with_sigma.a_sigma) and np.array_equal(got.b_sigma, with_sigma.b_sigma)
    assert np.array_equal(got.eigenvalues_sigma_real, with_sigma.eigenvalues_sigma_real, equal_nan=True)
    assert (got.bicycle, got.rider, got.feedback) == ("Browser", rider, "" if feedback is None else feedback.name)
    assert np.all(got.a_sigma[2:] > 0.0) and np.all(got.a_sigma[:2] == 0.0)  # the 0/1 rows are exact


def test_ride_speed_gives_the_latched_state_space_rate_limited_and_stepped(
    probe: Probe, ros_env: dict[str, str], node_env: dict[str, str], tmp_path: Path
) -> None:
    from std_msgs.msg import Float64

    from bike_rig_msgs.msg import StateSpaceModel

    box = probe.listen(topics.RIDE_STATE_SPACE, StateSpaceModel)
    args = (
        "-p",
        f"ride_speed_step:={STEP}",
        "-p",
        f"ride_max_rate:={RATE}",
        "-p",
        "rider:=paper",
        "-p",
        f"feedback:={ASSIST}",
    )
    with start_node("model", "model_ride", node_env, tmp_path, *args) as node:
        speed = probe.publisher(topics.RIDE_SPEED, Float64, matched=True)
        # speeds before any parameter set give nothing; the model follows as soon as a set arrives
        stream_until(probe, speed, 3.0, lambda: node_saw_speed(node), "the node to hear the speed", node)
        assert not box
        publish_set(probe, ComMethod.CENTROID, STAMP_NS)
        stream_until(probe, speed, 3.0, lambda: bool(box), "the first ride state space", node)
        first = box[0]
        assert first.speed == 3.0
        assert_equals_core(first, "paper", load_feedback(ASSIST))

        # within the step: nothing, however long (three intervals) and however often it comes
        deadline = time.monotonic() + 3.0 / RATE
        while time.monotonic() < deadline:
            publish_speed(speed, 3.0 + 0.9 * STEP)
            probe.executor.spin_once(timeout_sec=0.05)
        assert len(box) == 1, [m.speed for m in box]

        # three changes at once: spaced by the rate limit, the latest speed last
        for v in (4.0, 5.0):
            publish_speed(speed, v)
        stream_until(probe, speed, 6.0, lambda: box[-1].speed == 6.0, "the latest speed", node)
        last = box[-1]
        # which of them are published depends on how long each computation takes (one that takes an
        # interval lets 4, 5 and 6 each through); what holds: speeds sent, in the order sent, the
        # latest last, and the node's stamps (the time the rate limit counts from) an interval apart
        later = [m.speed for m in box[1:]]
        assert set(later) <= {4.0, 5.0, 6.0} and later == sorted(set(later)) and later[-1] == 6.0, later
        stamps = [stamp_of(m) for m in box]
        assert all(b - a >= INTERVAL_NS for a, b in zip(stamps, stamps[1:], strict=False)), np.diff(stamps)
        assert_equals_core(last, "paper", load_feedback(ASSIST))

        # latched: a subscriber started now gets the current model
        with Probe(ros_env) as late:
            late.listen(topics.RIDE_STATE_SPACE, StateSpaceModel)
            got = late.wait_message(topics.RIDE_STATE_SPACE, lambda m: True, "the latched state space", [node])
            assert got.speed == 6.0 and stamp_of(got) == stamp_of(last)

        # a new parameter set: the state space at the current speed again
        publish_set(probe, ComMethod.LEAST_SQUARES, STAMP_NS + 1)
        again = probe.wait_message(
            topics.RIDE_STATE_SPACE, lambda m: stamp_of(m) > stamp_of(last), "after a new set", [node]
        )
        assert again.speed == 6.0 and not np.array_equal(np.asarray(again.a), np.asarray(last.a))
        code = node.stop()
    assert code == 0, node.describe()
