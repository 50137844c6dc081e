"""A node that publishes one period estimate (transient-local) and waits: for the recorder's sync test.

Run by the launcher as ``python -m test.bag.late_publisher --ros-args ...`` (never collected:
no ``test_`` prefix). Prints ``PUBLISHED`` once the estimate is published, then spins until
SIGINT/SIGTERM and exits at once: what it holds goes with it.
"""

from __future__ import annotations

import importlib
import sys
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from bike_rig.config.topics import PERIODS
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")


def main() -> int:
    rclpy.init(args=sys.argv)
    node = Node("late")
    pub = node.create_publisher(msgs.PeriodEstimate, PERIODS.name, profile(PERIODS))
    est = msgs.PeriodEstimate()
    est.trial_id, est.measurement_key, est.valid, est.period, est.period_sigma = "late_t1", "TcR1", True, 1.25, 1e-4
    pub.publish(est)
    print("PUBLISHED", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
