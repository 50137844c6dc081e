"""Make the bag of a recording that did not end cleanly readable again.

A killed recorder leaves no metadata.yaml and an MCAP file without summary and footer, maybe cut
mid-record; every chunk it flushed is whole. :func:`scan_mcap` keeps every complete record
(schemas, channels, messages, the records of every chunk whose checksum holds) up to the cut;
:func:`recover_bag` writes them into a new bag (times, sequence numbers, bytes, QoS, type hashes
and schemas kept) and counts each topic's messages. It names what it could not recover (missing
storage files, channels that are not ROS 2 CDR with a ``ros2msg`` schema:
:mod:`bike_rig.bag.foreign`) and refuses another tool's file in one line. The damaged bag is
never modified.
"""

from __future__ import annotations

import shutil
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import BinaryIO

import yaml
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk
from rosbags.rosbag2.errors import ReaderError
from rosbags.rosbag2.metadata import parse_qos

from .check import check_metadata, within_limits
from .errors import BagError, BagExistsError, BagReadError, NotABagError
from .foreign import ChannelShape, foreign_reason, not_ros2_error
from .reader import MCAP_MAGIC, listed_files, split_order
from .typestore import standard_typestore, type_hash
from .writer import BagWriter, Compression

__all__ = [
    "McapScan",
    "MissingFile",
    "Recovery",
    "TopicRecovery",
    "missing_files",
    "recover_bag",
    "scan_mcap",
    "storage_files",
]

#: The schema encoding the recovered bag's writer writes (a channel with another is not copied).
_WRITTEN_SCHEMA = "ros2msg"

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
_RECORD_LIMIT = 1 << 32


@dataclass
class McapScan:
    """What :func:`scan_mcap` could read from one MCAP file.

    Attributes:
        path: The file.
        size: Its size, bytes.
        profile: The header's profile (``ros2`` for rosbag2).
        schemas: Schema records by id.
        channels: Channel records by id.
        messages: Every complete message, in file order.
        complete: The file ends with its footer (it was closed cleanly).
        read_bytes: Bytes up to the end of the last complete record.
        chunks: Complete chunks read.
        bad_chunks: Complete chunks skipped because they do not decompress or fail their
            checksum.
        stop_reason: Why reading stopped before the footer ("" when complete).
        compression: The compression of the chunks ("" when none).
        chunk_ends: The byte offset just after each complete chunk read, with the number of
            messages read by then.
    """

    path: Path
    size: int = 0
    profile: str = ""
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[Message] = field(default_factory=list)
    complete: bool = False
    read_bytes: int = 0
    chunks: int = 0
    bad_chunks: int = 0
    stop_reason: str = ""
    compression: str = ""
    chunk_ends: list[tuple[int, int]] = field(default_factory=list)


def _records(f: BinaryIO, scan: McapScan) -> Iterator[tuple[int, bytes]]:
    """Complete (opcode, body) records after the magic; sets scan.stop_reason at a cut."""
    offset = len(MCAP_MAGIC)
    while True:
        head = f.read(9)
        if len(head) < 9:
            scan.stop_reason = "end of file" if not head else f"cut in a record header at byte {offset}"
            return
        opcode, length = struct.unpack("<BQ", head)
        if length > _RECORD_LIMIT:
            scan.stop_reason = f"implausible record length {length} at byte {offset} (corrupt)"
            return
        body = f.read(length)
        if len(body) < length:
            scan.stop_reason = f"cut at byte {offset + 9 + len(body)}, in a record of {length} bytes at byte {offset}"
            return
        offset += 9 + length
        scan.read_bytes = offset
        yield opcode, body


def scan_mcap(path: str | Path) -> McapScan:
    """Read every complete record of an MCAP file, however it ends.

    A file shorter than the magic that starts like it (an empty one included) was cut as it was
    created: it holds nothing, and is not complete.

    Raises:
        NotABagError: The file does not start with the MCAP magic.
        BagReadError: It cannot be read.
    """
    path = Path(path)
    scan = McapScan(path)
    try:
        with path.open("rb") as f:
            scan.size = f.seek(0, 2)
            f.seek(0)
            head = f.read(len(MCAP_MAGIC))
            if len(head) < len(MCAP_MAGIC) and MCAP_MAGIC.startswith(head):
                # created, then cut before its magic was written (a recorder killed right after a split)
                scan.stop_reason = f"cut before its first record ({scan.size} bytes)"
                return scan
            if head != MCAP_MAGIC:
                raise NotABagError(str(path), "not an MCAP file (bad magic)")
            scan.read_bytes = len(MCAP_MAGIC)
            _scan_records(f, scan)
    except OSError as exc:
        raise BagReadError(str(path), f"cannot read ({exc.strerror or exc})") from None
    return scan


def _scan_records(f: BinaryIO, scan: McapScan) -> None:
    for opcode, body in _records(f, scan):
        stream = ReadDataStream(BytesIO(body))
        try:
            if opcode == _OP_FOOTER:
                scan.complete = True
                scan.stop_reason = ""
                return
            if opcode == _OP_HEADER:
                scan.profile = stream.read(stream.read4()).decode("utf-8")
            elif opcode == _OP_SCHEMA:
                schema = Schema.read(stream)
                scan.schemas.setdefault(schema.id, schema)
            elif opcode == _OP_CHANNEL:
                channel = Channel.read(stream)
                scan.channels.setdefault(channel.id, channel)
            elif opcode == _OP_MESSAGE:
                scan.messages.append(Message.read(stream, len(body)))
            elif opcode == _OP_CHUNK:
                _scan_chunk(Chunk.read(stream), scan)
                scan.chunk_ends.append((scan.read_bytes, len(scan.messages)))
        except (struct.error, ValueError, UnicodeDecodeError, EOFError) as exc:
            scan.stop_reason = f"corrupt record (opcode 0x{opcode:02x}): {exc}"
            return
        except Exception as exc:  # mcap's EndOfFile and friends: a record shorter than it says
            scan.stop_reason = f"corrupt record (opcode 0x{opcode:02x}): {type(exc).__name__}"
            return


def _scan_chunk(chunk: Chunk, scan: McapScan) -> None:
    try:
        records = breakup_chunk(chunk, validate_crc=True)
    except (ValueError, zlib.error, RuntimeError, OSError, EOFError, struct.error, MemoryError):
        scan.bad_chunks += 1
        return
    except Exception:  # zstandard/lz4 errors are their own classes
        scan.bad_chunks += 1
        return
    scan.chunks += 1
    scan.compression = scan.compression or chunk.compression
    for r in records:
        if isinstance(r, Message):
            scan.messages.append(r)
        elif isinstance(r, Schema):
            scan.schemas.setdefault(r.id, r)
        elif isinstance(r, Channel):
            scan.channels.setdefault(r.id, r)


@dataclass(frozen=True)
class MissingFile:
    """A storage file of the bag that is not there: its name and what says it belongs to the bag."""

    name: str
    why: str


def missing_files(bag: str | Path) -> tuple[list[MissingFile], str]:
    """The storage files a bag directory should hold but does not, and a note when metadata.yaml cannot tell.

    A file is missing when metadata.yaml lists it, or when it is numbered between the bag's
    other files (``NAME_1.mcap`` beside ``NAME_0.mcap`` and ``NAME_2.mcap``: the recorder
    numbers them from 0 as it writes them; a missing last file only metadata.yaml can tell).

    Returns:
        The missing files, and why metadata.yaml was not read ("" when it was, or there is none).
    """
    p = Path(bag)
    if not p.is_dir():
        return [], ""
    out: dict[str, MissingFile] = {}
    note = ""
    if (p / "metadata.yaml").is_file():
        try:
            listed = listed_files(check_metadata(p / "metadata.yaml", str(bag)))
        except BagError as exc:
            listed, note = [], f"metadata.yaml cannot be read ({exc.reason}): the files it lists are not known"
        for name in listed:
            if not (p / name).is_file():
                out[name] = MissingFile(name, "metadata.yaml lists it")
    numbered: dict[str, set[int]] = {}
    for f in p.glob("*.mcap"):
        stem, index, _ = split_order(f)
        if index >= 0:
            numbered.setdefault(stem, set()).add(index)
    for stem, present in sorted(numbered.items()):
        for k in sorted(set(range(max(present))) - present):
            name = f"{stem}_{k}.mcap"
            out.setdefault(name, MissingFile(name, "the files numbered after it are here"))
    return sorted(out.values(), key=lambda m: split_order(Path(m.name))), note


def storage_files(bag: str | Path) -> list[Path]:
    """The MCAP files of a bag directory (or the file itself), a split bag's in recording order.

    Raises:
        BagError: The path does not exist, or holds no MCAP file.
    """
    p = Path(bag)
    if not p.exists():
        raise BagError(str(bag), "no such file or directory")
    if p.is_file():
        return [p]
    files = sorted(p.glob("*.mcap"), key=split_order)
    if not files:
        raise NotABagError(str(bag), "not a bag with MCAP storage (no .mcap file)")
    return files


@dataclass(frozen=True)
class TopicRecovery:
    """One topic of a recovered bag.

    Attributes:
        name: Topic name.
        msgtype: Type name.
        count: Messages recovered.
        first: Log time of the first one, ns since the epoch (0 if none).
        last: Log time of the last one, ns since the epoch (0 if none).
    """

    name: str
    msgtype: str
    count: int
    first: int
    last: int


@dataclass(frozen=True)
class Recovery:
    """What :func:`recover_bag` did.

    Attributes:
        source: The damaged bag, as given.
        output: The new bag.
        topics: Every recovered topic, in channel order.
        files: The scans of the source's MCAP files.
        skipped: Channels left out, with the reason and the messages not copied.
        missing: Storage files of the bag that are not there (:func:`missing_files`).
        notes: What else limits what is known (metadata.yaml unreadable).
    """

    source: str
    output: Path
    topics: tuple[TopicRecovery, ...]
    files: tuple[McapScan, ...]
    skipped: tuple[str, ...]
    missing: tuple[MissingFile, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def message_count(self) -> int:
        """Messages recovered."""
        return sum(t.count for t in self.topics)

    @property
    def was_complete(self) -> bool:
        """Whether every source file had its footer and none is missing (nothing was damaged)."""
        return all(s.complete for s in self.files) and not self.missing

    @property
    def nothing_lost(self) -> bool:
        """Whether nothing was lost: complete, no corrupt chunk, no channel left out."""
        return self.was_complete and not self.skipped and not any(s.bad_chunks for s in self.files)

    @property
    def lost_bytes(self) -> int:
        """Bytes after the last complete record (the cut-off tail), over all files."""
        return sum(s.size - s.read_bytes for s in self.files if not s.complete)

    @property
    def last_time(self) -> int:
        """Log time of the last message recovered, ns since the epoch (0 if none)."""
        return max((t.last for t in self.topics), default=0)


def _type_hash(channel: Channel, schema: Schema) -> str:
    recorded = channel.metadata.get("topic_type_hash", "")
    if recorded:
        return recorded
    if schema.name in standard_typestore().fielddefs:
        return type_hash(schema.name)
    return ""


def default_output(bag: str | Path) -> Path:
    """Where :func:`recover_bag` writes when no output is given: ``<BAG>_recovered`` beside it."""
    p = Path(bag)
    stem = p.stem if p.is_file() else p.name
    return p.parent / f"{stem}_recovered"


def _refusal(s: McapScan, ch: Channel) -> str:
    """Why a channel is not copied ("" when it is: CDR messages, a ros2msg schema)."""
    schema = s.schemas.get(ch.schema_id) if ch.schema_id else None
    shape = ChannelShape(
        ch.topic, ch.message_encoding, schema.name if schema else "", schema.encoding if schema else None
    )
    reason = foreign_reason(None, [shape])
    if not reason and schema is not None and schema.encoding != _WRITTEN_SCHEMA:
        reason = (
            f"channel {ch.topic}: its schema {schema.name} has encoding {schema.encoding!r} "
            f"(a recovered bag holds {_WRITTEN_SCHEMA} schemas only)"
        )
    return reason


def _check_scans(bag: str | Path, scans: tuple[McapScan, ...]) -> None:
    """Refuse files that are not rosbag2 MCAP, and a bag with no readable channel at all."""
    for s in scans:
        if s.profile and s.profile != "ros2":
            reason = next((r for ch in s.channels.values() if (r := _refusal(s, ch))), "")
            raise not_ros2_error(s.path, str(bag), reason or f"MCAP profile {s.profile!r} is not 'ros2'")
    if not any(s.channels for s in scans):
        reasons = "; ".join(f"{s.path.name}: {s.stop_reason or 'no channel'}" for s in scans)
        raise BagReadError(str(bag), f"nothing to recover: no complete chunk holds a channel ({reasons})")
    refused = [(s, r) for s in scans for ch in s.channels.values() if (r := _refusal(s, ch))]
    if len(refused) == sum(len(s.channels) for s in scans):
        s, reason = refused[0]
        raise not_ros2_error(s.path, str(bag), reason)


def _add_channels(
    writer: BagWriter, s: McapScan, skipped: list[str], stats: dict[str, list[int]], types: dict[str, str]
) -> dict[int, str]:
    """Add the ROS 2 CDR channels of one scanned file to ``writer`` (each topic once).

    Channels that are not (:func:`_refusal`) are named in ``skipped``; a new topic gets zeroed
    ``stats`` (count, first and last log time [ns]) and its type in ``types``.

    Returns:
        The topic of each channel id copied.
    """
    topic_of: dict[int, str] = {}
    for cid, ch in s.channels.items():
        schema = s.schemas.get(ch.schema_id)
        reason = _refusal(s, ch)
        if reason or schema is None:
            lost = sum(1 for m in s.messages if m.channel_id == cid)
            skipped.append(f"{s.path.name}: {reason or 'no schema'} ({lost} messages not copied)")
            continue
        if not writer.has_topic(ch.topic):
            try:
                text = ch.metadata.get("offered_qos_profiles", "")
                within_limits(text)  # ruamel's and libyaml's composers recurse: a deep text crashes them
                qos = parse_qos(text)
            except (ReaderError, KeyError, TypeError, ValueError, yaml.YAMLError):  # YamlLimitError is a ValueError
                qos = []
            writer.add_topic(
                ch.topic,
                schema.name,
                offered_qos=qos,
                msgdef=schema.data.decode("utf-8"),
                rihs01=_type_hash(ch, schema),
            )
            stats[ch.topic] = [0, 0, 0]
            types[ch.topic] = schema.name
        topic_of[cid] = ch.topic
    return topic_of


def _copy_messages(writer: BagWriter, s: McapScan, topic_of: dict[int, str], stats: dict[str, list[int]]) -> None:
    """Write the messages of one scanned file's copied channels, counting them in ``stats``."""
    for m in s.messages:
        name = topic_of.get(m.channel_id)
        if name is None:
            continue
        writer.write(name, m.log_time, m.data, m.publish_time, m.sequence)
        st = stats[name]
        st[0] += 1
        st[1] = m.log_time if st[0] == 1 else min(st[1], m.log_time)
        st[2] = max(st[2], m.log_time)


def recover_bag(bag: str | Path, output: str | Path | None = None) -> Recovery:
    """Rewrite every readable message of a (possibly damaged) bag into a new, valid bag.

    Args:
        bag: The bag directory, or one of its MCAP files.
        output: The new bag directory (default ``<BAG>_recovered``); must not exist.

    Returns:
        What was recovered, per topic.

    Raises:
        BagExistsError: The output exists.
        BagError: No MCAP file, not MCAP, unreadable, or nothing readable at all.
    """
    missing, note = missing_files(bag)
    if missing and Path(bag).is_dir() and not any(Path(bag).glob("*.mcap")):
        names = ", ".join(m.name for m in missing)
        raise BagReadError(str(bag), f"nothing to recover: every storage file metadata.yaml lists is missing ({names})")
    files = storage_files(bag)
    out = Path(output) if output is not None else default_output(bag)
    if out.exists():
        raise BagExistsError(str(out), "exists already; choose another output with -o")
    scans = tuple(scan_mcap(f) for f in files)
    _check_scans(bag, scans)
    compression = next((s.compression for s in scans if s.compression), "")
    writer = BagWriter(
        out,
        compression=compression if compression in ("zstd", "lz4") else Compression.NONE,
        flush_period_s=3600.0,
        custom_data={"recovered_from": str(bag)},
    )
    writer.open()
    skipped: list[str] = []
    stats: dict[str, list[int]] = {}
    types: dict[str, str] = {}
    try:
        for s in scans:
            topic_of = _add_channels(writer, s, skipped, stats, types)
            _copy_messages(writer, s, topic_of, stats)
        writer.close()
    except BaseException:
        writer.abort()
        shutil.rmtree(out, ignore_errors=True)
        raise
    topics = tuple(TopicRecovery(name, types[name], *stats[name]) for name in stats)
    return Recovery(str(bag), out, topics, scans, tuple(skipped), tuple(missing), (note,) if note else ())
