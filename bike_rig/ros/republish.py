"""Play a recorded session's raw stream back into a live ROS graph (rclpy).

The recorded CDR bytes of the rig's inputs (gyro batches, trial events, static readings by
default) are published as they are (``Publisher.publish(bytes)``), each topic with its
contract QoS, in log-time order and with the original spacing divided by ``rate_scale``; the
header stamps inside the messages are the original ones. A fitter, parameter and model node
started against the graph then recompute the session live (the recorder can record it again).

The process gets the project's ROS environment (:mod:`bike_rig.ros.env`: LOCALHOST discovery,
the run's domain id). SIGINT or SIGTERM stops the playback early. Run through
``bike-rig replay BAG --republish`` or ``python -m bike_rig.ros.republish BAG``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

from ..bag.errors import NoRigTopicsError
from ..bag.reader import BagReader
from ..config import topics
from ..core.errors import BikeRigError
from .env import ros_environment

__all__ = ["DEFAULT_TOPICS", "RepublishStats", "main", "republish"]

#: What is played back by default: the rig's inputs, not the results the nodes recompute.
DEFAULT_TOPICS: tuple[topics.Topic, ...] = (topics.STATIC_READINGS, topics.TRIAL_EVENTS, topics.GYRO)
LINGER_S = 1.0
"""Time the publishers stay up after the last message, so that reliable delivery completes."""


@dataclass
class RepublishStats:
    """What a playback did.

    Attributes:
        bag: The bag, as given.
        counts: Messages published per topic.
        bag_span_s: Log-time span of the messages played, s.
        wall_s: Wall time of the playback, s.
        rate_scale: Speed factor.
        subscribers: Subscriptions matched per topic when playback began.
        interrupted: Stopped early by a signal.
        max_lag_s: Largest delay of a publication behind its schedule, s.
    """

    bag: str
    counts: dict[str, int] = field(default_factory=dict)
    bag_span_s: float = 0.0
    wall_s: float = 0.0
    rate_scale: float = 1.0
    subscribers: dict[str, int] = field(default_factory=dict)
    interrupted: bool = False
    max_lag_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON."""
        return dict(self.__dict__)

    def describe(self) -> str:
        """A few lines for the terminal."""
        total = sum(self.counts.values())
        how = "interrupted after" if self.interrupted else "published"
        lines = [
            f"{how} {total} messages of {self.bag} in {self.wall_s:.2f} s "
            f"(bag span {self.bag_span_s:.2f} s, rate scale {self.rate_scale:g}, "
            f"largest lag {1e3 * self.max_lag_s:.1f} ms)"
        ]
        lines += [
            f"  {name}: {n} (subscribers at start: {self.subscribers.get(name, 0)})" for name, n in self.counts.items()
        ]
        return "\n".join(lines)


def _message_class(msgtype: str) -> Any:
    package, _, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def _chosen_topics(reader: BagReader, which: Sequence[topics.Topic]) -> list[topics.Topic]:
    """The topics of ``which`` the bag has messages on, each checked to hold the expected type.

    Raises:
        NoRigTopicsError: The bag holds none of them.
        ReplayError: A topic holds a type that is not the rig's, or was recorded with another definition.
    """
    chosen = [t for t in which if t.name in reader.topics and reader.topics[t.name].count]
    if not chosen:
        names = ", ".join(t.name for t in which)
        raise NoRigTopicsError(reader.shown, f"has no messages on {names}: nothing to republish")
    for t in chosen:
        reader.check_type(t.name)
    return chosen


def _wait_for_subscribers(node: Any, pubs: dict[str, Any], wait_s: float, stop: dict[str, bool]) -> None:
    """Spin until every publisher has a subscription, ``wait_s`` [s] have passed, or a stop is requested."""
    import rclpy

    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline and not stop["requested"]:
        if all(p.get_subscription_count() > 0 for p in pubs.values()):
            break
        rclpy.spin_once(node, timeout_sec=0.02)


def _play(
    reader: BagReader, pubs: dict[str, Any], rate_scale: float, stats: RepublishStats, stop: dict[str, bool]
) -> None:
    """Publish the messages in log-time order on their original schedule divided by ``rate_scale``.

    Fills ``stats``: counts, interruption, largest lag [s], wall time [s] and bag span [s].
    """
    wall0 = time.monotonic()
    first: int | None = None
    last = 0
    for msg in reader.messages(list(pubs)):
        if stop["requested"]:
            stats.interrupted = True
            break
        first = msg.log_time if first is None else first
        due = wall0 + (msg.log_time - first) / 1e9 / rate_scale
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            stats.max_lag_s = max(stats.max_lag_s, -delay)
        pubs[msg.topic].publish(msg.data)
        stats.counts[msg.topic] += 1
        last = msg.log_time
    stats.wall_s = time.monotonic() - wall0
    stats.bag_span_s = 0.0 if first is None else (last - first) / 1e9


def _linger(node: Any, stop: dict[str, bool]) -> None:
    """Keep the node spinning for :data:`LINGER_S` after the last message, unless a stop is requested."""
    import rclpy

    linger = time.monotonic() + LINGER_S
    while time.monotonic() < linger and not stop["requested"]:
        rclpy.spin_once(node, timeout_sec=0.05)


def republish(
    bag: str | Path,
    rate_scale: float = 1.0,
    wait_s: float = 5.0,
    which: Sequence[topics.Topic] = DEFAULT_TOPICS,
    args: Sequence[str] | None = None,
) -> RepublishStats:
    """Publish a bag's raw messages into the live graph with their original timing scaled.

    Args:
        bag: The bag.
        rate_scale: Speed factor (2: twice as fast), > 0.
        wait_s: Wait up to this long for every topic to have a subscriber before starting.
        which: The topics to play (those the bag holds).
        args: rclpy arguments (``--ros-args ...``).

    Raises:
        BagError: The bag cannot be read, or holds none of the topics.
    """
    import rclpy
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    from .qos import profile

    env = ros_environment(os.environ)
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
        os.environ[key] = env[key]
    stats = RepublishStats(str(bag), rate_scale=float(rate_scale))
    with BagReader(bag) as reader:
        chosen = _chosen_topics(reader, which)
        stop = {"requested": False}

        def request_stop(signum: int, _frame: FrameType | None) -> None:
            stop["requested"] = True

        previous = {s: signal.signal(s, request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
        node: Node | None = None
        try:
            rclpy.init(args=list(args or []), signal_handler_options=SignalHandlerOptions.NO)
            node = Node("bag_republisher")
            pubs = {t.name: node.create_publisher(_message_class(t.type), t.name, profile(t)) for t in chosen}
            stats.counts = {t.name: 0 for t in chosen}
            _wait_for_subscribers(node, pubs, wait_s, stop)
            stats.subscribers = {name: p.get_subscription_count() for name, p in pubs.items()}
            _play(reader, pubs, rate_scale, stats, stop)
            _linger(node, stop)
        finally:
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
            for s, handler in previous.items():
                signal.signal(s, handler)
    return stats


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bike_rig.ros.republish BAG [--rate-scale X] [--wait S]``."""
    parser = argparse.ArgumentParser(prog="python -m bike_rig.ros.republish", description=__doc__.split("\n")[0])
    parser.add_argument("bag", metavar="BAG")
    parser.add_argument("--rate-scale", type=float, default=1.0, metavar="X")
    parser.add_argument("--wait", type=float, default=5.0, metavar="S")
    args, ros_args = parser.parse_known_args(argv)
    if not (args.rate_scale > 0 and args.wait >= 0):
        print(f"{parser.prog}: error: --rate-scale must be > 0 and --wait >= 0", file=sys.stderr)
        return 2
    try:
        stats = republish(args.bag, args.rate_scale, args.wait, args=ros_args)
    except BikeRigError as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 2
    print(stats.describe(), flush=True)
    return 130 if stats.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
