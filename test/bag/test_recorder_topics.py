"""What the recorder's ``topics: [all]`` records: every topic of the graph."""

from __future__ import annotations

from bike_rig.config import topics
from bike_rig.ros.nodes.recorder import resolve_topics


def test_all_records_every_topic_of_the_graph_diagnostics_and_fit_details_included() -> None:
    recorded = set(resolve_topics(["all"]))
    declared = {v for v in vars(topics).values() if isinstance(v, topics.Topic)}
    ride = {topics.RIDE_SPEED, topics.RIDE_STATE_SPACE}  # a ride record's, not a session's
    assert recorded == declared - ride
    assert topics.DIAGNOSTICS in recorded and topics.FIT_DETAILS in recorded
    assert resolve_topics(["fit_details", "/diagnostics"]) == (topics.FIT_DETAILS, topics.DIAGNOSTICS)
