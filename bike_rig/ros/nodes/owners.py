"""Take each topic only from its owner node's process: a message's publisher checked against the graph.

Every publisher of one process shares its DDS participant (:mod:`bike_rig.ros.nodes.publishers`): the
participant of a message is in rclpy's message info, and the graph's publisher info of its topic
says which nodes publish from that participant. A message is its owner's when one of them is an
owner of the topic (:data:`TOPIC_OWNERS`). Another process on the domain (a second driver, a
rogue) is told apart; a node name is not a secret, so this guards against mistakes and stray
processes, not against a process that takes an owner's name.

:class:`OwnerFilter` holds the messages offered to it and releases them in their order of
arrival, each with its verdict. A message can arrive before discovery tells which node its
process is: it and every message after it wait until the graph says (asked again at most every
:data:`RELOOK_S`), so that nothing overtakes it; after :data:`HOLD_S` it is released as from an
unknown process (not owned). It is ROS-free apart from the graph it is given (an rclpy ``Node``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from ...config import topics
from .publishers import participant, publisher_source

__all__ = ["HOLD_S", "RELOOK_S", "TOPIC_OWNERS", "Graph", "OwnerFilter", "Released"]

#: The nodes that may publish each topic (ROS node names; ``bike-rig replay --republish``'s node
#: stands in for the driver).
TOPIC_OWNERS: Mapping[str, tuple[str, ...]] = {
    topics.TRIAL_EVENTS.name: ("driver", "bag_republisher"),
    topics.GYRO.name: ("driver", "bag_republisher"),
    topics.PERIODS.name: ("fitter",),
    topics.FIT_DETAILS.name: ("fitter",),
    topics.PARAMETERS.name: ("parameter",),
    topics.EIGEN_SWEEP.name: ("model",),
}

#: How often the graph is asked again about a topic's publishers while a message waits, s.
RELOOK_S = 0.05
#: How long a message from a process the graph does not know yet is held before it is released as unknown, s.
HOLD_S = 5.0
#: The node name the graph gives an endpoint whose node it has not discovered yet (rmw_dds_common).
_UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"

T = TypeVar("T")


class Graph(Protocol):
    """What the filter asks of the ROS graph (an rclpy ``Node`` is one)."""

    def get_publishers_info_by_topic(self, topic_name: str) -> Sequence[Any]:
        """The topic's publishers, each with ``node_name`` and ``endpoint_gid``."""
        ...


@dataclass(frozen=True)
class Released(Generic[T]):
    """A message released by :meth:`OwnerFilter.release`, with its verdict.

    Attributes:
        topic: The topic it came on.
        item: What was offered (the message, or a record made from it).
        source: Its publisher's participant, hex ("" when the middleware does not say).
        owned: Whether it came from the process of one of the topic's owners (True too for a
            topic without owners, or a message whose participant is unknown to the middleware).
        nodes: The nodes the graph names for that participant on the topic (empty: not known).
    """

    topic: str
    item: T
    source: str
    owned: bool
    nodes: tuple[str, ...] = ()

    @property
    def publisher(self) -> str:
        """Who published it, in words: ``node 'rogue'``, ``nodes 'a', 'b'`` or ``an unknown node``."""
        if not self.nodes:
            return "an unknown node"
        return ("node " if len(self.nodes) == 1 else "nodes ") + ", ".join(f"'{n}'" for n in self.nodes)


@dataclass(frozen=True)
class _Held(Generic[T]):
    topic: str
    source: str
    item: T
    since: float


class OwnerFilter(Generic[T]):
    """Messages in, each released in order with whether its process is the topic's owner's.

    Args:
        graph: Where the topics' publishers are looked up (the node that subscribes).
        owners: The owner nodes of each topic (default :data:`TOPIC_OWNERS`); a topic not in it
            has no owner: everything on it is owned.
        relook_s: Least time between two look-ups of one topic's publishers, s.
        hold_s: Longest a message from an unknown process is held, s.
        clock: Monotonic time, s.
    """

    def __init__(
        self,
        graph: Graph,
        owners: Mapping[str, Sequence[str]] = TOPIC_OWNERS,
        *,
        relook_s: float = RELOOK_S,
        hold_s: float = HOLD_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Start with nothing held and nothing known of the graph."""
        self._graph = graph
        self._owners = {topic: frozenset(names) for topic, names in owners.items()}
        self._relook_s = relook_s
        self._hold_s = hold_s
        self._clock = clock
        self._nodes: dict[tuple[str, str], set[str]] = {}  # (topic, participant) -> its publishing nodes
        self._looked: dict[str, float] = {}  # topic -> when its publishers were last looked up
        self._held: list[_Held[T]] = []

    @property
    def holding(self) -> bool:
        """Whether messages wait for the graph (call :meth:`release` again within :data:`RELOOK_S`)."""
        return bool(self._held)

    def offer(self, topic: str, info: Any, item: T) -> None:
        """Hold ``item``, which came on ``topic`` with rclpy's message ``info``, until :meth:`release`."""
        self._held.append(_Held(topic, publisher_source(info), item, self._clock()))

    def nodes_of(self, topic: str, source: str) -> tuple[str, ...]:
        """The nodes the graph named, so far, as publishing ``topic`` from participant ``source``."""
        return tuple(sorted(self._nodes.get((topic, source), ())))

    def _look_up(self, topic: str, now: float) -> None:
        if now - self._looked.get(topic, -self._relook_s) < self._relook_s:
            return
        self._looked[topic] = now
        for p in self._graph.get_publishers_info_by_topic(topic):
            if p.node_name and p.node_name != _UNKNOWN_NODE:  # (its node not discovered yet)
                self._nodes.setdefault((topic, participant(bytes(p.endpoint_gid))), set()).add(p.node_name)

    def _verdict(self, topic: str, source: str, now: float) -> bool | None:
        """Whether ``source`` is an owner's process; None while the graph does not know it."""
        owners = self._owners.get(topic)
        if owners is None or not source:
            return True
        known = self._nodes.get((topic, source))
        if known is None or not known & owners:  # (unknown, or not yet every node of the process known)
            self._look_up(topic, now)
            known = self._nodes.get((topic, source))
        return None if known is None else bool(known & owners)

    def release(self) -> list[Released[T]]:
        """The held messages whose process the graph now knows (or that waited :data:`HOLD_S`), in order."""
        now = self._clock()
        out: list[Released[T]] = []
        for k, h in enumerate(self._held):
            verdict = self._verdict(h.topic, h.source, now)
            if verdict is None and now - h.since < self._hold_s:
                self._held = self._held[k:]
                return out
            out.append(Released(h.topic, h.item, h.source, bool(verdict), self.nodes_of(h.topic, h.source)))
        self._held = []
        return out
