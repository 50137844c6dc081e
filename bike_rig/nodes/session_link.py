"""The operator console's link to the live graph (an rclpy node spun in a background thread).

It calls the driver's StartTrial/StopTrial services, publishes the operator's readings on
``/bike_rig/readings``, and collects what the graph publishes as pipeline records
(:mod:`bike_rig.messages` converts): trial events, period estimates, readings (all
transient-local, so a console that joins late gets the session so far), the latest parameter
set and stability sweep (latched), and the gyro batches as they come (reliable but volatile:
the live trace needs them contiguous, never the session's whole history).

Implements :class:`bike_rig.session.controller.GraphLink`.
"""

from __future__ import annotations

import importlib
import os
import threading
from collections import deque
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .. import topics
from ..messages import (
    MessageError,
    fill_reading_entry,
    reading_entry_from_msg,
    sample_batch_from_msg,
    session_parameters_from_msg,
    stability_sweep_from_msg,
    trial_event_from_msg,
    trial_fit_from_msg,
)
from ..pipeline.readings import ReadingEntry
from ..rosenv import ros_environment
from ..rosqos import profile
from ..session.controller import GraphEvent, StartReply
from ..session.plan import TrialItem

__all__ = ["SERVICE_TIMEOUT_S", "SessionLink"]

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_srvs: Any = importlib.import_module("bike_rig_msgs.srv")

#: Longest wait for the driver's answer to a start or stop, s.
SERVICE_TIMEOUT_S = 5.0

_LIVE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)  # fmt: skip


class SessionLink:
    """The console's rclpy node and its executor thread (see the module docstring).

    Args:
        node_name: The node's name.
    """

    def __init__(self, node_name: str = "session_console") -> None:
        """Initialise rclpy (LOCALHOST discovery, the environment's domain), create the node, spin."""
        env = ros_environment(os.environ)
        for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
            os.environ[key] = env[key]
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        self.node = Node(node_name, context=self._context)
        self._events: deque[GraphEvent] = deque()
        self._lock = threading.Lock()
        n = self.node
        self._start: Any = n.create_client(_srvs.StartTrial, topics.START_TRIAL)
        self._stop: Any = n.create_client(_srvs.StopTrial, topics.STOP_TRIAL)
        self._readings = n.create_publisher(_msgs.ReadingEntry, topics.READINGS.name, profile(topics.READINGS))
        subs = (
            (_msgs.TrialEvent, topics.TRIAL_EVENTS, trial_event_from_msg, profile(topics.TRIAL_EVENTS)),
            (_msgs.GyroBatch, topics.GYRO, sample_batch_from_msg, _LIVE),
            (_msgs.PeriodEstimate, topics.PERIODS, trial_fit_from_msg, profile(topics.PERIODS)),
            (_msgs.BenchmarkParameters, topics.PARAMETERS, session_parameters_from_msg, profile(topics.PARAMETERS)),
            (_msgs.EigenSweep, topics.EIGEN_SWEEP, stability_sweep_from_msg, profile(topics.EIGEN_SWEEP)),
            (_msgs.ReadingEntry, topics.READINGS, reading_entry_from_msg, profile(topics.READINGS)),
        )
        for msg_type, topic, convert, qos in subs:
            n.create_subscription(msg_type, topic.name, self._collector(convert), qos)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(n)
        self._thread = threading.Thread(target=self._spin, name="session-link", daemon=True)
        self._running = True
        self._thread.start()

    def _spin(self) -> None:
        while self._running and self._context.ok():
            self._executor.spin_once(timeout_sec=0.05)

    def _collector(self, convert: Any) -> Any:
        def collect(msg: Any) -> None:
            try:
                record = convert(msg)
            except MessageError as exc:
                self.node.get_logger().warning(f"message ignored: {exc}")
                return
            with self._lock:
                self._events.append(record)

        return collect

    # ------------------------------------------------------------------ GraphLink
    def events(self) -> list[GraphEvent]:
        """What arrived since the last call, in arrival order."""
        with self._lock:
            out = list(self._events)
            self._events.clear()
        return out

    def _call(self, client: Any, request: Any) -> Any:
        if not client.wait_for_service(timeout_sec=SERVICE_TIMEOUT_S):
            return None
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _f: done.set())
        if not done.wait(SERVICE_TIMEOUT_S):
            return None
        return future.result()

    def start_trial(self, item: TrialItem, duration_s: float) -> StartReply:
        """Ask the driver to start a trial of ``item`` (StartTrial)."""
        m = item.measurement
        req = _srvs.StartTrial.Request()
        req.part, req.pendulum = m.part, m.pendulum
        req.orientation, req.repeat = m.orientation or 0, item.repeat
        req.measurement_key, req.duration_s = item.key, float(duration_s)
        req.note = f"plan item {item.item_id}"
        res = self._call(self._start, req)
        if res is None:
            return StartReply(
                False, "", f"no answer from the driver ({topics.START_TRIAL}) within {SERVICE_TIMEOUT_S:g} s"
            )
        return StartReply(bool(res.accepted), str(res.trial_id), str(res.message))

    def stop_trial(self, trial_id: str, abort: bool) -> tuple[bool, str]:
        """Ask the driver to stop or abort ``trial_id`` (StopTrial)."""
        req = _srvs.StopTrial.Request()
        req.trial_id, req.abort = trial_id, bool(abort)
        res = self._call(self._stop, req)
        if res is None:
            return False, f"no answer from the driver ({topics.STOP_TRIAL}) within {SERVICE_TIMEOUT_S:g} s"
        return bool(res.accepted), str(res.message)

    def send_reading(self, entry: ReadingEntry) -> None:
        """Publish ``entry`` on ``/bike_rig/readings``."""
        self._readings.publish(fill_reading_entry(_msgs.ReadingEntry(), entry))

    def close(self) -> None:
        """Stop spinning and shut this node's rclpy context down."""
        self._running = False
        self._thread.join(timeout=2.0)
        self._executor.shutdown()
        self.node.destroy_node()
        if self._context.ok():
            rclpy.shutdown(context=self._context)
