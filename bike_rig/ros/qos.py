"""rclpy QoS profiles of the plain :class:`bike_rig.config.topics.QosSpec` (REP-2003).

Next to :mod:`bike_rig.ros.env`: everything that creates publishers or subscriptions (the nodes,
the bag republisher, the demo's monitor, test probes) builds its profiles here, from the topic
contract in :mod:`bike_rig.config.topics`. Importing this module imports rclpy.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..config.topics import QosSpec, Topic

__all__ = ["profile"]


def profile(spec: QosSpec | Topic) -> QoSProfile:
    """The rclpy profile of a topic or QoS spec.

    Args:
        spec: A topic of the contract (its ``qos`` is used) or a QoS spec.

    Returns:
        KEEP_LAST of the spec's depth, reliable or best effort, transient-local or volatile.
    """
    q = spec.qos if isinstance(spec, Topic) else spec
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=q.depth,
        reliability=ReliabilityPolicy.RELIABLE if q.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if q.transient_local else DurabilityPolicy.VOLATILE,
    )
