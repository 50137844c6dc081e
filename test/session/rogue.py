"""A rogue publisher on the rig's domain, for the session tests (never collected: no ``test_`` prefix).

    python rogue.py TRIAL_ID

Waits until every reader of the session subscribes (``MATCHED``: the fitter or parameter
node, the recorder and the console), then on ``GO`` from
stdin publishes, from its own process: START events of 5,000 unknown trials, a batch of NaN at
index 0 of ``TRIAL_ID`` (the driver's next trial), a STOP of ``TRIAL_ID`` after 100 samples,
a 20,000-sample batch, and a usable-looking period estimate of 1e308 s for ``TcR1``; prints
``DONE`` once every subscriber has acknowledged them, and spins until SIGTERM.
"""

from __future__ import annotations

import array
import importlib
import sys
import time
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node

from bike_rig.config.topics import GYRO, PERIODS, TRIAL_EVENTS
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")


def _event(kind: int, trial_id: str, count: int = 0) -> Any:
    m = msgs.TrialEvent()
    m.kind, m.trial_id, m.measurement_key = kind, trial_id, "TcR1"
    m.part, m.pendulum, m.repeat, m.sample_rate_hz, m.sample_count = "rear_wheel", "compound", 1, 1000.0, count
    return m


def _batch(trial_id: str, first: int, values: list[float]) -> Any:
    m = msgs.GyroBatch()
    m.trial_id, m.first_index, m.sample_rate_hz = trial_id, first, 1000.0
    m.rates = array.array("d", values)
    return m


def main() -> int:
    trial_id = sys.argv[1]
    rclpy.init()
    node = Node("rogue")
    events = node.create_publisher(msgs.TrialEvent, TRIAL_EVENTS.name, profile(TRIAL_EVENTS))
    gyro = node.create_publisher(msgs.GyroBatch, GYRO.name, profile(GYRO))
    periods = node.create_publisher(msgs.PeriodEstimate, PERIODS.name, profile(PERIODS))
    deadline = time.monotonic() + 60
    # every reader the session has: fitter or parameter node, recorder and console (a transient-local
    # reader matched late would get the junk only at the next heartbeat)
    while min(p.get_subscription_count() for p in (events, gyro, periods)) < 3 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("MATCHED", flush=True)
    sys.stdin.readline()  # GO
    for i in range(5000):
        events.publish(_event(msgs.TrialEvent.START, f"junk{i}"))
    gyro.publish(_batch(trial_id, 0, [float("nan")] * 50))
    events.publish(_event(msgs.TrialEvent.STOP, trial_id, 100))
    gyro.publish(_batch("junk0", 0, [0.1] * 20_000))
    est = msgs.PeriodEstimate()
    est.trial_id, est.measurement_key, est.valid = "rogue_t1", "TcR1", True
    est.period, est.period_sigma, est.n_samples, est.n_expected, est.r2 = 1e308, 1e-4, 30000, 30000, 0.999
    est.window_stop = 30000
    periods.publish(est)
    for p in (events, gyro, periods):
        p.wait_for_all_acked(Duration(seconds=20))
    print("DONE", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
