"""The diagnostics updater every node shares: its statuses on ``/diagnostics`` once a second.

A node gives a function that returns its :class:`bike_rig.diagnostics.Status` list (computed
without ROS from its own counters); the updater calls it on a 1 Hz timer and publishes the
``diagnostic_msgs/DiagnosticArray`` (REP-107). A failing status function never stops the node:
its error becomes one ERROR status.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node

from .. import topics
from ..diagnostics import Level, Status
from ..messages.diagnostics import fill_diagnostic_array
from ..rosqos import profile

__all__ = ["DIAGNOSTICS_PERIOD_S", "DiagnosticsUpdater"]

#: Seconds between two arrays (REP-107's usual 1 Hz).
DIAGNOSTICS_PERIOD_S = 1.0

_diag: Any = importlib.import_module("diagnostic_msgs.msg")


class DiagnosticsUpdater:
    """Publishes ``statuses()`` of ``node`` on ``/diagnostics`` every ``period_s``.

    Args:
        node: The node (its clock stamps the arrays; the timer and publisher are its own).
        statuses: Returns the node's statuses now.
        period_s: Seconds between arrays.
    """

    def __init__(
        self, node: Node, statuses: Callable[[], Sequence[Status]], period_s: float = DIAGNOSTICS_PERIOD_S
    ) -> None:
        """Create the publisher and the timer."""
        self._node = node
        self._statuses = statuses
        self.published = 0
        self._pub = node.create_publisher(_diag.DiagnosticArray, topics.DIAGNOSTICS.name, profile(topics.DIAGNOSTICS))
        self._timer = node.create_timer(period_s, self.publish)

    def publish(self) -> None:
        """Publish the node's statuses now (never raises)."""
        try:
            statuses = list(self._statuses())
        except Exception as exc:  # a status function must not take the node down
            statuses = [Status.of(self._node.get_name(), "diagnostics", Level.ERROR, f"status failed: {exc!r}")]
        msg = fill_diagnostic_array(_diag.DiagnosticArray(), statuses, _diag.DiagnosticStatus, _diag.KeyValue)
        msg.header.stamp = self._node.get_clock().now().to_msg()
        self._pub.publish(msg)
        self.published += 1
