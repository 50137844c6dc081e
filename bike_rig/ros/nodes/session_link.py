"""The operator console's link to the live graph: the run's listener plus the driver's services.

It follows the graph with :class:`~bike_rig.ros.nodes.run_monitor.GraphMonitor` (the listener
``bike-rig run`` uses), asked also for the readings entered and for the gyro batches as records
(reliable but volatile: the live trace needs them contiguous, never the session's whole
history); trial events, period estimates and readings are transient-local, so a console that
joins late gets the session so far. On top it calls the driver's StartTrial/StopTrial services
and publishes the operator's readings on ``/bike_rig/readings``; the monitor also hands on each
``/diagnostics`` array as a :class:`~bike_rig.pipeline.diagnostics.StatusReport`. Everything runs in the
caller's thread: :meth:`SessionLink.events` takes in what is ready, and a service call spins
until its answer (what arrives meanwhile is kept for the next :meth:`~SessionLink.events`).

Implements :class:`bike_rig.session.controller.GraphLink`.
"""

from __future__ import annotations

import importlib
import time
from typing import Any

from ...config import topics
from ...messages import fill_reading_entry
from ...pipeline.readings import ReadingEntry
from ...session.controller import GraphEvent, StartReply
from ...session.plan import TrialItem
from ..qos import profile
from .run_monitor import GraphMonitor

__all__ = ["DISCOVERY_TIMEOUT_S", "SERVICE_TIMEOUT_S", "SessionLink"]

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_srvs: Any = importlib.import_module("bike_rig_msgs.srv")

#: Longest wait for the driver's answer to a start or stop, s (a loaded machine answers in seconds).
SERVICE_TIMEOUT_S = 15.0
#: Longest wait for the driver's services to be discovered, s (first call after the graph starts).
DISCOVERY_TIMEOUT_S = 30.0
#: How long one spin waits while a service call is pending, s.
_CALL_SPIN_S = 0.005

_LIVE = profile(topics.QosSpec(reliable=True, transient_local=False, depth=1000))


class SessionLink:
    """The console's rclpy node: a :class:`GraphMonitor` with the driver's services (module docstring).

    Args:
        node_name: The node's name.
    """

    def __init__(self, node_name: str = "session_console") -> None:
        """Start the listener (LOCALHOST discovery, the environment's domain) and create the clients."""
        self.monitor = GraphMonitor(node_name=node_name, samples=_LIVE, readings=True, diagnostics=True)
        n = self.monitor.node
        self._start: Any = n.create_client(_srvs.StartTrial, topics.START_TRIAL)
        self._stop: Any = n.create_client(_srvs.StopTrial, topics.STOP_TRIAL)
        self._readings = n.create_publisher(_msgs.ReadingEntry, topics.READINGS.name, profile(topics.READINGS))
        self._pending: list[GraphEvent] = []

    # ------------------------------------------------------------------ GraphLink
    def events(self) -> list[GraphEvent]:
        """What arrived since the last call, in arrival order."""
        polled = self.monitor.poll(timeout_s=0.0)
        out = self._pending + polled
        self._pending = []
        return out

    def _call(self, client: Any, request: Any, service: str) -> tuple[Any, str]:
        """The service's answer, or None and why there is none."""
        if not client.wait_for_service(timeout_sec=DISCOVERY_TIMEOUT_S):
            return None, f"the driver's service {service} not found within {DISCOVERY_TIMEOUT_S:g} s (is it running?)"
        future = client.call_async(request)
        deadline = time.monotonic() + SERVICE_TIMEOUT_S
        while not future.done() and time.monotonic() < deadline:
            self._pending += self.monitor.poll(timeout_s=_CALL_SPIN_S)
        if future.done():
            return future.result(), ""
        return None, (
            f"no answer from the driver ({service}) within {SERVICE_TIMEOUT_S:g} s (a busy machine?): "
            "if it acts on the request late, the console follows what it does"
        )

    def start_trial(self, item: TrialItem, duration_s: float) -> StartReply:
        """Ask the driver to start a trial of ``item`` (StartTrial)."""
        m = item.measurement
        req = _srvs.StartTrial.Request()
        req.part, req.pendulum = m.part, m.pendulum
        req.orientation, req.repeat = m.orientation or 0, item.repeat
        req.measurement_key, req.duration_s = item.key, float(duration_s)
        req.note = f"plan item {item.item_id}"
        res, why = self._call(self._start, req, topics.START_TRIAL)
        if res is None:
            return StartReply(False, "", why)
        return StartReply(bool(res.accepted), str(res.trial_id), str(res.message))

    def stop_trial(self, trial_id: str, abort: bool) -> tuple[bool, str]:
        """Ask the driver to stop or abort ``trial_id`` (StopTrial)."""
        req = _srvs.StopTrial.Request()
        req.trial_id, req.abort = trial_id, bool(abort)
        res, why = self._call(self._stop, req, topics.STOP_TRIAL)
        if res is None:
            return False, why
        return bool(res.accepted), str(res.message)

    def send_reading(self, entry: ReadingEntry) -> None:
        """Publish ``entry`` on ``/bike_rig/readings``."""
        self._readings.publish(fill_reading_entry(_msgs.ReadingEntry(), entry))

    def close(self) -> None:
        """Destroy the node and shut its rclpy context down."""
        self.monitor.close()
