"""OwnerFilter without a ROS graph: a fake graph and clock decide which process each message is from."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from bike_rig.config import topics
from bike_rig.ros.nodes.owners import HOLD_S, RELOOK_S, TOPIC_OWNERS, OwnerFilter, Released
from test.support.fakes import ManualClock

PARAMETERS = topics.PARAMETERS.name
OWNER, ROGUE, LATE = b"\x01" * 12, b"\x02" * 12, b"\x03" * 12


@dataclass
class Endpoint:
    node_name: str
    endpoint_gid: bytes


@dataclass
class FakeGraph:
    """The topics' publishers as the graph would list them; counts the look-ups."""

    publishers: dict[str, list[Endpoint]] = field(default_factory=dict)
    looked: int = 0

    def get_publishers_info_by_topic(self, topic_name: str) -> list[Endpoint]:
        self.looked += 1
        return list(self.publishers.get(topic_name, []))


def info(prefix: bytes) -> dict[str, Any]:
    """The message info rclpy gives for a publisher of the process ``prefix`` (its GUID prefix)."""
    return {"publisher_gid": {"data": prefix + b"\x00\x00\x01\x03" + bytes(8)}}


def graph(*nodes: tuple[bytes, str]) -> FakeGraph:
    return FakeGraph({PARAMETERS: [Endpoint(name, prefix + b"\x00\x00\x02\x03") for prefix, name in nodes]})


def verdicts(released: list[Released[str]]) -> list[tuple[str, bool, tuple[str, ...]]]:
    return [(r.item, r.owned, r.nodes) for r in released]


def test_the_owners_messages_pass_and_another_process_is_told_apart() -> None:
    f: OwnerFilter[str] = OwnerFilter(graph((OWNER, "parameter"), (ROGUE, "rogue")), clock=ManualClock(100.0))
    for item, who in (("a", OWNER), ("b", ROGUE), ("c", OWNER)):
        f.offer(PARAMETERS, info(who), item)
    out = f.release()
    assert verdicts(out) == [("a", True, ("parameter",)), ("b", False, ("rogue",)), ("c", True, ("parameter",))]
    assert out[1].publisher == "node 'rogue'" and out[1].source == ROGUE.hex()
    assert not f.holding and f.release() == []


def test_a_process_with_the_owner_among_its_nodes_is_the_owners() -> None:
    f: OwnerFilter[str] = OwnerFilter(graph((OWNER, "test_probe"), (OWNER, "parameter")), clock=ManualClock(100.0))
    f.offer(PARAMETERS, info(OWNER), "a")
    assert verdicts(f.release()) == [("a", True, ("parameter", "test_probe"))]


def test_a_message_from_an_undiscovered_process_waits_and_nothing_overtakes_it() -> None:
    clock = ManualClock(100.0)
    g = graph((OWNER, "parameter"), (LATE, "_NODE_NAME_UNKNOWN_"))
    f: OwnerFilter[str] = OwnerFilter(g, clock=clock)
    f.offer(PARAMETERS, info(LATE), "late")
    f.offer(PARAMETERS, info(OWNER), "after")
    assert f.release() == [] and f.holding
    looked = g.looked
    assert f.release() == [] and g.looked == looked  # asked again only after RELOOK_S
    clock.now += 2 * RELOOK_S
    g.publishers[PARAMETERS][1] = Endpoint("parameter", LATE + b"\x00\x00\x02\x03")  # discovery names it
    assert verdicts(f.release()) == [("late", True, ("parameter",)), ("after", True, ("parameter",))]
    assert g.looked == looked + 1 and not f.holding


def test_a_message_the_graph_never_names_is_released_as_unknown_after_the_hold() -> None:
    clock = ManualClock(100.0)
    f: OwnerFilter[str] = OwnerFilter(graph((OWNER, "parameter")), clock=clock)
    f.offer(PARAMETERS, info(LATE), "ghost")
    clock.now += HOLD_S - 0.01
    assert f.release() == []
    clock.now += 0.01
    out = f.release()
    assert verdicts(out) == [("ghost", False, ())] and out[0].publisher == "an unknown node"


def test_a_topic_without_owners_and_a_middleware_that_does_not_say_pass_unchecked() -> None:
    g = graph()
    f: OwnerFilter[str] = OwnerFilter(g, clock=ManualClock(100.0))
    f.offer(topics.RIDE_SPEED.name, info(ROGUE), "speed")
    f.offer(PARAMETERS, {}, "no gid")
    assert verdicts(f.release()) == [("speed", True, ()), ("no gid", True, ())] and g.looked == 0


def test_the_owners_are_the_graphs_nodes() -> None:
    assert TOPIC_OWNERS[PARAMETERS] == ("parameter",)
    assert TOPIC_OWNERS[topics.EIGEN_SWEEP.name] == ("model",)
    assert TOPIC_OWNERS[topics.TRIAL_EVENTS.name] == TOPIC_OWNERS[topics.GYRO.name] == ("driver", "bag_republisher")
