"""What ``bike-rig run`` follows of the graph it started: a small rclpy listener in its own process.

It subscribes to the trial events, the period estimates, the parameter set and the stability
sweep (every one reliable and transient-local, :mod:`bike_rig.topics`, so a listener that joins
after the first trial still gets the whole session so far) and hands them on as pipeline records
(:mod:`bike_rig.messages` converts): :class:`~bike_rig.pipeline.acquire.TrialEventRecord`,
:class:`~bike_rig.pipeline.fit.TrialFit`, :class:`~bike_rig.pipeline.assemble.SessionParameters`
and :class:`~bike_rig.pipeline.model.StabilitySweep`. It spins only when asked
(:meth:`GraphMonitor.poll`), in the caller's thread, with an rclpy context of its own.

Options add what the operator console (:mod:`bike_rig.nodes.session_link`) also follows: the
readings entered (``readings``), the gyro batches as records (``samples``, with the QoS
given), and every node's ``/diagnostics`` array as a :class:`~bike_rig.diagnostics.StatusReport`
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
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeAlias

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from .. import topics
from ..diagnostics import StatusReport
from ..messages import (
    MessageError,
    fit_details_from_msg,
    reading_entry_from_msg,
    sample_batch_from_msg,
    session_parameters_from_msg,
    stability_sweep_from_msg,
    trial_event_from_msg,
    trial_fit_from_msg,
)
from ..messages.diagnostics import statuses_from_msg
from ..pipeline.acquire import SampleBatch, TrialEventRecord
from ..pipeline.assemble import SessionParameters
from ..pipeline.fit import TrialFit
from ..pipeline.fit_details import FitDetails
from ..pipeline.model import StabilitySweep
from ..pipeline.readings import ReadingEntry
from ..rosenv import ros_environment
from ..rosqos import profile
from .publishers import participant, publisher_source

__all__ = ["OWNERS", "GraphMonitor", "MonitorRecord"]

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_diag: Any = importlib.import_module("diagnostic_msgs.msg")

#: The nodes that may publish each followed topic (ROS names; ``bike-rig replay --republish``'s
#: node stands in for the driver).
OWNERS: dict[str, tuple[str, ...]] = {
    topics.TRIAL_EVENTS.name: ("driver", "bag_republisher"),
    topics.GYRO.name: ("driver", "bag_republisher"),
    topics.PERIODS.name: ("fitter",),
    topics.FIT_DETAILS.name: ("fitter",),
    topics.PARAMETERS.name: ("parameter",),
    topics.EIGEN_SWEEP.name: ("model",),
}

#: How often the graph is asked again which node publishes a topic from an unknown process, s.
_RELOOK_S = 0.05
#: The node name the graph gives an endpoint whose node it has not discovered yet (rmw_dds_common).
_UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
#: How long a message from a process the graph does not know yet is held before it is dropped, s.
_HOLD_S = 5.0


@dataclass(frozen=True)
class _Held:
    """A message waiting for the graph to say which node its process is."""

    topic: str
    source: str
    record: Any
    since: float


#: Most callbacks taken in one :meth:`GraphMonitor.poll` after the first.
MAX_BURST = 1000

#: The gyro subscription's QoS: it is there to be counted, not to receive the session's history.
_COUNTED_ONLY = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)  # fmt: skip

#: What the monitor hands on.
MonitorRecord: TypeAlias = (
    TrialEventRecord | TrialFit | FitDetails | SessionParameters | StabilitySweep | SampleBatch | ReadingEntry
    | StatusReport
)


def _drop(_data: bytes) -> None:
    """The gyro batches are not used (see the module docstring)."""


class GraphMonitor:
    """The listener (see the module docstring).

    Args:
        domain_id: The graph's ROS_DOMAIN_ID (None: the environment's, as
            :func:`bike_rig.rosenv.ros_environment` decides); this process's environment is set
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
        self._owners: dict[str, str] = {}  # participant -> node name, as last looked up
        self._looked: dict[str, float] = {}  # topic -> when its publishers were last looked up
        self._foreign_said: set[tuple[str, str]] = set()
        self._held: list[_Held] = []
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
            self.node.create_subscription(_diag.DiagnosticArray, topics.DIAGNOSTICS.name, self._on_diagnostics,
                                          profile(topics.DIAGNOSTICS))  # fmt: skip

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
            source = publisher_source(info)
            self._held.append(_Held(topic, source, record, time.monotonic()))

        return collect

    def _owner_of(self, topic: str, source: str, now: float) -> bool | None:
        """Whether ``source`` is the process of ``topic``'s owner; None while the graph does not know it yet.

        True for a topic without an owner, and for a middleware that does not say (nothing to check).
        """
        if topic not in OWNERS or not source:
            return True
        if source not in self._owners and now - self._looked.get(topic, -_RELOOK_S) >= _RELOOK_S:
            self._looked[topic] = now
            for p in self.node.get_publishers_info_by_topic(topic):
                if p.node_name and p.node_name != _UNKNOWN_NODE:  # (its node not discovered yet)
                    self._owners[participant(bytes(p.endpoint_gid))] = p.node_name
        name = self._owners.get(source)
        return None if name is None else name in OWNERS[topic]

    def _release(self) -> None:
        """Hand on the messages of owners in their order of arrival; drop the others (see the module docstring).

        A message can arrive before discovery tells which node published it: it and every
        message after it wait until the graph says (looked up again at most every
        :data:`_RELOOK_S`), so that nothing overtakes it (a result its START); after
        :data:`_HOLD_S` it is dropped as from an unknown process.
        """
        now = time.monotonic()
        for k, h in enumerate(self._held):
            verdict = self._owner_of(h.topic, h.source, now)
            if verdict is None and now - h.since < _HOLD_S:
                self._held = self._held[k:]
                return
            if verdict:
                self._records.append(h.record)
            else:
                self._drop_foreign(h.topic, h.source)
        self._held = []

    def _drop_foreign(self, topic: str, source: str) -> None:
        self.foreign[topic] = self.foreign.get(topic, 0) + 1
        if (topic, source) not in self._foreign_said:
            self._foreign_said.add((topic, source))
            who = self._owners.get(source) or "an unknown node"
            self.ignored.append(f"{topic}: messages from {who} in another process than the {OWNERS[topic][0]} ignored")

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
