"""What the live view in Foxglove shows: the topics the bridge forwards and their schemas.

No rclpy and no Foxglove import: the bridge node (:mod:`bike_rig.ros.nodes.foxglove_bridge`), the
``bike-rig view`` command and the layout's tests share it.

Every topic keeps its ROS name (``/bike_rig/gyro``, ``/diagnostics``...) as the Foxglove
channel's topic, its ROS type as the schema name, the ``ros2msg`` definition text of
:func:`bike_rig.bag.typestore.message_definition` (the one the recorder writes into its MCAP
bags) as the schema, and the message's serialized CDR as it is: a layout made for the live
view opens a recorded bag too, and the other way round.

QoS of the bridge's subscriptions: the contract's (:mod:`bike_rig.config.topics`) for everything but
the gyro batches, which it takes volatile (a bridge started in the middle of a session does
not pull the whole session's transient-local history of up to 50,000 batches: a live view
shows the trace from now on). For the other topics the bridge keeps each one's last
``replay_depth`` messages and sends them to a Foxglove client when it subscribes, so a client
that connects late still sees the trials, periods, parameters and eigenvalues of the session
(the transient-local history plays the same role for ROS subscribers).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

from ..config import topics

__all__ = [
    "DEFAULT_PORT",
    "DIAGNOSTICS",
    "GRAPH_GRACE_S",
    "GraphPresence",
    "LAYOUT_FILE",
    "VIEW_TOPICS",
    "ViewTopic",
    "schema_text",
]

#: Foxglove's default WebSocket port (the app's "Open connection" dialog proposes it).
DEFAULT_PORT = 8765

#: The layout shipped for this view, relative to the config folder (:func:`bike_rig.config.paths.config_dir`).
LAYOUT_FILE = "foxglove/bike_rig_layout.json"

#: REP-107 diagnostics (``diagnostic_msgs/msg/DiagnosticArray``), published by every node.
DIAGNOSTICS = topics.Topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", topics.QosSpec(True, False, 100))


@dataclass(frozen=True)
class ViewTopic:
    """One topic of the live view.

    Attributes:
        topic: Name, ROS type and contract QoS.
        qos: The QoS the bridge subscribes with.
        replay_depth: Messages kept for a Foxglove client that subscribes later (0: none).
    """

    topic: topics.Topic
    qos: topics.QosSpec
    replay_depth: int

    @property
    def name(self) -> str:
        """The ROS topic name, also the Foxglove channel's topic."""
        return self.topic.name

    @property
    def type(self) -> str:
        """The ROS type (``pkg/msg/Name``), also the Foxglove schema's name."""
        return self.topic.type


def _contract(topic: topics.Topic) -> ViewTopic:
    return ViewTopic(topic, topic.qos, topic.qos.depth if topic.qos.transient_local else 0)


#: The topics of the live view: the gyro trace, trial events, periods (and what each fit found),
#: the static readings, parameters, canonical matrices, eigen sweep and the diagnostics.
VIEW_TOPICS: tuple[ViewTopic, ...] = (
    ViewTopic(topics.GYRO, topics.QosSpec(reliable=True, transient_local=False, depth=1000), 0),
    _contract(topics.TRIAL_EVENTS),
    _contract(topics.PERIODS),
    _contract(topics.FIT_DETAILS),
    _contract(topics.STATIC_READINGS),
    _contract(topics.READINGS),
    _contract(topics.PARAMETERS),
    _contract(topics.MATRICES),
    _contract(topics.EIGEN_SWEEP),
    ViewTopic(DIAGNOSTICS, DIAGNOSTICS.qos, 0),
)


def schema_text(msgtype: str) -> str:
    """The ``ros2msg`` schema of a ROS type, as the recorder writes it into MCAP.

    Args:
        msgtype: ``pkg/msg/Name``.

    Raises:
        BagError: The rig's ``.msg`` files cannot be found or parsed.
        KeyError: The type is neither the rig's nor a standard ROS 2 Kilted type.
    """
    from ..bag.typestore import message_definition

    return message_definition(msgtype)


#: Seconds the view waits for discovery before it says that no graph is on its domain.
GRAPH_GRACE_S = 5.0


@dataclass
class GraphPresence:
    """Whether a bike_rig graph is on the view's ROS domain: one line to print when that changes.

    A graph is there when some node publishes one of the rig's topics (any of
    :data:`VIEW_TOPICS` but ``/diagnostics``, which every ROS node may publish).

    Attributes:
        domain_id: The ROS_DOMAIN_ID the view serves.
        grace_s: Seconds of discovery before "no graph" is said.
    """

    domain_id: int
    grace_s: float = GRAPH_GRACE_S
    found: bool | None = field(default=None, init=False)

    def update(self, elapsed_s: float, publishers: Collection[str], nodes: Collection[str]) -> str | None:
        """The text to print, if any, after ``elapsed_s`` s of serving.

        Args:
            elapsed_s: Seconds since the view started.
            publishers: The rig's topics that have a publisher now.
            nodes: The names of the nodes that publish them.
        """
        if publishers:
            if self.found:
                return None
            self.found = True
            named = ", ".join(sorted(nodes)) or "(names not yet discovered)"
            return f"found a bike_rig graph on ROS_DOMAIN_ID={self.domain_id}: nodes {named}"
        if self.found:
            self.found = False
            return (
                f"the bike_rig graph on ROS_DOMAIN_ID={self.domain_id} is gone (no node publishes the rig's "
                "topics); still serving, waiting for the next one"
            )
        if self.found is None and elapsed_s >= self.grace_s:
            self.found = False
            return (
                f"no bike_rig graph found on ROS_DOMAIN_ID={self.domain_id}: no node publishes the rig's topics, "
                "so Foxglove shows empty channels (this view keeps serving and says when a graph appears)\n"
                "  bike-rig run and bike-rig session print their graph's ROS_DOMAIN_ID; "
                "point the view at it: bike-rig view --domain-id N"
            )
        return None
