"""Publisher and subscriber processes of bike_rig_msgs/GyroBatch, for the smoke test.

Run as a script, never imported by pytest's collection (no ``test_`` prefix)::

    python gyro_nodes.py sub TOPIC
    python gyro_nodes.py pub TOPIC BATCHES_JSON

Both print one line per event on stdout (``<WORD> <json>``, flushed) and spin until they are
stopped with SIGINT or SIGTERM, then exit 0:

* ``ENV {...}``: the process's ROS environment and the domain id rclpy actually uses.
* ``MATCHED {"count": n}``: the other side has been discovered (publisher: a subscription
  matched; subscriber: a publisher matched).
* subscriber: ``MSG {...}`` for every GyroBatch received, as a dict (see ``batch_to_dict``).
* publisher: waits for a ``GO`` line on stdin after its match (the test sends it once the
  subscriber has matched too, so no sample can be written before both ends know each other),
  publishes every batch of BATCHES_JSON in order, then ``PUBLISHED {"count": n}``.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from bike_rig_msgs.msg import GyroBatch

# Self-imposed limit on the wait for a match, so a process never waits forever on its own.
MATCH_TIMEOUT_S = 60.0

QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


def report(word: str, payload: Any = None) -> None:
    """Print one event line for the test to read."""
    print(word if payload is None else f"{word} {json.dumps(payload)}", flush=True)


def batch_to_dict(msg: Any) -> dict[str, Any]:
    """A GyroBatch as plain JSON-able data (floats round-trip exactly through json)."""
    return {
        "stamp": [msg.header.stamp.sec, msg.header.stamp.nanosec],
        "frame_id": msg.header.frame_id,
        "trial_id": msg.trial_id,
        "sample_rate_hz": msg.sample_rate_hz,
        "rates": [float(x) for x in msg.rates],
        "raw_volts": [float(x) for x in msg.raw_volts],
    }


def dict_to_batch(data: dict[str, Any]) -> Any:
    """The inverse of batch_to_dict."""
    msg = GyroBatch()
    msg.header.stamp.sec, msg.header.stamp.nanosec = data["stamp"]
    msg.header.frame_id = data["frame_id"]
    msg.trial_id = data["trial_id"]
    msg.sample_rate_hz = data["sample_rate_hz"]
    msg.rates = data["rates"]
    msg.raw_volts = data["raw_volts"]
    return msg


def report_env() -> None:
    """Report the ROS variables this process runs with and the domain rclpy uses."""
    names = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION")
    env: dict[str, Any] = {name: os.environ.get(name) for name in names}
    env["context_domain_id"] = rclpy.get_default_context().get_domain_id()
    env["rmw"] = rclpy.get_rmw_implementation_identifier()
    report("ENV", env)


def wait_until(node: Node, condition: Any, what: str) -> None:
    """Spin the node until condition() is true; exit 3 after MATCH_TIMEOUT_S."""
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            print(f"timed out waiting for {what}", file=sys.stderr, flush=True)
            sys.exit(3)
        rclpy.spin_once(node, timeout_sec=0.05)


def run_subscriber(node: Node, topic: str) -> None:
    """Report every batch received on topic."""
    sub = node.create_subscription(GyroBatch, topic, lambda msg: report("MSG", batch_to_dict(msg)), QOS)
    wait_until(node, lambda: sub.get_publisher_count() > 0, "a publisher")
    report("MATCHED", {"count": sub.get_publisher_count()})
    rclpy.spin(node)


def run_publisher(node: Node, topic: str, batches_file: str) -> None:
    """Publish the batches of batches_file once the test says GO."""
    with open(batches_file, encoding="utf-8") as f:
        batches = [dict_to_batch(b) for b in json.load(f)]
    pub = node.create_publisher(GyroBatch, topic, QOS)
    wait_until(node, lambda: pub.get_subscription_count() > 0, "a subscription")
    report("MATCHED", {"count": pub.get_subscription_count()})

    go = threading.Event()

    def read_stdin() -> None:
        for line in sys.stdin:
            if line.strip() == "GO":
                go.set()
                return

    threading.Thread(target=read_stdin, daemon=True).start()
    wait_until(node, go.is_set, "GO on stdin")
    for msg in batches:
        pub.publish(msg)
    # (no wait_for_all_acked: acks follow Fast DDS's 3 s heartbeat period; the subscriber's
    # report is the proof of delivery)
    report("PUBLISHED", {"count": len(batches)})
    rclpy.spin(node)


def main(argv: list[str]) -> int:
    """Run one side; stop cleanly on SIGINT/SIGTERM."""
    role, topic = argv[0], argv[1]
    rclpy.init()
    node = Node(f"gyro_smoke_{role}")
    try:
        report_env()
        if role == "sub":
            run_subscriber(node, topic)
        elif role == "pub":
            run_publisher(node, topic, argv[2])
        else:
            print(f"unknown role {role!r}", file=sys.stderr)
            return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
