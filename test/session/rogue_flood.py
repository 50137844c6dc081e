"""A rogue flooding the rig's domain while a trial records (never collected: no ``test_`` prefix).

    python rogue_flood.py TRIAL_ID SECONDS RATE_SCALE

Waits until every reader of the session subscribes (``MATCHED``), then on ``GO`` from stdin
publishes for ``SECONDS`` s of wall time, from its own process, ``RATE_SCALE`` times as many
50-sample gyro batches per second as the driver (20 per second at 1 kHz): batches of the
driver's trial ``TRIAL_ID`` with indices going backwards and a wrong sample rate, batches of
its own trial ``flood_t1`` (announced with a START whose stamp goes back in time, its batches'
stamps going backwards too, at 500 Hz while the START said 1 kHz), and TrialEvents with stamps
going backwards. Prints ``DONE n`` (the batches sent) once every subscriber acknowledged them,
and spins until SIGTERM.
"""

from __future__ import annotations

import array
import importlib
import math
import sys
import time
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node

from bike_rig.config.topics import GYRO, TRIAL_EVENTS
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")

#: The driver's batches per second at 1 kHz (50 samples each).
DRIVER_BATCHES_PER_S = 20


def _stamp(msg: Any, ns: int) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(max(ns, 0), 1_000_000_000)


def _event(kind: int, trial_id: str, stamp_ns: int) -> Any:
    m = msgs.TrialEvent()
    m.kind, m.trial_id, m.measurement_key = kind, trial_id, "TcR1"
    m.part, m.pendulum, m.repeat, m.sample_rate_hz = "rear_wheel", "compound", 1, 1000.0
    _stamp(m, stamp_ns)
    return m


def _batch(trial_id: str, first: int, rate_hz: float, stamp_ns: int, k: int) -> Any:
    m = msgs.GyroBatch()
    m.trial_id, m.first_index, m.sample_rate_hz = trial_id, max(first, 0), rate_hz
    m.rates = array.array("d", (0.05 * math.sin(0.01 * (k * 50 + i)) for i in range(50)))
    _stamp(m, stamp_ns)
    return m


def main() -> int:
    trial_id, seconds, scale = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    rclpy.init()
    node = Node("rogue_flood")
    events = node.create_publisher(msgs.TrialEvent, TRIAL_EVENTS.name, profile(TRIAL_EVENTS))
    gyro = node.create_publisher(msgs.GyroBatch, GYRO.name, profile(GYRO))
    deadline = time.monotonic() + 60
    while min(p.get_subscription_count() for p in (events, gyro)) < 3 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("MATCHED", flush=True)
    sys.stdin.readline()  # GO
    now_ns = time.time_ns()
    events.publish(_event(msgs.TrialEvent.START, "flood_t1", now_ns - 3_600_000_000_000))  # an hour back
    period = 1.0 / (DRIVER_BATCHES_PER_S * scale)
    start = time.monotonic()
    sent = 0
    while time.monotonic() - start < seconds:
        back_ns = now_ns - sent * 10_000_000  # every stamp earlier than the one before
        if sent % 2:
            gyro.publish(_batch(trial_id, 100_000 - 50 * sent, 250.0, back_ns, sent))  # the driver's trial
        else:
            gyro.publish(_batch("flood_t1", 50 * sent, 500.0, back_ns, sent))
        if sent % 20 == 0:
            events.publish(
                _event(msgs.TrialEvent.STOP if sent % 40 else msgs.TrialEvent.START, f"flood_e{sent}", back_ns)
            )
        sent += 1
        time.sleep(max(0.0, start + sent * period - time.monotonic()))
    for p in (events, gyro):
        p.wait_for_all_acked(Duration(seconds=30))
    print(f"DONE {sent}", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
