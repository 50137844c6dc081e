"""The recorder node: every topic of the graph (``/diagnostics`` too), raw CDR, into a rosbag2 MCAP bag.

Subscriptions are raw (``create_subscription(..., raw=True)``): the bytes DDS delivers, with
their CDR encapsulation header, go into the bag as they are, never deserialized. Each topic
is subscribed with its contract QoS (:mod:`bike_rig.config.topics`), so transient-local topics
(static readings, periods, parameters, model, the current trial's gyro batches) are recorded
even when they were published before the recorder started.

Per message: log time = receive time (when the recorder takes it from the middleware, so
that log times follow the delivery order), publish time = the publisher's source stamp,
sequence = the publication sequence number; the header stamps stay inside the messages. A
topic's channel is created when its first message arrives, with the QoS profiles its
publishers offer (from the ROS graph, which does not report history and depth: those are the
topic contract's); topics that stayed silent are added, empty, when the bag closes. Chunks
are flushed at least every ``flush_period`` s (default 0.5), so a recorder killed with SIGKILL
loses at most that much (``bike-rig bag recover``).
SIGINT or SIGTERM: the messages already delivered are drained, then the bag is closed
(summary, footer, metadata.yaml). SIGUSR1 (the launcher, before it stops the other nodes): wait
until every node named in ``sync_file`` is discovered and every publisher the graph shows is
matched, take what they hold, log a line beginning ``synced:`` and remove ``sync_file``.

Parameters (``config/recorder.yaml``):

* ``output`` (string): the bag directory to create; never overwritten. Empty: a new
  ``bike_rig_YYYY_MM_DD-HH_MM_SS`` in the working directory.
* ``topics`` (string array): ``["all"]`` (default) or topic names, full (``/bike_rig/gyro``)
  or relative to ``/bike_rig`` (``gyro``, ``model/matrices``).
* ``compression`` (string): chunk compression, ``zstd`` (default), ``lz4`` or ``none``.
* ``flush_period`` (double, s): in (0, 1]; default 0.5.
* ``min_free_disk_mb`` (double, MB): ``recorder: disk`` on ``/diagnostics`` warns below this
  free space; default 500. (``recorder: bag``: bytes and messages written, dropped, the longest
  write of the last second.)
* ``max_bag_size`` (integer, bytes): split the bag into a new storage file (``NAME_1.mcap``,
  ...) before a file exceeds this size; 0 (default): never.
* ``max_bag_duration`` (double, s): split before a file spans more than this; 0 (default): never.
* ``snapshot_duration`` (double, s): seconds kept in memory for ``save_snapshot``; 0
  (default, as rosbag2's snapshot mode is opt-in): no snapshots, no memory spent.
* ``snapshot_max_bytes`` (integer, bytes): the snapshot buffer's memory bound (message data
  plus 240 bytes per message); default 64 MiB.
* ``sync_file`` (string): the file naming (one per line) the nodes a sync (SIGUSR1) waits for;
  set by the launcher, which writes it before the signal and waits for it to go.

Services (``bike_rig_msgs/srv``), as rosbag2's recorder offers them:

* ``/bike_rig/recorder/pause`` (``Pause``) and ``/bike_rig/recorder/resume`` (``Resume``):
  while paused, arriving messages are not recorded (nor kept for snapshots); they are counted,
  logged on resume and kept in metadata.yaml's ``custom_data``
  (``messages_dropped_while_paused``, ``pauses``).
* ``/bike_rig/recorder/split_bag`` (``SplitBag``): close the current storage file, go on in
  the next; nothing is lost.
* ``/bike_rig/recorder/save_snapshot`` (``SaveSnapshot``): write the last N seconds (the
  buffer, :mod:`bike_rig.bag.snapshot`) into a new bag; the recording goes on.

Counters a diagnostics task can read: :attr:`Recorder.received`, :attr:`Recorder.dropped`
(not written after a failure), :attr:`Recorder.dropped_paused`, :attr:`Recorder.paused`,
:attr:`Recorder.errors`, ``writer.bytes_written``, ``writer.files``.

Run: ``python -m bike_rig.ros.nodes.recorder --ros-args -p output:=session1`` (or
``--params-file config/recorder.yaml``).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import shutil
import signal
import sys
import time
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from types import FrameType
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from ...bag.errors import BagError
from ...bag.snapshot import BufferedMessage, SnapshotBuffer, SnapshotTopic, write_snapshot
from ...bag.writer import BagWriter, Compression, contract_qos
from ...config import topics as contract
from ...config.settings import ParamSpec
from ...config.topics import RECORDER_PAUSE, RECORDER_RESUME, RECORDER_SNAPSHOT, RECORDER_SPLIT
from ...core.errors import BikeRigError
from ...pipeline.health import RecorderHealth, recorder_statuses
from ..env import ros_environment
from ..qos import profile
from .diagnostics import DiagnosticsUpdater
from .settings import declare_parameters, parameter_error

__all__ = ["EXIT_USER_ERROR", "PARAMETERS", "RECORDED", "Recorder", "main", "resolve_topics"]

EXIT_USER_ERROR = 2
NODE_NAME = "recorder"
DRAIN_TIMEOUT_S = 2.0
"""Longest time spent taking already-delivered messages after a stop request."""
DRAIN_IDLE_S = 0.05
"""The drain ends when nothing arrives for this long."""
SYNC_TIMEOUT_S = 10.0
"""Longest wait for every publisher to be matched on a sync request (SIGUSR1)."""
SYNCED = "synced:"
"""What the log line that ends a sync begins with (the sync file is removed after it)."""

# the generated service classes ship no type information: imported by name
_srvs: Any = importlib.import_module("bike_rig_msgs.srv")

#: The recorder's parameters (``config/recorder.yaml``). Typed by hand on ``bike-rig run
#: --param`` lines, ``flush_period`` also takes an integer and ``topics`` one name.
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("output", "", "bag directory to create (never overwritten); empty: bike_rig_<time>"),
    ParamSpec(
        "topics", ("all",), "topics to record: ['all'] or names (full or relative to /bike_rig)", loose_type=True
    ),
    ParamSpec(
        "compression",
        Compression.ZSTD.value,
        "chunk compression: zstd, lz4 or none",
        choices=tuple(c.value for c in Compression),
    ),
    ParamSpec(
        "flush_period",
        0.5,
        "longest time a received message stays in memory, s",
        (0.0, 1.0),
        open_low=True,
        loose_type=True,
    ),
    ParamSpec(
        "min_free_disk_mb", 500.0, "free disk space below which /diagnostics warns, MB", (0.0, 1e12), loose_type=True
    ),
    ParamSpec(
        "max_bag_size", 0, "split into a new storage file before one exceeds this size, bytes; 0: never", (0, 2**62)
    ),
    ParamSpec(
        "max_bag_duration",
        0.0,
        "split into a new storage file before one spans more than this, s; 0: never",
        (0.0, 1e9),
        loose_type=True,
    ),
    ParamSpec(
        "snapshot_duration",
        0.0,
        "seconds kept in memory for save_snapshot, s; 0: no snapshots",
        (0.0, 86400.0),
        loose_type=True,
    ),
    ParamSpec(
        "snapshot_max_bytes", 64 << 20, "most memory kept for save_snapshot (data + 240 per message), bytes", (1, 2**62)
    ),
    ParamSpec("sync_file", "", "file naming the nodes a sync (SIGUSR1) waits for, removed when done; the launcher's"),
)


#: What ``all`` records: every topic of the graph, the fitter's details and ``/diagnostics``
#: included (not the ride topics, which belong to a ride record).
RECORDED: tuple[contract.Topic, ...] = (*contract.TOPICS, contract.FIT_DETAILS, contract.DIAGNOSTICS)


def resolve_topics(names: Sequence[str]) -> tuple[contract.Topic, ...]:
    """The topics to record for the ``topics`` parameter.

    Raises:
        NodeParameterError: An unknown topic name.
    """
    if not names or list(names) == ["all"]:
        return RECORDED
    by_name = {t.name: t for t in RECORDED}
    out: list[contract.Topic] = []
    for raw in names:
        name = raw if raw.startswith("/") else f"{contract.NAMESPACE}/{raw}"
        topic = by_name.get(name)
        if topic is None:
            known = ", ".join(t.name.removeprefix(contract.NAMESPACE + "/") for t in RECORDED)
            raise parameter_error("topics", f"unknown topic {raw!r} (known: all, {known})")
        if topic not in out:
            out.append(topic)
    return tuple(out)


def _message_class(msgtype: str) -> Any:
    package, _, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def _enum(enum: Any, value: Any, unknown: Any) -> Any:
    try:
        return enum(int(value))
    except (ValueError, TypeError):
        return unknown


def _time(duration: Any) -> QosTime:
    ns = int(duration.nanoseconds)
    return QosTime(ns // 1_000_000_000, ns % 1_000_000_000)


def offered_qos(qos: QoSProfile, contract_depth: int | None = None) -> Qos:
    """An rclpy QoS profile (as the graph reports a publisher's) in rosbag2's terms.

    The graph does not carry history and depth (it reports UNKNOWN and 0); when
    ``contract_depth`` is given they are filled in as the topic contract's KEEP_LAST depth.
    """
    history = _enum(QosHistory, qos.history, QosHistory.UNKNOWN)
    depth = int(qos.depth)
    if history in (QosHistory.UNKNOWN, QosHistory.SYSTEM_DEFAULT) and contract_depth is not None:
        history, depth = QosHistory.KEEP_LAST, contract_depth
    return Qos(
        history,
        depth,
        _enum(QosReliability, qos.reliability, QosReliability.UNKNOWN),
        _enum(QosDurability, qos.durability, QosDurability.UNKNOWN),
        _time(qos.deadline),
        _time(qos.lifespan),
        _enum(QosLiveliness, qos.liveliness, QosLiveliness.UNKNOWN),
        _time(qos.liveliness_lease_duration),
        bool(qos.avoid_ros_namespace_conventions),
    )


def default_output(now: datetime | None = None) -> str:
    """rosbag2's default bag name for a recording started now."""
    return (now or datetime.now()).strftime("bike_rig_%Y_%m_%d-%H_%M_%S")


class Recorder(Node):
    """Records the rig's topics into a bag (see the module docstring)."""

    def __init__(self) -> None:
        """Declare the parameters, create the bag and subscribe to the topics (raw).

        Raises:
            NodeParameterError: A parameter is wrong (an unknown topic too).
            BikeRigError: The bag exists already or cannot be created.
        """
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PARAMETERS)
        self.topics = resolve_topics(values["topics"])
        self.writer = BagWriter(
            Path(values["output"] or default_output()),
            compression=values["compression"],
            flush_period_s=values["flush_period"],
            custom_data={"recorder": f"bike_rig.ros.nodes.recorder, node {self.get_fully_qualified_name()}"},
            max_bytes=values["max_bag_size"],
            max_duration_s=values["max_bag_duration"],
        )
        self.snapshot: SnapshotBuffer | None = None
        if values["snapshot_duration"] > 0:
            latched = (t.name for t in self.topics if t.qos.transient_local and t.qos.depth == 1)
            self.snapshot = SnapshotBuffer(values["snapshot_duration"], values["snapshot_max_bytes"], latched)
        self.writer.open()
        self.received = 0
        self.errors = 0
        self.failed: OSError | None = None
        self.dropped = 0
        self.paused = False
        self.pauses = 0
        self.dropped_paused = 0
        """Messages that arrived while paused (not recorded, knowingly)."""
        self.snapshots: list[Path] = []
        self._closed = False
        self._min_free_bytes = int(1e6 * float(values["min_free_disk_mb"]))
        self._write_ms = 0.0  # the longest write since the last diagnostics, ms
        self.diagnostics = DiagnosticsUpdater(self, self._health)
        self.create_service(_srvs.Pause, RECORDER_PAUSE, self._on_pause)
        self.create_service(_srvs.Resume, RECORDER_RESUME, self._on_resume)
        self.create_service(_srvs.SplitBag, RECORDER_SPLIT, self._on_split)
        self.create_service(_srvs.SaveSnapshot, RECORDER_SNAPSHOT, self._on_snapshot)
        self.sync_file = Path(values["sync_file"]) if values["sync_file"] else None
        self.subscriptions_by_topic = {
            topic.name: self.create_subscription(
                _message_class(topic.type), topic.name, self._callback(topic), profile(topic), raw=True
            )
            for topic in self.topics
        }
        self.get_logger().info(
            f"recording {len(self.topics)} topics to {self.writer.path} "
            f"(chunks flushed every {self.writer.flush_period_s:g} s, {self.writer.compression.value})"
        )

    def _callback(self, topic: contract.Topic) -> Any:
        def on_message(data: bytes, info: Any) -> None:
            self.diagnostics.note_input(info)
            # never let an exception escape into the executor (see shared/notes §4)
            try:
                self._record(topic, data, info)
            except Exception as exc:
                self.errors += 1
                if self.errors <= 10:
                    self.get_logger().error(f"{topic.name}: message not recorded: {exc!r}")

        return on_message

    def _record(self, topic: contract.Topic, data: bytes, info: Any) -> None:
        # The time the message is taken, not the middleware's per-sample arrival stamp: a
        # reliable reader holds samples back until a lost one is repaired, so arrival stamps
        # can run backwards in delivery order, and bag readers sort by log time.
        received = time.time_ns()
        sent = int(info.get("source_timestamp") or 0) or received
        sequence = int(info.get("publication_sequence_number") or 0)
        self.received += 1
        if self.paused:
            self.dropped_paused += 1
            return
        payload = bytes(data)
        if self.snapshot is not None:
            self.snapshot.push(BufferedMessage(topic.name, received, sent, sequence, payload))
        if self.failed is not None:
            self.dropped += 1
            return
        files = len(self.writer.files)
        try:
            if not self.writer.has_topic(topic.name):
                self._add_channel(topic, first=True)
            started = time.perf_counter()
            self.writer.write(topic.name, received, payload, sent, sequence)
            self._write_ms = max(self._write_ms, 1e3 * (time.perf_counter() - started))
        except OSError as exc:
            self.dropped += 1
            self._fail(exc, received=self.received - 1)
            return
        if len(self.writer.files) != files:
            self.get_logger().info(f"split (limit reached): {self._split_line()}")

    def _split_line(self) -> str:
        names = self.writer.files
        return f"closed {names[-2]}, recording into {names[-1]} ({self.writer.bytes_written} bytes so far)"

    # ------------------------------------------------------------------ services
    def _on_pause(self, _request: Any, response: Any) -> Any:
        """Pause recording (``Pause``): what arrives from now on is counted, not recorded."""
        if self.failed is not None:
            response.ok, response.message = False, f"recording stopped earlier ({self.failed.strerror})"
        elif self.paused:
            response.ok, response.message = True, "already paused"
        else:
            self.paused = True
            self.pauses += 1
            self.writer.custom_data["pauses"] = str(self.pauses)
            response.ok, response.message = True, "paused"
            self.get_logger().info("paused: messages arriving now are counted, not recorded")
        return response

    def _on_resume(self, _request: Any, response: Any) -> Any:
        """Resume recording (``Resume``)."""
        if self.failed is not None:
            response.ok, response.message = False, f"recording stopped earlier ({self.failed.strerror})"
        elif not self.paused:
            response.ok, response.message = True, "not paused"
        else:
            self.paused = False
            self.writer.custom_data["messages_dropped_while_paused"] = str(self.dropped_paused)
            response.ok = True
            response.message = f"resumed ({self.dropped_paused} message(s) dropped while paused so far)"
            self.get_logger().info(response.message)
        return response

    def _on_split(self, _request: Any, response: Any) -> Any:
        """Close the current storage file and go on in the next (``SplitBag``)."""
        response.ok, response.closed_file, response.new_file = False, "", ""
        if self.failed is not None:
            response.message = f"recording stopped earlier ({self.failed.strerror})"
            return response
        try:
            response.closed_file, response.new_file = self.writer.split()
        except OSError as exc:
            self._fail(exc)
            response.message = f"cannot write {self.writer.path}: {exc.strerror or exc}"
            return response
        except BagError as exc:
            response.message = str(exc)
            return response
        response.ok = True
        response.message = f"split: {self._split_line()}"
        self.get_logger().info(response.message)
        return response

    def _on_snapshot(self, request: Any, response: Any) -> Any:
        """Write the last ``request.seconds`` into a new bag (``SaveSnapshot``)."""
        response.ok, response.path, response.message_count = False, "", 0
        if self.snapshot is None:
            response.message = "snapshots are off (parameter snapshot_duration is 0)"
            return response
        try:
            messages = self.snapshot.window(float(request.seconds))
            path = Path(request.output) if request.output else self._snapshot_path()
            about = {"snapshot_of": str(self.writer.path), "seconds": f"{request.seconds:g}"}
            writer = write_snapshot(path, messages, self._snapshot_topics(), self.writer.compression, about)
        except (ValueError, BagError, OSError) as exc:
            response.message = f"snapshot not written: {exc}"
            self.get_logger().error(response.message)
            return response
        self.snapshots.append(path)
        response.ok, response.path, response.message_count = True, str(path), writer.message_count
        response.message = f"snapshot: {writer.message_count} messages into {path}"
        self.get_logger().info(response.message)
        return response

    def _snapshot_path(self) -> Path:
        base = self.writer.path
        n = 1
        while (candidate := base.parent / f"{base.name}_snapshot_{n}").exists():
            n += 1
        return candidate

    def _snapshot_topics(self) -> list[SnapshotTopic]:
        w = self.writer
        return [
            SnapshotTopic(t.name, t.type, tuple(w.topic_qos(t.name) if w.has_topic(t.name) else [contract_qos(t.qos)]))
            for t in self.topics
        ]

    def _health(self) -> list[Any]:
        """Bag and disk statuses (:func:`bike_rig.pipeline.health.recorder_statuses`)."""
        path = Path(self.writer.path)
        try:
            written = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
            free = shutil.disk_usage(path).free
        except OSError:
            written, free = 0, 0
        latency, self._write_ms = self._write_ms, 0.0
        failed = "" if self.failed is None else str(self.failed.strerror or self.failed)
        return recorder_statuses(
            RecorderHealth(
                str(path),
                written,
                self.writer.message_count,
                self.dropped + self.errors,
                latency,
                free,
                self._min_free_bytes,
                failed,
                self.paused,
                self.dropped_paused,
            )
        )

    def _fail(self, exc: OSError, received: int | None = None, closing: bool = False) -> None:
        """The bag cannot be written any more (disk full, out of inodes, read-only, removed): say so once, stop.

        Any write of the bag ends here: a message, a flush, a split, the closing records and
        metadata.yaml at close. The file is left as a crash leaves it (:meth:`BagWriter.abort`):
        every chunk flushed before is recoverable. Before close the node stays up (the graph
        goes on computing) and counts what it receives from now on without recording it.

        Args:
            exc: The write's error.
            received: Messages received before the failure (default: all so far).
            closing: The failure came while closing the bag.
        """
        self.failed = exc
        self.writer.abort()
        after = (
            "the bag was being closed"
            if closing
            else "the graph goes on, and what arrives from now on is counted, not recorded"
        )
        self.get_logger().error(
            f"recording stopped: cannot write {self.writer.path}: {exc.strerror or exc} (errno {exc.errno}) after "
            f"{self.received if received is None else received} messages; the chunks flushed before are "
            f"recoverable with 'bike-rig bag recover {self.writer.path}'; {after}"
        )

    def _add_channel(self, topic: contract.Topic, first: bool) -> None:
        publishers = self.get_publishers_info_by_topic(topic.name)
        qos = [offered_qos(p.qos_profile, topic.qos.depth) for p in publishers] or [contract_qos(topic.qos)]
        self.writer.add_topic(topic.name, topic.type, offered_qos=qos)
        if first:
            self.get_logger().info(f"recording {topic.name} ({len(publishers)} publisher(s))")

    def unsynced(self, nodes: Sequence[str]) -> list[str]:
        """What a sync still waits for: ``nodes`` not discovered, publishers the graph shows not matched."""
        seen = {name for name, _ in self.get_node_names_and_namespaces()}
        out = [f"node {name} not discovered" for name in nodes if name not in seen]
        for name, sub in self.subscriptions_by_topic.items():
            known = len(self.get_publishers_info_by_topic(name))
            matched = sub.get_publisher_count()
            if matched < known:
                out.append(f"{name}: {matched} of {known} publishers matched")
        return out

    def tick(self) -> None:
        """Flush the chunk in progress if it is due (called by the spin loop)."""
        if self.failed is not None:
            return
        try:
            self.writer.flush_if_due()
        except OSError as exc:
            self._fail(exc)
        except Exception as exc:
            self.errors += 1
            self.get_logger().error(f"flush failed: {exc!r}")

    def close(self) -> bool:
        """Add the silent topics and close the bag (summary, footer, metadata.yaml).

        Returns:
            False when the bag could not be written to the end (:meth:`_fail`), now or before.
        """
        if self._closed:
            return self.failed is None
        self._closed = True
        if self.failed is not None:
            self.get_logger().error(
                f"{self.dropped} message(s) not recorded after recording stopped ({self.failed.strerror}); "
                f"the bag needs 'bike-rig bag recover {self.writer.path}'"
            )
            return False
        if self.pauses:
            self.writer.custom_data["pauses"] = str(self.pauses)
            self.writer.custom_data["messages_dropped_while_paused"] = str(self.dropped_paused)
            self.get_logger().info(f"{self.dropped_paused} message(s) arrived while paused (not recorded)")
        try:
            for topic in self.topics:
                if not self.writer.has_topic(topic.name):
                    self._add_channel(topic, first=False)
            counts = self.writer.close()
        except OSError as exc:
            self._fail(exc, closing=True)
            return False
        summary = ", ".join(f"{c.name} {c.count}" for c in counts)
        files = self.writer.files
        in_files = f" in {len(files)} files" if len(files) > 1 else ""
        self.get_logger().info(f"closed {self.writer.path}: {self.writer.message_count} messages{in_files} ({summary})")
        if self.errors:
            self.get_logger().error(f"{self.errors} message(s) could not be recorded")
        return True


def _spin_until_idle(executor: SingleThreadedExecutor, node: Recorder) -> None:
    deadline = time.monotonic() + DRAIN_TIMEOUT_S
    while time.monotonic() < deadline:
        before = node.received
        executor.spin_once(timeout_sec=DRAIN_IDLE_S)
        if node.received == before:
            return


def _sync(executor: SingleThreadedExecutor, node: Recorder) -> None:
    """Wait until every publisher is matched (:meth:`Recorder.unsynced`), take what they hold, and say so.

    Asked by the launcher before it stops the nodes that publish (SIGUSR1): a publisher the
    recorder has not matched yet still holds its transient-local history, which it loses with
    its process. The nodes waited for are named in :attr:`Recorder.sync_file`; it is removed
    at the end, after a log line beginning with :data:`SYNCED`.
    """
    nodes: list[str] = []
    if node.sync_file is not None:
        with contextlib.suppress(OSError):
            nodes = [n.strip() for n in node.sync_file.read_text(encoding="utf-8").splitlines() if n.strip()]
    deadline = time.monotonic() + SYNC_TIMEOUT_S
    waiting = node.unsynced(nodes)
    while waiting and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
        node.tick()
        waiting = node.unsynced(nodes)
    _spin_until_idle(executor, node)
    if waiting:
        node.get_logger().warning(
            f"{SYNCED} after {SYNC_TIMEOUT_S:g} s still {'; '.join(waiting)}: what they hold may not be recorded"
        )
    else:
        node.get_logger().info(f"{SYNCED} every publisher matched, {node.received} messages received")
    if node.sync_file is not None:
        with contextlib.suppress(OSError):
            node.sync_file.unlink()


def _record_until_stopped(executor: SingleThreadedExecutor, node: Recorder, stop: dict[str, bool]) -> None:
    """Spin until a stop is requested (syncing when asked), then drain what was delivered."""
    while rclpy.ok() and not stop["requested"]:
        executor.spin_once(timeout_sec=0.1)
        node.tick()
        if stop["sync"]:
            stop["sync"] = False
            _sync(executor, node)
    if rclpy.ok():
        _spin_until_idle(executor, node)


def main(args: Sequence[str] | None = None) -> int:
    """Run the recorder until SIGINT/SIGTERM; returns the exit status (2 on a user mistake)."""
    env = ros_environment(os.environ)
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
        os.environ[key] = env[key]
    argv = list(sys.argv if args is None else args)
    # our own handlers (not rclpy's, which would shut the context down before the drain)
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    stop = {"requested": False, "sync": False}

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        stop["requested"] = True

    def request_sync(signum: int, _frame: FrameType | None) -> None:
        stop["sync"] = True

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, request_stop)
    signal.signal(signal.SIGUSR1, request_sync)
    node: Recorder | None = None
    executor: SingleThreadedExecutor | None = None
    try:
        node = Recorder()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        _record_until_stopped(executor, node, stop)
        return 0 if node.close() else 1
    except BikeRigError as exc:
        print(f"{NODE_NAME}: error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except (KeyboardInterrupt, ExternalShutdownException):
        if node is not None:
            node.close()
        return 0
    finally:
        if executor is not None:
            executor.shutdown(timeout_sec=1.0)
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
