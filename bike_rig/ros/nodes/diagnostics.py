"""The diagnostics updater every node shares: its statuses on ``/diagnostics`` once a second.

A node gives a function that returns its :class:`bike_rig.pipeline.diagnostics.Status` list (computed
without ROS from its own counters); the updater calls it on a 1 Hz timer and publishes the
``diagnostic_msgs/DiagnosticArray`` (REP-107). A failing status function never stops the node:
its error becomes one ERROR status.

Each subscription callback also calls :meth:`DiagnosticsUpdater.note_input` with rclpy's message
info: from the first message on, the array holds ``"<node>: input lag"``, WARN while the node
handles messages more than :data:`~bike_rig.pipeline.health.LAG_WARN_S` after they were sent
(:class:`~bike_rig.pipeline.diagnostics.LagMeter`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rclpy.node import Node

from ...config import topics
from ...messages.diagnostics import fill_diagnostic_array
from ...pipeline.diagnostics import LagMeter, Level, Status
from ...pipeline.health import InputLag, input_lag_statuses
from ..qos import profile

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
        #: How far behind its input the node is (fed by :meth:`note_input`).
        self.input_lag = LagMeter()
        self._pub = node.create_publisher(_diag.DiagnosticArray, topics.DIAGNOSTICS.name, profile(topics.DIAGNOSTICS))
        self._timer = node.create_timer(period_s, self.publish)

    def note_input(self, info: Mapping[str, Any] | None) -> None:
        """A subscription callback handles a message now: feed its DDS source time to the lag meter.

        Args:
            info: rclpy's message info (``source_timestamp``: ns since the epoch, the host clock);
                None or without it: nothing is noted. Never raises.
        """
        try:
            self.input_lag.note(int(info.get("source_timestamp") or 0) if info is not None else None)
        except (AttributeError, TypeError, ValueError):  # not rclpy's info: nothing to note
            return

    def publish(self) -> None:
        """Publish the node's statuses now, its input lag from the first message handled (never raises)."""
        try:
            statuses = list(self._statuses())
            meter = self.input_lag
            if meter.handled:
                lag = InputLag(meter.lag(), meter.largest_s, meter.handled)
                statuses += input_lag_statuses(lag, self._node.get_name())
        except Exception as exc:  # a status function must not take the node down
            statuses = [Status.of(self._node.get_name(), "diagnostics", Level.ERROR, f"status failed: {exc!r}")]
        msg = fill_diagnostic_array(_diag.DiagnosticArray(), statuses, _diag.DiagnosticStatus, _diag.KeyValue)
        msg.header.stamp = self._node.get_clock().now().to_msg()
        self._pub.publish(msg)
        self.published += 1
