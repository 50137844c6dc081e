"""What ``bike-rig run`` follows of the graph it started: a small rclpy listener in its own process.

It subscribes to the trial events, the period estimates, the parameter set and the stability
sweep (every one reliable and transient-local, :mod:`bike_rig.config.topics`, so a listener that joins
after the first trial still gets the whole session so far) and hands them on as pipeline records
(:mod:`bike_rig.messages` converts): :class:`~bike_rig.pipeline.acquire.TrialEventRecord`,
:class:`~bike_rig.pipeline.fit.TrialFit`, :class:`~bike_rig.pipeline.assemble.SessionParameters`
and :class:`~bike_rig.pipeline.model.StabilitySweep`. It spins only when asked
(:meth:`GraphMonitor.poll`), in the caller's thread, with an rclpy context of its own.

Options add what the operator console (:mod:`bike_rig.ros.nodes.session_link`) also follows: the
readings entered (``readings``), the gyro batches as records (``samples``, with the QoS
given), and every node's ``/diagnostics`` array as a :class:`~bike_rig.pipeline.diagnostics.StatusReport`
(``diagnostics``: handed on as it arrives, not held with the results below; the follower's
heartbeat of each node, :class:`~bike_rig.pipeline.stalls.StallWatch`).

Without ``samples`` it subscribes to the gyro batches raw, best effort, volatile, and drops
them: only so that it counts among the gyro topic's subscribers, so that a driver told to wait
for it (``wait_for_subscribers``, which counts the subscribers of both the gyro and the trial-event
topics) publishes its first START only once the listener is matched. (A START published before a
reader matched reaches that reader only at the writer's next heartbeat, up to 3 s later.)

Each topic is taken only from the process of the node that owns it (:data:`OWNERS`: the
driver's trial events and batches, the fitter's estimates, the parameter node's set, the model
node's sweep), known by the DDS participant of its publisher (rclpy's message info) and the
graph's record of which node publishes from it. Another process publishing on the domain (a
second driver, a rogue) is dropped and said once in :attr:`GraphMonitor.ignored`: it cannot start,
cut short or mark a trial for the console, nor stand in for a result.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from typing import Any, TypeAlias

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions

from ...config import topics
from ...messages import (
    MessageError,
    fit_details_from_msg,
    reading_entry_from_msg,
    sample_batch_from_msg,
    session_parameters_from_msg,
    stability_sweep_from_msg,
    trial_event_from_msg,
    trial_fit_from_msg,
)
from ...messages.diagnostics import statuses_from_msg
from ...pipeline.acquire import SampleBatch, TrialEventRecord
from ...pipeline.assemble import SessionParameters
from ...pipeline.diagnostics import StatusReport
from ...pipeline.fit import TrialFit
from ...pipeline.fit_details import FitDetails
from ...pipeline.model import StabilitySweep
from ...pipeline.readings import ReadingEntry
from ..env import ros_environment
from ..qos import profile
from .owners import TOPIC_OWNERS, OwnerFilter, Released

__all__ = ["OWNERS", "GraphMonitor", "MonitorRecord"]

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_diag: Any = importlib.import_module("diagnostic_msgs.msg")

#: The nodes that may publish each followed topic (:data:`bike_rig.ros.nodes.owners.TOPIC_OWNERS`).
OWNERS = TOPIC_OWNERS

#: Most callbacks taken in one :meth:`GraphMonitor.poll` after the first.
MAX_BURST = 1000

#: The gyro subscription's QoS: it is there to be counted, not to receive the session's history.
_COUNTED_ONLY = profile(topics.QosSpec(reliable=False, transient_local=False, depth=1))

#: What the monitor hands on.
MonitorRecord: TypeAlias = (
    TrialEventRecord
    | TrialFit
    | FitDetails
    | SessionParameters
    | StabilitySweep
    | SampleBatch
    | ReadingEntry
    | StatusReport
)


def _drop(_data: bytes) -> None:
    """The gyro batches are not used (see the module docstring)."""


class GraphMonitor:
    """The listener (see the module docstring).

    Args:
        domain_id: The graph's ROS_DOMAIN_ID (None: the environment's, as
            :func:`bike_rig.ros.env.ros_environment` decides); this process's environment is set
            to it, with LOCALHOST discovery, before rclpy starts.
        node_name: The listener node's name.
        samples: Also hand on the gyro batches as records, subscribed with this QoS (None: the
            batches are only counted, see the module docstring).
        readings: Also hand on the readings entered (``/bike_rig/readings``, transient-local).
        diagnostics: Also hand on every ``/diagnostics`` array (reliable, volatile).
    """

    def __init__(
        self,
        domain_id: int | None = None,
        node_name: str = "run_monitor",
        samples: QoSProfile | None = None,
        readings: bool = False,
        diagnostics: bool = False,
    ) -> None:
        """Set the ROS environment, start an rclpy context and subscribe."""
        env = ros_environment(os.environ, domain_id=domain_id)
        for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
            os.environ[key] = env[key]
        self._context = rclpy.Context()
        # no rclpy signal handlers: Ctrl-C must not shut this context down before the last results
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(node_name, context=self._context)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._records: list[MonitorRecord] = []
        #: Messages that could not be converted, one line each; a foreign publisher once per topic.
        self.ignored: list[str] = []
        #: Messages dropped per topic because another process than the topic's owner sent them.
        self.foreign: dict[str, int] = {}
        self._gate: OwnerFilter[MonitorRecord] = OwnerFilter(self.node, OWNERS)
        self._foreign_said: set[tuple[str, str]] = set()
        self._taken = 0  # callbacks run
        subscriptions: tuple[tuple[Any, topics.Topic, Callable[[Any], MonitorRecord]], ...] = (
            (_msgs.TrialEvent, topics.TRIAL_EVENTS, trial_event_from_msg),
            # (the details before their estimate: when both are ready the executor takes them in
            # creation order, and the fitter publishes the details first)
            (_msgs.FitDetails, topics.FIT_DETAILS, fit_details_from_msg),
            (_msgs.PeriodEstimate, topics.PERIODS, trial_fit_from_msg),
            (_msgs.BenchmarkParameters, topics.PARAMETERS, session_parameters_from_msg),
            (_msgs.EigenSweep, topics.EIGEN_SWEEP, stability_sweep_from_msg),
        )
        if readings:
            subscriptions += ((_msgs.ReadingEntry, topics.READINGS, reading_entry_from_msg),)
        for msg_type, topic, convert in subscriptions:
            self.node.create_subscription(msg_type, topic.name, self._collector(topic.name, convert), profile(topic))
        if samples is None:
            self.node.create_subscription(_msgs.GyroBatch, topics.GYRO.name, _drop, _COUNTED_ONLY, raw=True)
        else:
            gyro = self._collector(topics.GYRO.name, sample_batch_from_msg)
            self.node.create_subscription(_msgs.GyroBatch, topics.GYRO.name, gyro, samples)
        if diagnostics:
            self.node.create_subscription(
                _diag.DiagnosticArray, topics.DIAGNOSTICS.name, self._on_diagnostics, profile(topics.DIAGNOSTICS)
            )

    def _on_diagnostics(self, msg: Any) -> None:
        """Hand on one node's ``/diagnostics`` array at once (a malformed one is skipped)."""
        self._taken += 1
        try:
            self._records.append(StatusReport(tuple(statuses_from_msg(msg))))
        except MessageError:
            return

    def _collector(self, topic: str, convert: Callable[[Any], MonitorRecord]) -> Callable[[Any, Any], None]:
        def collect(msg: Any, info: Any) -> None:
            try:
                record = convert(msg)
            except MessageError as exc:
                self._taken += 1
                self.ignored.append(f"{type(msg).__name__} ignored: {exc}")
                return
            self._taken += 1
            self._gate.offer(topic, info, record)

        return collect

    def _release(self) -> None:
        """Hand on the messages of owners in their order of arrival; drop the others (see the module docstring).

        A message whose process discovery has not named yet waits, and every message after it
        (:class:`~bike_rig.ros.nodes.owners.OwnerFilter`).
        """
        for r in self._gate.release():
            if r.owned:
                self._records.append(r.item)
            else:
                self._drop_foreign(r)

    def _drop_foreign(self, r: Released[MonitorRecord]) -> None:
        self.foreign[r.topic] = self.foreign.get(r.topic, 0) + 1
        if (r.topic, r.source) not in self._foreign_said:
            self._foreign_said.add((r.topic, r.source))
            who, owner = ", ".join(r.nodes) or "an unknown node", OWNERS[r.topic][0]
            self.ignored.append(f"{r.topic}: messages from {who} in another process than the {owner} ignored")

    def poll(self, timeout_s: float = 0.1) -> list[MonitorRecord]:
        """Wait up to ``timeout_s`` (s) for a message, take in what is ready, and return it in order."""
        if self._context.ok():
            self._executor.spin_once(timeout_sec=timeout_s)
            for _ in range(MAX_BURST):
                before = self._taken
                self._executor.spin_once(timeout_sec=0.0)
                if self._taken == before:
                    break
        self._release()
        out, self._records = self._records, []
        return out

    def close(self) -> None:
        """Destroy the node and shut its rclpy context down."""
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self._context.ok():
            rclpy.shutdown(context=self._context)
