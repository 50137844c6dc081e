"""Write serialized (CDR) messages into a rosbag2 bag with MCAP storage, as rosbag2 does.

``NAME/NAME_<i>.mcap``: profile ``ros2``, one ``ros2msg`` schema per type, one ``cdr`` channel per
topic (metadata ``offered_qos_profiles`` and ``topic_type_hash``), compressed chunks (log time =
receive, publish time = send), then a ``rosbag2`` metadata record, summary and footer; each file
of a split bag is complete on its own. ``NAME/metadata.yaml`` (version 9, storage ``mcap``) is
written on close. Raw CDR (with its encapsulation header) is written as it is. The chunk in
progress reaches the OS at least every ``flush_period_s``, so a killed writer loses at most that
(:mod:`bike_rig.bag.recover` rebuilds the bag).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from importlib.metadata import version as package_version
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import yaml
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2.metadata import dump_qos_v9

from .. import __version__
from ..config.topics import QosSpec
from .errors import BagError, BagExistsError
from .filesize import MESSAGE_RECORD_OVERHEAD, RATIO_MIN_BYTES, FileStats
from .typestore import message_definition, type_hash

__all__ = [
    "METADATA_VERSION",
    "ROS_DISTRO",
    "BagWriter",
    "Compression",
    "TopicCount",
    "contract_qos",
    "data_file_name",
]

METADATA_VERSION = 9
"""rosbag2 metadata version written (rosbag2 writes 9 since Jazzy)."""

ROS_DISTRO = "kilted"
"""The ROS distribution the rig runs on (``ros_distro`` in metadata.yaml)."""

PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
METADATA_RECORD = "rosbag2"

_ZERO = QosTime(0, 0)


class Compression(str, Enum):
    """Compression of the MCAP chunks (every MCAP reader and Foxglove read all three)."""

    ZSTD = "zstd"
    LZ4 = "lz4"
    NONE = "none"


_MCAP_COMPRESSION = {
    Compression.ZSTD: CompressionType.ZSTD,
    Compression.LZ4: CompressionType.LZ4,
    Compression.NONE: CompressionType.NONE,
}


def data_file_name(bag: Path, index: int = 0) -> str:
    """The name of the bag's ``index``-th storage file, as rosbag2 names it: ``NAME_0.mcap``."""
    return f"{bag.name}_{index}.mcap"


def contract_qos(spec: QosSpec) -> Qos:
    """A QoS of :mod:`bike_rig.config.topics` as rosbag2 describes an offered profile.

    KEEP_LAST with the depth; deadline, lifespan and lease left at the system default.
    """
    return Qos(
        QosHistory.KEEP_LAST,
        spec.depth,
        QosReliability.RELIABLE if spec.reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if spec.transient_local else QosDurability.VOLATILE,
        _ZERO,
        _ZERO,
        QosLiveliness.SYSTEM_DEFAULT,
        _ZERO,
        False,
    )


def _qos_yaml(profiles: Sequence[Qos]) -> str:
    """The offered QoS profiles as rosbag2 stores them in a channel's metadata (v9 YAML)."""
    dumped = dump_qos_v9(list(profiles))
    return yaml.safe_dump(dumped, sort_keys=False, default_flow_style=False).strip() if dumped else ""


@dataclass
class _Channel:
    id: int
    name: str
    msgtype: str
    type_hash: str
    offered_qos: list[Qos]
    count: int = 0


@dataclass(frozen=True)
class TopicCount:
    """One topic of a closed bag: name, type and number of messages."""

    name: str
    msgtype: str
    count: int


@dataclass
class _Stats:
    start: int = 2**63 - 1
    end: int = 0
    count: int = 0
    chunks_flushed: int = 0
    last_flush: float = field(default_factory=time.monotonic)


class BagWriter:
    """A rosbag2 bag with MCAP storage, written from serialized messages.

    Use as a context manager (closes on success, leaves the data file as written on an
    exception, like a crash), or call :meth:`open` and :meth:`close`.

    Args:
        path: The bag directory to create. It must not exist.
        compression: Chunk compression.
        flush_period_s: Longest time a written message may stay in memory, s (> 0).
        chunk_size: A chunk is also closed when it reaches this size, bytes.
        custom_data: String pairs stored as ``custom_data`` in metadata.yaml.
        fsync: Also ask the OS to write every flushed chunk to the disk (survives a power
            cut, not only a crash of the process; slower).
        max_bytes: Split the bag into a new storage file before a file exceeds this size,
            bytes (0: never). A message goes in while it would fit even if the chunk in
            progress did not compress (closing records counted); beyond that the chunk is
            flushed to measure it, unless small and over even at the file's compression ratio.
        max_duration_s: Split before a message whose log time is this far from the file's
            first, s (0: never). A message is never split from its file or lost.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        compression: Compression | str = Compression.ZSTD,
        flush_period_s: float = 0.5,
        chunk_size: int = 1 << 20,
        custom_data: Mapping[str, str] | None = None,
        fsync: bool = False,
        max_bytes: int = 0,
        max_duration_s: float = 0.0,
    ) -> None:
        """Check and keep the settings; nothing is created on disk before :meth:`open`.

        Raises:
            BagError: The compression is unknown, the flush period is not positive or a split
                limit is negative.
        """
        self.path = Path(path)
        try:
            self.compression = Compression(compression)
        except ValueError:
            choices = ", ".join(c.value for c in Compression)
            raise BagError(str(path), f"unknown compression {compression!r} (use {choices})") from None
        if not flush_period_s > 0:
            raise BagError(str(path), f"flush period must be positive, got {flush_period_s!r} s")
        self.flush_period_s = float(flush_period_s)
        if not (max_bytes >= 0 and max_duration_s >= 0):
            limits = f"{max_bytes!r} B, {max_duration_s!r} s"
            raise BagError(str(path), f"split limits must be 0 (off) or positive, got {limits}")
        self.max_bytes = int(max_bytes)
        self.max_duration_ns = int(round(float(max_duration_s) * 1e9))
        self.chunk_size = int(chunk_size)
        self.custom_data = dict(custom_data or {})
        self.fsync = fsync
        self.data_path = self.path / data_file_name(self.path)
        self._stream: IO[bytes] | None = None
        self._mcap: McapWriter | None = None
        self._channels: dict[str, _Channel] = {}
        self._schemas: dict[str, int] = {}
        self._msgdefs: dict[str, str] = {}
        self._stats = _Stats()
        self._files: list[FileStats] = []
        self._metadata_bytes = 0
        self._summary_bytes = 0
        """Bytes of the schema and channel records of the current file (its summary repeats them)."""
        self._closed = False

    # ------------------------------------------------------------------ life cycle
    def open(self) -> None:
        """Create the bag directory and its MCAP file and write the MCAP header.

        Raises:
            BagExistsError: The path exists (a bag is never overwritten).
            BagError: The directory or file cannot be created.
        """
        if self.path.exists() or self.path.is_symlink():
            raise BagExistsError(str(self.path), "exists already; a bag is never overwritten (choose another output)")
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise BagExistsError(str(self.path), "exists already; a bag is never overwritten") from None
        except OSError as exc:
            raise BagError(str(self.path), f"cannot create the bag ({exc.strerror or exc})") from None
        self._stats = _Stats()
        self._files = []
        try:
            self._open_file()
        except FileExistsError:
            raise BagExistsError(str(self.data_path), "exists already; a bag is never overwritten") from None
        except OSError as exc:
            with contextlib.suppress(OSError):
                self.path.rmdir()  # the directory just created, empty again
            raise BagError(str(self.path), f"cannot create {self.data_path.name} ({exc.strerror or exc})") from None

    def _open_file(self) -> None:
        """Create the next storage file, write its MCAP header and every topic known so far.

        Raises:
            OSError: The file cannot be created or written (out of space or inodes, read-only).
                A file created but not written to the end is removed: it holds no message,
                and a bag with an empty storage file would not recover.
        """
        self.data_path = self.path / data_file_name(self.path, len(self._files))
        self._stream = self.data_path.open("xb")
        try:
            self._mcap = McapWriter(
                self._stream,
                chunk_size=self.chunk_size,
                compression=_MCAP_COMPRESSION[self.compression],
            )
            library = f"bike_rig {__version__}; mcap-python {package_version('mcap')}"
            self._mcap.start(profile=PROFILE, library=library)
            self._schemas = {}
            self._summary_bytes = 0
            for ch in self._channels.values():
                ch.id = 0  # registered in this file with its first message here
            self._mcap.flush()
        except OSError:
            self.abort()
            with contextlib.suppress(OSError):
                self.data_path.unlink()
            raise
        ratio = self._files[-1].ratio if self._files else 1.0
        self._files.append(FileStats(self.data_path.name, ratio=ratio))
        self._files[-1].size = self._files[-1].header = self._stream.tell()
        self._metadata_bytes = self._metadata_record_size()

    def _metadata_record_size(self) -> int:
        """Bytes the rosbag2 metadata record would take now (a file's closing records hold it)."""
        return len(yaml.safe_dump(self.metadata()["rosbag2_bagfile_information"], sort_keys=False)) + 64

    def _register(self, name: str, msgtype: str, msgdef: str, rihs01: str, offered_qos: Sequence[Qos]) -> int:
        """Register a channel (and its type's schema the first time) in the current file; its id."""
        mcap = self._require_open()
        schema_id = self._schemas.get(msgtype)
        if schema_id is None:
            data = msgdef.encode("utf-8")
            schema_id = mcap.register_schema(msgtype, SCHEMA_ENCODING, data)
            self._schemas[msgtype] = schema_id
            self._summary_bytes += 27 + len(msgtype) + len(SCHEMA_ENCODING) + len(data)
        metadata = {"offered_qos_profiles": _qos_yaml(offered_qos), "topic_type_hash": rihs01}
        self._summary_bytes += 25 + len(name) + len(MESSAGE_ENCODING)
        self._summary_bytes += sum(8 + len(k) + len(v) for k, v in metadata.items())
        return mcap.register_channel(name, MESSAGE_ENCODING, schema_id, metadata)

    def add_topic(
        self,
        name: str,
        msgtype: str,
        *,
        offered_qos: Sequence[Qos] = (),
        msgdef: str | None = None,
        rihs01: str | None = None,
    ) -> None:
        """Add a topic to the bag (listed in metadata.yaml).

        Its channel, and its type's schema, are written into a storage file with the file's first
        message of the topic: an MCAP file's summary lists only what its data section holds.

        Args:
            name: Topic name.
            msgtype: Full type name, e.g. ``bike_rig_msgs/msg/GyroBatch``.
            offered_qos: The QoS profiles its publishers offer.
            msgdef: The ``ros2msg`` schema text; from the rig's typestore if None.
            rihs01: The type hash; from the rig's typestore if None.
        """
        self._require_open()
        if name in self._channels:
            raise BagError(str(self.path), f"topic {name} added twice")
        if msgdef is None:
            msgdef = self._msgdefs.get(msgtype) or message_definition(msgtype)
        if rihs01 is None:
            rihs01 = type_hash(msgtype)
        self._msgdefs.setdefault(msgtype, msgdef)
        self._channels[name] = _Channel(0, name, msgtype, rihs01, list(offered_qos))
        self._metadata_bytes = self._metadata_record_size()

    def topic_qos(self, name: str) -> list[Qos]:
        """The offered QoS profiles a topic was added with."""
        return list(self._channels[name].offered_qos)

    def has_topic(self, name: str) -> bool:
        """Whether the topic has been added."""
        return name in self._channels

    def write(
        self,
        topic: str,
        log_time: int,
        data: bytes,
        publish_time: int | None = None,
        sequence: int = 0,
    ) -> None:
        """Write one serialized message.

        Args:
            topic: A topic added before.
            log_time: When it was received, ns since the epoch.
            data: The CDR bytes, encapsulation header included.
            publish_time: When it was sent, ns since the epoch (``log_time`` if unknown).
            sequence: The publisher's sequence number (0 if unknown).
        """
        self._require_open()
        ch = self._channels[topic]
        if self._split_due(log_time, len(data)):
            self.split()
        mcap = self._require_open()
        if not ch.id:
            before = self._summary_bytes
            ch.id = self._register(ch.name, ch.msgtype, self._msgdefs[ch.msgtype], ch.type_hash, ch.offered_qos)
            self._files[-1].raw_pending += self._summary_bytes - before  # (the records in the chunk too)
        mcap.add_message(
            ch.id,
            log_time=log_time,
            data=data,
            publish_time=log_time if publish_time is None else publish_time,
            sequence=sequence & 0xFFFFFFFF,
        )
        ch.count += 1
        for st in (self._stats, self._files[-1]):
            st.count += 1
            if log_time < st.start:
                st.start = log_time
            if log_time > st.end:
                st.end = log_time
        f = self._files[-1]
        f.raw_pending += len(data) + MESSAGE_RECORD_OVERHEAD
        if self._stream is not None:
            f.written(self._stream.tell())  # a chunk full at chunk_size is written at once
        self.flush_if_due()

    def _split_due(self, log_time: int, size: int) -> bool:
        """Whether a message of ``size`` bytes logged at ``log_time`` [ns] must go into a new file."""
        f = self._files[-1]
        if not f.count:
            return False
        if self.max_duration_ns and log_time - f.start >= self.max_duration_ns:
            return True
        if not self.max_bytes or self._estimated_total(size, worst=True) <= self.max_bytes:
            return False  # it fits even if nothing in the chunk in progress compresses
        if f.raw_pending < RATIO_MIN_BYTES and self._estimated_total(size) > self.max_bytes:
            return True  # over even at the file's ratio, with too little pending to be worth measuring
        if f.raw_pending:  # near the limit: measure the chunk in progress rather than guess
            self.flush()  # (its data may compress worse than the file's so far)
        return self._estimated_total(size, worst=True) > self.max_bytes

    def _estimated_total(self, size: int, worst: bool = False) -> int:
        """Bytes the current file would take on disk, closed, with one more message of ``size`` bytes.

        ``worst``: the chunk in progress as if nothing in it compressed (else at the file's ratio).
        """
        closing = self._summary_bytes + self._metadata_bytes  # (the summary repeats the schemas and channels)
        return self._files[-1].estimated_closed(size, closing, len(self._channels), worst)

    def split(self) -> tuple[str, str]:
        """Close the current storage file (summary, footer) and go on in the next one.

        Returns:
            The names of the file closed and of the new one.

        Raises:
            BagError: The bag is not open.
            OSError: The closed file could not be written to the end, or the next one cannot be
                created (:meth:`abort` then leaves the bag as a crash would).
        """
        self._require_open()
        closed = self._files[-1].name
        self._finish_file()
        self._open_file()
        return closed, self._files[-1].name

    def _finish_file(self) -> None:
        """Finish the current MCAP file: rosbag2 metadata record (the bag so far), summary, footer."""
        mcap, stream = self._require_open(), self._stream
        assert stream is not None
        mcap.flush()  # the last chunk before the closing records
        serialized = yaml.safe_dump(self.metadata()["rosbag2_bagfile_information"], sort_keys=False)
        mcap.add_metadata(METADATA_RECORD, {"serialized_metadata": serialized, "ROS_DISTRO": ROS_DISTRO})
        mcap.finish()
        stream.flush()
        if self.fsync:
            os.fsync(stream.fileno())
        self._files[-1].size = stream.tell()
        stream.close()
        self._mcap = None
        self._stream = None

    def flush(self) -> None:
        """Close the chunk in progress and hand everything written so far to the OS."""
        mcap = self._require_open()
        mcap.flush()
        if self.fsync and self._stream is not None:
            os.fsync(self._stream.fileno())
        if self._stream is not None:
            self._files[-1].written(self._stream.tell())
        self._stats.chunks_flushed += 1
        self._stats.last_flush = time.monotonic()

    def flush_if_due(self, now: float | None = None) -> bool:
        """Flush if the last flush is ``flush_period_s`` or more ago; True if it flushed."""
        if self._mcap is None:
            return False
        now = time.monotonic() if now is None else now
        if now - self._stats.last_flush >= self.flush_period_s:
            self.flush()
            return True
        return False

    def close(self) -> list[TopicCount]:
        """Finish the MCAP file (rosbag2 metadata record, summary, footer) and write metadata.yaml.

        Safe to call twice.

        Returns:
            Every topic with its message count, in the order added.

        Raises:
            OSError: The storage file or metadata.yaml cannot be written (out of space or
                inodes, read-only). Every chunk flushed before is on disk; call :meth:`abort`,
                and the bag needs :mod:`bike_rig.bag.recover`. No partial metadata.yaml is left.
        """
        if self._closed or self._mcap is None or self._stream is None:
            return self.topic_counts
        self._finish_file()
        text = yaml.safe_dump(self.metadata(), sort_keys=False)
        tmp = self.path / "metadata.yaml.tmp"
        try:
            tmp.write_text(text, encoding="utf-8")
            tmp.replace(self.path / "metadata.yaml")
        except OSError:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
            raise
        self._closed = True
        return self.topic_counts

    def abort(self) -> None:
        """Stop writing without a summary or metadata.yaml (what a crash leaves, minus the chunk in progress).

        The bag then needs :mod:`bike_rig.bag.recover`. Never raises: a write that fails here
        (the disk is still full) loses only what a crash would.
        """
        stream, self._stream, self._mcap = self._stream, None, None
        if stream is not None:
            with contextlib.suppress(OSError):  # the buffered tail; the file is closed anyway
                stream.close()

    def __enter__(self) -> BagWriter:
        """Open the bag (:meth:`open`) and return the writer."""
        self.open()
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        """Close the bag on a normal exit; on an exception abort it, as a crash would leave it."""
        if exc_type is None:
            self.close()
        else:
            self.abort()

    # ------------------------------------------------------------------ state
    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self._stats.count

    @property
    def topic_counts(self) -> list[TopicCount]:
        """Every topic with its message count so far, in the order added."""
        return [TopicCount(c.name, c.msgtype, c.count) for c in self._channels.values()]

    @property
    def files(self) -> list[str]:
        """The names of the storage files so far, in order (the last one is being written)."""
        return [f.name for f in self._files]

    @property
    def bytes_written(self) -> int:
        """Bytes handed to the OS so far, over every storage file (as of the last flush)."""
        return sum(f.size for f in self._files)

    @property
    def chunks_flushed(self) -> int:
        """How many times the writer has flushed."""
        return self._stats.chunks_flushed

    def metadata(self) -> dict[str, Any]:
        """The content of metadata.yaml for what has been written so far."""
        st = self._stats
        start = st.start if st.count else 0
        duration = st.end - st.start if st.count else 0
        files = self._files or [FileStats(self.data_path.name)]
        topics = [
            {
                "topic_metadata": {
                    "name": c.name,
                    "type": c.msgtype,
                    "serialization_format": MESSAGE_ENCODING,
                    "offered_qos_profiles": dump_qos_v9(c.offered_qos),
                    "type_description_hash": c.type_hash,
                },
                "message_count": c.count,
            }
            for c in self._channels.values()
        ]
        return {
            "rosbag2_bagfile_information": {
                "version": METADATA_VERSION,
                "storage_identifier": "mcap",
                "duration": {"nanoseconds": duration},
                "starting_time": {"nanoseconds_since_epoch": start},
                "message_count": st.count,
                "topics_with_message_count": topics,
                "compression_format": "",
                "compression_mode": "",
                "relative_file_paths": [f.name for f in files],
                "files": [f.entry() for f in files],
                "custom_data": dict(self.custom_data) or None,
                "ros_distro": ROS_DISTRO,
            }
        }

    def _require_open(self) -> McapWriter:
        if self._mcap is None:
            raise BagError(str(self.path), "the bag is not open for writing")
        return self._mcap
