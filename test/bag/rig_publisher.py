"""A stand-in for the rig's nodes in recorder tests.

Publishes sample messages of every rig topic with the contract QoS. Run as a script (never
collected: no ``test_`` prefix)::

    PYTHONPATH=<repo> python rig_publisher.py SPEC_JSON

SPEC_JSON: ``{"early": {topic: n}, "live": {topic: n}, "rate_hz": r, "until_stop": bool}``.
Every message is ``test.support.samples.make_message(type, seed_of(topic, k))``; the gyro
batches also get ``first_index = k`` and a header stamp taken just before publishing.

Protocol (one line per event on stdout, ``<WORD> <json>``):

* ``EARLY {...}``: the ``early`` messages are published (before any subscriber exists; the
  transient-local ones must still reach a recorder started afterwards).
* ``MATCHED {...}``: every publisher has a subscription.
* waits for ``GO`` on stdin, then publishes the ``live`` messages round-robin at ``rate_hz``
  (absolute deadlines). With ``until_stop`` it keeps publishing gyro batches until ``STOP``
  arrives on stdin.
* ``PUBLISHED {"counts": {...}, "gyro_stamps": [ns, ...]}``; then spins until SIGINT/SIGTERM.
"""

from __future__ import annotations

import importlib
import json
import sys
import threading
import time
from pathlib import Path
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.serialization import deserialize_message

from bike_rig.config.topics import GYRO, TOPICS
from bike_rig.ros.qos import profile
from test.support.samples import make_message, seed_of, serialize

MATCH_TIMEOUT_S = 60.0
BY_NAME = {t.name: t for t in TOPICS}


def report(word: str, payload: Any) -> None:
    print(f"{word} {json.dumps(payload)}", flush=True)


def rclpy_message(topic: str, k: int) -> Any:
    t = BY_NAME[topic]
    package, _, name = t.type.split("/")
    cls = getattr(importlib.import_module(f"{package}.msg"), name)
    msg = deserialize_message(serialize(make_message(t.type, seed_of(topic, k))), cls)
    if topic == GYRO.name:
        msg.first_index = k
    return msg


def wait_for_match(node: Node, pubs: dict[str, Any]) -> bool:
    """Spin until every publisher has a subscription; False after ``MATCH_TIMEOUT_S`` (reported on stderr)."""
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while not all(p.get_subscription_count() > 0 for p in pubs.values()):
        if time.monotonic() > deadline:
            print("timed out waiting for subscriptions", file=sys.stderr, flush=True)
            return False
        rclpy.spin_once(node, timeout_sec=0.05)
    return True


def publish_one(pub: Any, name: str, k: int) -> int | None:
    """Publish the k-th message of a topic; a gyro batch gets the current time as its stamp, returned [ns]."""
    msg = rclpy_message(name, k)
    now = None
    if name == GYRO.name:
        now = time.time_ns()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
    pub.publish(msg)
    return now


def publish_live(
    spec: dict[str, Any], topics: list[str], pubs: dict[str, Any], stdin_lines: list[str]
) -> tuple[dict[str, int], list[int]]:
    """Publish the ``live`` messages round-robin at ``rate_hz`` (with ``until_stop``: gyro batches until STOP).

    Returns:
        The messages published per topic (the early ones included) and the gyro batches' stamps [ns].
    """
    counts = {name: spec["early"].get(name, 0) for name in topics}
    live = dict(spec["live"])
    stamps: list[int] = []
    period = 1.0 / float(spec["rate_hz"])
    next_time = time.monotonic()
    while any(live.values()) or (spec.get("until_stop") and "STOP" not in stdin_lines):
        for name in topics:
            if live.get(name, 0) <= 0 and not (name == GYRO.name and spec.get("until_stop")):
                continue
            stamp = publish_one(pubs[name], name, counts[name])
            if stamp is not None:
                stamps.append(stamp)
            counts[name] += 1
            live[name] = max(0, live.get(name, 0) - 1)
            next_time += period
            time.sleep(max(0.0, next_time - time.monotonic()))
        if spec.get("until_stop") and "STOP" in stdin_lines:
            break
    return counts, stamps


def main(argv: list[str]) -> int:
    spec = json.loads(Path(argv[0]).read_text())
    rclpy.init()
    node = Node("rig_publisher")
    stdin_lines: list[str] = []
    got_line = threading.Event()

    def read_stdin() -> None:
        for line in sys.stdin:
            stdin_lines.append(line.strip())
            got_line.set()

    threading.Thread(target=read_stdin, daemon=True).start()
    try:
        topics = list(dict.fromkeys([*spec["early"], *spec["live"]]))
        pubs = {
            name: node.create_publisher(type(rclpy_message(name, 0)), name, profile(BY_NAME[name])) for name in topics
        }
        for name, n in spec["early"].items():
            for k in range(n):
                pubs[name].publish(rclpy_message(name, k))
        report("EARLY", spec["early"])
        if not wait_for_match(node, pubs):
            return 3
        report("MATCHED", {name: p.get_subscription_count() for name, p in pubs.items()})
        while "GO" not in stdin_lines:
            got_line.wait(0.1)
            got_line.clear()
        counts, stamps = publish_live(spec, topics, pubs, stdin_lines)
        report("PUBLISHED", {"counts": counts, "gyro_stamps": stamps})
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
