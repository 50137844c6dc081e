"""Sends a few oversized gyro batches to the fitter (a helper of bench_fitter_memory.py).

    python big_batches.py SAMPLES COUNT

Waits for the fitter to subscribe (``MATCHED``), then on each ``GO`` from stdin publishes one
batch of ``SAMPLES`` samples of its own trial and prints ``SENT`` once the fitter acknowledged it.
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

from bike_rig.config.topics import GYRO
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")


def main() -> int:
    samples, count = int(sys.argv[1]), int(sys.argv[2])
    rclpy.init()
    node = Node("big_batches")
    gyro = node.create_publisher(msgs.GyroBatch, GYRO.name, profile(GYRO))
    deadline = time.monotonic() + 60
    while gyro.get_subscription_count() < 1 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("MATCHED", flush=True)
    for i in range(count):
        sys.stdin.readline()  # GO
        m = msgs.GyroBatch()
        m.trial_id, m.first_index, m.sample_rate_hz = f"big{i}", 0, 1000.0
        m.rates = array.array("d", bytes(8 * samples))
        gyro.publish(m)
        gyro.wait_for_all_acked(Duration(seconds=30))
        print("SENT", flush=True)
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
