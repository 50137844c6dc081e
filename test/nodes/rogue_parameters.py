"""A foreign process publishing a parameter set on the rig's domain (never collected: no ``test_`` prefix).

    python rogue_parameters.py SUBSCRIBERS

Its node is ``rogue``. Waits until ``SUBSCRIBERS`` readers of ``/bike_rig/parameters`` have
matched, publishes one complete ``BenchmarkParameters``: the benchmark bicycle named ``Rogue``
with IBxx = -9.2 kg m² (:data:`ROGUE_STAMP_NS`), prints ``DONE`` once every reader has
acknowledged it, and spins until SIGINT/SIGTERM.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node

from bike_rig.config.paths import config_file
from bike_rig.config.topics import PARAMETERS
from bike_rig.core.benchmark import ParameterSet
from bike_rig.core.loader import load_input
from bike_rig.ros.qos import profile
from test.support.standin import ROGUE_STAMP_NS, msgs, parameter_message


def rogue_message() -> Any:
    """The rogue's set: the benchmark bicycle as ``Rogue``, IBxx = -9.2 kg m²."""
    ps = load_input(config_file("bicycles/benchmark.yaml"))
    assert isinstance(ps, ParameterSet)
    return parameter_message(ps, ROGUE_STAMP_NS, "Rogue", {"IBxx": -9.2})


def main() -> int:
    readers = int(sys.argv[1])
    rclpy.init()
    node = Node("rogue")
    pub = node.create_publisher(msgs.BenchmarkParameters, PARAMETERS.name, profile(PARAMETERS))
    deadline = time.monotonic() + 60
    while pub.get_subscription_count() < readers and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("MATCHED", pub.get_subscription_count(), flush=True)
    pub.publish(rogue_message())
    pub.wait_for_all_acked(Duration(seconds=20))
    print("DONE", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
