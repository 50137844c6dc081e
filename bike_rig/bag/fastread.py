"""A fast read path for the common bag, giving exactly what rosbags' reader gives.

The common bag is a rosbag2 directory (``metadata.yaml``, MCAP storage files with a summary,
chunk indexes and message indexes, no file or message compression) or one such ``.mcap``
file. For it, :func:`open_fast` reads the index (topics, counts, times) with no YAML parser
beyond libyaml, and :func:`bike_rig.bag.msgtable.read_table` reads every message of some
topics in the order rosbags yields them as one table, with no Python object per message.

Anything else (SQLite storage, compressed files or messages, unindexed or malformed MCAP,
metadata that PyYAML and ruamel might read differently, a failing checksum...) raises
:class:`Unusual`: the caller then reads the bag with rosbags, which gives the same result
or the error the user must see. The rules mirrored are those of rosbags 0.11
(``rosbag2/reader.py`` and ``rosbag2/storage_mcap.py``).
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path, PurePath
from typing import Any, cast

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from ..core.safe_yaml import YamlLimitError
from .check import Metadata, within_limits

__all__ = [
    "MAGIC",
    "Chunk",
    "FastBag",
    "FastTopic",
    "Storage",
    "UnsafeYaml",
    "Unusual",
    "need",
    "open_fast",
    "split_order",
]

MAGIC = b"\x89MCAP0\r\n"
_FOOTER_HEAD = b"\x02\x14\x00\x00\x00\x00\x00\x00\x00"

#: Plain scalars that YAML 1.1 (PyYAML) and YAML 1.2 (ruamel, as rosbags reads) may read
#: differently: booleans beyond true/false, octal, hex, binary, sexagesimal, underscores,
#: merge keys and tags. A metadata text holding one is left to rosbags.
_RISKY_YAML = re.compile(
    r"(?:^|[:\-\[,]\s*)(?:[-+]?0[0-9_oxbOXB]|[-+]?\d[\d_]*:[0-5]?\d|[-+]?[\d.]+_|[-+]?\.?\d[\d.]*[eE])"
    r"|(?:^|[:\-\[,]\s+)(?i:y|n|yes|no|on|off)\s*(?:$|[,\]#])"
    r"|<<|!",
    re.M,
)

_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


class Unusual(Exception):
    """The bag is not the common kind this module reads: read it with rosbags instead."""


class UnsafeYaml(Unusual):
    """YAML text in the bag (a channel's QoS profiles) beyond bike_rig's YAML limits: no reader may load it.

    (libyaml's and ruamel's composers recurse, and crash the process, on a text some
    hundred thousand levels deep.)
    """


def _yaml_load(text: str) -> Any:
    """``text`` as rosbags' ruamel would load it, with libyaml (Unusual when they may differ)."""
    if _RISKY_YAML.search(text):
        raise Unusual("metadata YAML with scalars YAML 1.1 and 1.2 read differently")
    try:
        if not within_limits(text):
            raise Unusual("YAML with aliases")
    except YamlLimitError as exc:
        raise UnsafeYaml(exc.reason) from None
    except Exception as exc:  # a YAML error: rosbags says what is wrong
        raise Unusual(f"metadata YAML ({exc})") from None
    try:
        return _libyaml_loader().load(text)
    except Exception as exc:  # no libyaml, a YAML error, a duplicate key: rosbags says what is wrong
        raise Unusual(f"metadata YAML ({exc})") from None


@lru_cache(maxsize=1)
def _libyaml_loader() -> Any:
    """A loader of ``text`` with libyaml that refuses duplicate keys (as ruamel does)."""
    import yaml

    class Loader(yaml.CSafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            keys = [self.construct_object(k, deep=True) for k, _ in node.value]
            if len(set(map(repr, keys))) != len(keys):
                raise ValueError("duplicate key")
            return super().construct_mapping(node, deep)

    class Load:
        @staticmethod
        def load(text: str) -> Any:
            return yaml.load(text, Loader=Loader)

    return Load


def split_order(path: PurePath) -> tuple[str, int, str]:
    """Sort key of a storage file: a split bag's ``NAME_2.mcap`` before ``NAME_10.mcap``.

    (The recorder and rosbag2 number a bag's files in the order they write them.)
    """
    stem, _, index = path.stem.rpartition("_")
    return (stem, int(index), "") if index.isdigit() else (path.stem, -1, path.name)


def need(ok: Any, why: str) -> None:
    """Raise :class:`Unusual` (saying ``why``) unless ``ok``."""
    if not bool(ok):
        raise Unusual(why)


def _is_int(x: object) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _qos(profiles: object) -> tuple[Qos, ...]:
    """QoS profiles (a list of dicts or rosbags' v9 YAML text) parsed as rosbags does."""
    if isinstance(profiles, str):
        return _qos_text(profiles)
    return _qos_list(profiles)


@lru_cache(maxsize=64)
def _qos_text(text: str) -> tuple[Qos, ...]:
    """QoS profiles as YAML text (each channel of a bag holds one; the rig's are few)."""
    return _qos_list(_yaml_load(text) if text else [])


def _qos_list(profiles: object) -> tuple[Qos, ...]:
    need(profiles is None or isinstance(profiles, list), "QoS profiles are not a list")
    try:
        return tuple(_one_qos(item) for item in cast("list[object]", profiles or []))
    except Exception as exc:  # a malformed profile: rosbags raises its own error
        raise Unusual(f"QoS profiles ({exc})") from None


def _policy(kind: Any, value: object) -> Any:
    """A QoS policy as rosbags reads it: an int is the enum's value, a name its member, else UNKNOWN."""
    try:
        return kind(value) if isinstance(value, int) else kind.__members__[cast(str, value).upper()]
    except (KeyError, ValueError):
        return kind(kind.UNKNOWN)


def _one_qos(item: object) -> Qos:
    """One profile (a mapping of metadata.yaml) as rosbags' ``parse_qos`` makes it.

    (rosbags' own function is not imported: importing ``rosbags.rosbag2`` takes ~35 ms.)
    """
    need(isinstance(item, dict), "a QoS profile is not a mapping")
    d = cast("dict[str, Any]", item)
    return Qos(
        _policy(QosHistory, d["history"]),
        d["depth"],
        _policy(QosReliability, d["reliability"]),
        _policy(QosDurability, d["durability"]),
        QosTime(d["deadline"]["sec"], d["deadline"]["nsec"]),
        QosTime(d["lifespan"]["sec"], d["lifespan"]["nsec"]),
        _policy(QosLiveliness, d["liveliness"]),
        QosTime(d["liveliness_lease_duration"]["sec"], d["liveliness_lease_duration"]["nsec"]),
        d["avoid_ros_namespace_conventions"],
    )


# --------------------------------------------------------------------------------------------
# MCAP index
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Channel:
    """One MCAP channel as rosbags' connection: id, topic, type, encoding, offered QoS, and its schema.

    ``schema_encoding`` and ``schema_text`` are its schema's (both "" for a channel without one).
    """

    id: int
    topic: str
    msgtype: str
    encoding: str
    qos: tuple[Qos, ...]
    schema_encoding: str = ""
    schema_text: str = ""


@dataclass(frozen=True)
class Chunk:
    """One chunk index record (rosbags' ChunkInfo)."""

    start_time: int
    end_time: int
    offset: int
    length: int
    index_offsets: dict[int, int]
    index_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    channel_count: dict[int, int]


@dataclass(frozen=True)
class Storage:
    """One MCAP file's index: its channels (in order of first appearance), chunks and statistics."""

    path: Path
    channels: tuple[Channel, ...]
    chunks: tuple[Chunk, ...]
    message_count: int
    start_time: int
    end_time: int
    channel_counts: dict[int, int]


class _Record:
    """A cursor over one record's bytes."""

    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        out = self.data[self.pos : self.pos + n]
        need(len(out) == n, "truncated MCAP record")
        self.pos += n
        return out

    def u16(self) -> int:
        return int(_U16.unpack(self.take(2))[0])

    def u32(self) -> int:
        return int(_U32.unpack(self.take(4))[0])

    def u64(self) -> int:
        return int(_U64.unpack(self.take(8))[0])

    def text(self) -> str:
        return self.take(self.u32()).decode()

    def blob(self) -> bytes:
        return self.take(self.u32())


def _metadata_map(blob: bytes) -> dict[str, str]:
    rec, out = _Record(blob), dict[str, str]()
    while rec.pos < len(blob):
        key = rec.text()
        out.setdefault(key, rec.text())
    return out


_CHUNK_HEAD = struct.Struct("<QQQQI")  # message start and end time, offset, length, index offsets' bytes
_U64_U32 = struct.Struct("<QI")  # message index length, compression's bytes
_U64_U64 = struct.Struct("<QQ")  # compressed and uncompressed size


def _chunk(rec: _Record) -> Chunk:
    """A chunk index record (read with whole-record structs: a recording holds thousands)."""
    data, pos = rec.data, rec.pos
    need(len(data) - pos >= _CHUNK_HEAD.size, "truncated MCAP record")
    start, end, offset, length, n = _CHUNK_HEAD.unpack_from(data, pos)
    pos += _CHUNK_HEAD.size
    need(len(data) - pos >= n + _U64_U32.size, "truncated MCAP record")
    need(n % 10 == 0, "bad message index offsets")
    index_offsets = {int(c): int(o) for c, o in struct.iter_unpack("<HQ", data[pos : pos + n])}
    index_length, k = _U64_U32.unpack_from(data, pos + n)
    pos += n + _U64_U32.size
    need(len(data) - pos >= k + _U64_U64.size, "truncated MCAP record")
    compression = data[pos : pos + k].decode()
    compressed, uncompressed = _U64_U64.unpack_from(data, pos + k)
    rec.pos = pos + k + _U64_U64.size
    # rosbags' message counts per channel (which chunks it reads depends on them)
    ordered = sorted((v, k) for k, v in index_offsets.items())
    ends = [*(v for v, _ in ordered), offset + length + index_length]
    counts = {k: n // 16 for (v, k), nxt in zip(ordered, ends[1:], strict=True) if (n := nxt - v - 15)}
    return Chunk(start, end, offset, length, index_offsets, index_length, compression, compressed, uncompressed, counts)


def _summary(data: bytes, channels: list[Channel], chunks: list[Chunk]) -> tuple[int, int, int, dict[int, int]] | None:
    """Parse the summary section (rosbags' read_index); return the statistics."""
    schemas: dict[int, tuple[str, str, str]] = {}  # name, encoding, text
    seen: set[int] = set()
    stats = None
    pos = 0
    while True:
        need(pos + 9 <= len(data), "truncated MCAP summary")
        op = data[pos]
        if op in (0x02, 0x0E):
            break
        size = _U64.unpack_from(data, pos + 1)[0]
        rec = _Record(data[pos + 9 : pos + 9 + size])
        need(len(rec.data) == size, "truncated MCAP summary record")
        pos += 9 + size
        if op == 0x03:
            key = rec.u16()
            schemas[key] = (rec.text(), rec.text(), rec.text())
        elif op == 0x04:
            key, schema_id = rec.u16(), rec.u16()
            topic, encoding, meta = rec.text(), rec.text(), rec.blob()
            if key not in seen:
                qos = _qos(_metadata_map(meta).get("offered_qos_profiles", ""))
                name, schema_encoding, text = schemas.get(schema_id, ("__schemaless__", "", ""))
                channels.append(Channel(key, topic, name, encoding, qos, schema_encoding, text))
                seen.add(key)
        elif op == 0x08:
            chunks.append(_chunk(rec))
        elif op == 0x0B:
            count, _, _, _, _, _, start, end = struct.unpack("<QHIIIIQQ", rec.take(42))
            pairs = rec.take(rec.u32() // 10 * 10)
            stats = (int(count), int(start), int(end), {int(c): int(n) for c, n in struct.iter_unpack("<HQ", pairs)})
    need(bool(schemas), "MCAP summary without schemas")
    return stats


def read_storage(path: Path) -> Storage:
    """The index of one MCAP file (Unusual unless it has a summary with statistics and chunk indexes)."""
    try:
        with path.open("rb") as f:
            head = f.read(9)
            need(head[:8] == MAGIC and head[8:9] == b"\x01", "bad MCAP header")
            rec = _Record(f.read(_U64.unpack(f.read(8))[0]))
            need(rec.text() == "ros2", "MCAP profile is not ros2")
            data_start = f.tell()
            footer_start = f.seek(-37, 2)
            footer = f.read()
            need(len(footer) == 37 and footer[:9] == _FOOTER_HEAD and footer[-8:] == MAGIC, "bad MCAP footer")
            summary_start = _U64.unpack_from(footer, 9)[0]
            need(bool(summary_start) and data_start <= summary_start <= footer_start, "no MCAP summary")
            f.seek(summary_start)
            summary = f.read()
    except (OSError, struct.error, UnicodeDecodeError) as exc:
        raise Unusual(f"MCAP file ({exc})") from None
    channels: list[Channel] = []
    chunks: list[Chunk] = []
    try:
        stats = _summary(summary, channels, chunks)
    except (struct.error, UnicodeDecodeError, ValueError) as exc:
        raise Unusual(f"MCAP summary ({exc})") from None
    # a file with no message (the last of a split bag, split just before the end) has no chunk
    need(stats is not None and (bool(chunks) or stats[0] == 0), "MCAP summary without statistics or chunk indexes")
    assert stats is not None
    count, start, end, per_channel = stats
    return Storage(path, tuple(channels), tuple(chunks), count, start, end, per_channel)


# --------------------------------------------------------------------------------------------
# The bag
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FastTopic:
    """One of rosbags' connections of the bag: topic, type, count, offered QoS, type hash."""

    name: str
    msgtype: str
    count: int
    qos: tuple[Qos, ...]
    digest: str


@dataclass(frozen=True)
class FastBag:
    """A bag opened by the fast path.

    Attributes:
        storages: Its MCAP files, in the order rosbags reads them.
        connections: rosbags' connections, in its order.
        routes: Per storage file, the topic each of its channels is read as (channels rosbags
            would not map to a connection are absent).
        start_time: Log time of the first message, ns (0 when empty).
        end_time: Log time of the last message, ns (0 when empty).
        message_count: Messages in the bag.
        files: ``metadata.yaml``'s ``files`` entries' paths (empty for a bare MCAP file).
    """

    storages: tuple[Storage, ...]
    connections: tuple[FastTopic, ...]
    routes: tuple[dict[int, str], ...]
    start_time: int
    end_time: int
    message_count: int
    files: tuple[str, ...]


def _topic_entries(meta: dict[str, Any]) -> list[tuple[FastTopic, str]]:
    out = []
    for entry in meta["topics_with_message_count"]:
        tm = entry["topic_metadata"]
        name, msgtype, form = tm["name"], tm["type"], tm["serialization_format"]
        digest, count = tm.get("type_description_hash", ""), entry["message_count"]
        need(all(isinstance(x, str) for x in (name, msgtype, form, digest)) and _is_int(count), "topic metadata")
        need(form == "cdr", "a serialization format other than cdr")
        out.append((FastTopic(name, msgtype, count, _qos(tm.get("offered_qos_profiles", [])), digest), form))
    return out


def _metadata(path: Path, read: Metadata | None) -> Any:
    """The bag's metadata.yaml loaded as rosbags' ruamel would (Unusual when they may differ).

    ``read`` is the document as the reader's checks loaded it (then not loaded again).
    """
    if read is None:
        return _yaml_load((path / "metadata.yaml").read_text())
    need(not _RISKY_YAML.search(read.text), "metadata YAML with scalars YAML 1.1 and 1.2 read differently")
    need(read.plain, "YAML with aliases")
    need(not read.duplicate_keys, "metadata YAML (duplicate key)")
    return read.doc


def _open_directory(path: Path, read: Metadata | None) -> FastBag:
    meta = _metadata(path, read)
    need(isinstance(meta, dict) and isinstance(meta.get("rosbag2_bagfile_information"), dict), "metadata")
    info = meta["rosbag2_bagfile_information"]
    try:
        version, storage_id = info["version"], info["storage_identifier"]
        need(_is_int(version) and version <= 9 and storage_id == "mcap", "not an MCAP bag of version <= 9")
        need(not (info.get("compression_mode", "") or "") and not info.get("compression_format"), "compressed")
        names = info["relative_file_paths"]
        need(isinstance(names, list) and all(isinstance(n, str) for n in names), "relative_file_paths")
        paths = [path / PurePath(n).name for n in names]
        need(all(p.exists() for p in paths), "missing storage files")
        entries = _topic_entries(info)
        duration, start = info["duration"]["nanoseconds"], info["starting_time"]["nanoseconds_since_epoch"]
        count = info["message_count"]
        need(_is_int(duration) and _is_int(start) and _is_int(count), "times and counts")
        files = info.get("files", []) or []
        need(isinstance(files, list), "files")
        file_names = tuple(f["path"] for f in files)
    except (KeyError, TypeError, AttributeError) as exc:
        raise Unusual(f"metadata ({exc})") from None
    storages = tuple(read_storage(p) for p in paths)
    connections = tuple(t for t, _ in entries)
    routes = []
    for storage in storages:
        route = {}
        for ch in storage.channels:
            # rosbags' DirectoryReader.messages: same topic, type, format and offered QoS
            if any(ch.topic == t.name and ch.msgtype == t.msgtype and ch.encoding == f and ch.qos == t.qos
                   for t, f in entries):  # fmt: skip
                route[ch.id] = ch.topic
        routes.append(route)
    return FastBag(
        storages,
        connections,
        tuple(routes),
        start if count else 0,
        start + duration if count else 0,
        int(count),
        file_names,
    )


def _open_mcap(path: Path) -> FastBag:
    storage = read_storage(path)
    connections = tuple(
        FastTopic(ch.topic, ch.msgtype, storage.channel_counts.get(ch.id, 0), ch.qos, "") for ch in storage.channels
    )
    count = storage.message_count
    return FastBag(
        (storage,),
        connections,
        ({ch.id: ch.topic for ch in storage.channels},),
        storage.start_time if count else 0,
        storage.end_time if count else 0,
        count,
        (),
    )


def open_fast(path: Path, metadata: Metadata | None = None) -> FastBag:
    """Open a bag directory or ``.mcap`` file (as resolved by the reader) by the fast path.

    ``metadata``: the directory's metadata.yaml as the reader's checks read it (else read here).

    Raises:
        Unusual: It is not the common kind (see the module docstring).
    """
    if path.is_dir():
        return _open_directory(path, metadata)
    if path.suffix == ".mcap":
        return _open_mcap(path)
    raise Unusual("neither a bag directory nor an .mcap file")
