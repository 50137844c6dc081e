"""rclpy QoS profiles for the plain :class:`bike_rig.topics.QosSpec`."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..topics import QosSpec, Topic

__all__ = ["profile", "best_effort"]


def profile(spec: QosSpec | Topic) -> QoSProfile:
    """The rclpy profile of a topic or spec."""
    q = spec.qos if isinstance(spec, Topic) else spec
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=q.depth,
        reliability=ReliabilityPolicy.RELIABLE if q.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if q.transient_local else DurabilityPolicy.VOLATILE,
    )


def best_effort(depth: int = 50) -> QoSProfile:
    """Sensor-data QoS for live displays that may miss samples (REP-2003)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )
