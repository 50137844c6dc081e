"""Read a bag with no ROS runtime: rosbags' reader, and bike_rig's typestore to decode.

rosbags' reader gives the index (topics, counts, times, QoS) and the messages in log-time
order; the ``mcap`` library reads an MCAP bag's messages with their publication sequence and
place in storage (:meth:`BagReader.records`). Each topic is decoded with the definition its
schema in the bag gives (:meth:`BagReader.decoding`, :mod:`bike_rig.bag.schemas`).

:func:`open_bag` accepts a rosbag2 bag directory (``metadata.yaml`` + storage files, MCAP or
SQLite) or a single ``.mcap`` file, and turns every problem into one
:class:`~bike_rig.bag.errors.BagError` that names the path and the reason: not a bag, not a
ROS 2 CDR bag (another tool's MCAP: :mod:`bike_rig.bag.foreign`), a storage file metadata.yaml
lists but that is missing (or an MCAP file it does not list), a recording that did not end
cleanly (use ``bike-rig bag recover``), unreadable or corrupt files.
"""

from __future__ import annotations

import gc
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path, PurePath
from types import TracebackType
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..core.safe_yaml import NotRegularFileError, open_regular_file
from .check import Metadata, check_mcap, check_metadata
from .chunks import exception_text, file_messages, first_corrupt_chunk, no_collection
from .errors import BagError, BagReadError, IncompleteBagError, NotABagError, ReplayError
from .foreign import check_ros2_cdr
from .order import split_order
from .schemas import Decoding, RecordedSchema, decoding_for

if TYPE_CHECKING:
    from rosbags.interfaces import Qos
    from rosbags.rosbag2 import Reader

__all__ = [
    "MCAP_MAGIC",
    "BagReader",
    "RawMessage",
    "Record",
    "TopicInfo",
    "listed_files",
    "open_bag",
    "split_order",
]

MCAP_MAGIC = b"\x89MCAP0\r\n"


class RawMessage(NamedTuple):
    """One recorded message: topic, log (receive) time in ns since the epoch, CDR bytes."""

    topic: str
    log_time: int
    data: bytes


class Record(NamedTuple):
    """One recorded message with its log time and where the recorder put it.

    Attributes:
        topic: Its topic.
        log_time: Its log (receive) time, ns since the epoch.
        sequence: The publication sequence number the recorder stored with it (0: none).
        stream: Its rank in the recorder's order of storage (file by the split index in its
            name, then place in the file).
        data: The CDR bytes.
    """

    topic: str
    log_time: int
    sequence: int
    stream: int
    data: bytes


def listed_files(metadata: Metadata) -> list[str]:
    """The storage files a bag's metadata.yaml lists (``relative_file_paths``, then ``files``), by name."""
    info = metadata.doc.get("rosbag2_bagfile_information") if isinstance(metadata.doc, dict) else None
    if not isinstance(info, dict):
        return []
    names = [n for n in info.get("relative_file_paths") or [] if isinstance(n, str)]
    names += [f["path"] for f in info.get("files") or [] if isinstance(f, dict) and isinstance(f.get("path"), str)]
    return list(dict.fromkeys(PurePath(n).name for n in names if n))


def _names(names: list[str]) -> str:
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 1 else names[0]


def _check_listed(path: Path, metadata: Metadata, shown: str) -> None:
    """Refuse a bag whose metadata.yaml lists a file that is missing, or does not list one of its MCAP files."""
    listed = listed_files(metadata)
    missing = [n for n in listed if not (path / n).is_file()]
    hint = f"run 'bike-rig bag recover {shown}' to copy what its files hold into a new bag"
    if missing:
        which = "which is" if len(missing) == 1 else "which are"
        raise BagReadError(shown, f"metadata.yaml lists {_names(missing)}, {which} missing ({hint})")
    unlisted = [p.name for p in sorted(path.glob("*.mcap"), key=split_order) if listed and p.name not in listed]
    if unlisted:
        raise BagReadError(shown, f"holds {_names(unlisted)}, which metadata.yaml does not list ({hint})")


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag.

    Attributes:
        name: Topic name.
        msgtype: Full type name.
        count: Number of messages.
        offered_qos: The QoS profiles its publishers offered.
        type_hash: The RIHS01 hash recorded for its type ("" if the bag has none).
        schemas: Its type's definitions as its channels carry them (one per distinct schema;
            none for SQLite storage).
    """

    name: str
    msgtype: str
    count: int
    offered_qos: tuple[Qos, ...]
    type_hash: str
    schemas: tuple[RecordedSchema, ...] = ()


def _check_mcap_file(path: Path, shown: str) -> None:
    """Fail early and clearly on a file that is not MCAP or has no footer."""
    try:
        with path.open("rb") as f:
            head = f.read(8)
            size = f.seek(0, 2)
            tail = b""
            if size >= 16:
                f.seek(-8, 2)
                tail = f.read(8)
    except OSError as exc:
        raise BagReadError(shown, f"cannot read {path.name} ({exc.strerror or exc})") from None
    if head != MCAP_MAGIC:
        what = "empty file" if not head else "not an MCAP file (bad magic)"
        raise NotABagError(shown, what if path.name == Path(shown).name else f"{path.name}: {what}")
    if tail != MCAP_MAGIC:
        raise IncompleteBagError(
            shown,
            f"{path.name} has no summary or footer: the recording did not end cleanly "
            f"(run 'bike-rig bag recover {shown}' to make it readable)",
        )
    check_mcap(path, shown)


def _regular(path: Path, shown: str) -> None:
    """Refuse a FIFO, a device, a socket or a symlink loop where a bag's file belongs, naming what it is."""
    try:
        open_regular_file(path.name, path).close()
    except NotRegularFileError as exc:
        raise BagReadError(shown, exc.reason if path == Path(shown) else f"{path.name} {exc.reason}") from None


def _check_exists(path: Path, shown: str) -> None:
    """Refuse a path that is not there (a symlink loop or a broken symlink named as such)."""
    if path.is_symlink() and not path.exists():
        _regular(path, shown)
    if not path.exists():
        raise BagError(shown, "no such file or directory")


def _resolve(path: Path, shown: str) -> tuple[Path, Metadata | None]:
    """The path rosbags should open, after checking what it is, and its metadata.yaml as read."""
    _check_exists(path, shown)
    if path.is_file() and path.name == "metadata.yaml":
        path = path.parent
    if path.is_dir():
        storage = sorted(path.glob("*.mcap"))
        for f in [path / "metadata.yaml", *storage]:
            if f.is_symlink() or f.exists():
                _regular(f, shown)
        if not (path / "metadata.yaml").is_file():
            if storage or any(path.glob("*.mcap.*")):
                raise IncompleteBagError(
                    shown,
                    "no metadata.yaml: the recording did not end cleanly "
                    f"(run 'bike-rig bag recover {shown}' to make it readable)",
                )
            raise NotABagError(shown, "not a rosbag2 bag (no metadata.yaml and no .mcap file)")
        metadata = check_metadata(path / "metadata.yaml", shown)
        _check_listed(path, metadata, shown)
        for f in storage:
            _check_mcap_file(f, shown)
        return path, metadata
    _regular(path, shown)
    if path.suffix.lower() == ".mcap":
        _check_mcap_file(path, shown)
        return path, None
    try:
        with path.open("rb") as stream:
            head = stream.read(8)
    except OSError as exc:
        raise BagReadError(shown, f"cannot read ({exc.strerror or exc})") from None
    if head == MCAP_MAGIC:
        raise NotABagError(shown, "an MCAP file must be named *.mcap to be read")
    if head.startswith(b"#ROSBAG"):
        raise NotABagError(
            shown,
            "a ROS 1 bag: bike-rig reads ROS 2 bags only (a rosbag2 directory or an MCAP file); "
            f"convert it with 'rosbags-convert --src {shown} --dst <new bag directory>'",
        )
    raise NotABagError(shown, "not a bag (neither a rosbag2 directory nor an MCAP file)")


class BagReader:
    """An open bag: its topics and its messages in log-time order.

    Args:
        path: A bag directory, its metadata.yaml, or a ``.mcap`` file.

    Raises:
        BagError: (on :meth:`open`) see the module docstring.
    """

    def __init__(self, path: str | Path) -> None:
        """A reader of ``path``, not yet open."""
        self.shown = str(path)
        self.path = Path(path)
        self._reader: Reader | None = None
        self._resolved: Path | None = None
        self._decodings: dict[str, Decoding] = {}
        self.topics: dict[str, TopicInfo] = {}

    def open(self) -> BagReader:
        """Open the bag and read its index.

        Raises:
            NotABagError: Not a bag, or not a ROS 2 CDR bag (a channel of another encoding...).
            BagError: see the module docstring.
        """
        resolved, _ = _resolve(self.path, self.shown)
        self._resolved = resolved
        for f in self._mcap_files(resolved):
            check_ros2_cdr(f, self.shown)
        reader = self._open_rosbags(resolved)
        if not all(isinstance(v, int) for v in (reader.message_count, reader.start_time, reader.end_time)):
            self.close()
            raise BagReadError(self.shown, "metadata.yaml: the message count, start or duration is not an integer")
        schemas: dict[str, list[RecordedSchema]] = {}
        self._refuse_foreign_connections(reader, schemas)
        topics: dict[str, TopicInfo] = {}
        for c in reader.connections:
            name, msgcount = c.topic, c.msgcount
            if not isinstance(msgcount, int) or not isinstance(name, str):
                self.close()
                raise BagReadError(self.shown, f"topic {name!r}: message count {msgcount!r} is not an integer")
            qos = tuple(getattr(c.ext, "offered_qos_profiles", ()) or ())
            prev = topics.get(name)
            count = msgcount + (prev.count if prev else 0)
            known = tuple(dict.fromkeys(x for x in schemas.get(name, ()) if x.msgtype == c.msgtype))
            topics[name] = TopicInfo(name, c.msgtype, count, qos, c.digest or "", known)
        self.topics = topics
        return self

    def _mcap_files(self, resolved: Path) -> list[Path]:
        """The bag's MCAP files (every one in its directory, or the file itself)."""
        return sorted(resolved.glob("*.mcap"), key=split_order) if resolved.is_dir() else [resolved]

    def _refuse_foreign_connections(self, reader: Reader, schemas: dict[str, list[RecordedSchema]]) -> None:
        """Refuse a connection rosbags reads whose serialization is not CDR; note each one's schema."""
        from rosbags.interfaces import MessageDefinitionFormat

        encodings: dict[object, str] = {MessageDefinitionFormat.MSG: "ros2msg", MessageDefinitionFormat.IDL: "ros2idl"}
        for c in reader.connections:
            form = getattr(c.ext, "serialization_format", "cdr")
            if form != "cdr":
                self.close()
                raise NotABagError(self.shown, f"not a ROS 2 CDR bag: topic {c.topic} is serialized as {form!r}")
            encoding = encodings.get(c.msgdef.format)
            if encoding and isinstance(c.msgdef.data, str):
                schemas.setdefault(c.topic, []).append(RecordedSchema(c.msgtype, encoding, c.msgdef.data))

    def _open_rosbags(self, resolved: Path) -> Reader:
        # rosbags leaves a storage file open when its open fails: it is closed (unreferenced)
        # with the exception, quietly (the warning would print before the error line)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResourceWarning)
            reader, reason = _try_rosbags(resolved)
            if reader is None:
                gc.collect()
        if reader is None:
            raise BagReadError(self.shown, f"unreadable bag ({reason})")
        self._reader = reader
        return reader

    def close(self) -> None:
        """Close the bag's files."""
        if self._reader is not None:
            self._reader.close()
            self._reader = None
        self._resolved = None

    def __enter__(self) -> BagReader:
        """Open the bag (unless it is open)."""
        return self.open() if self._resolved is None else self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        """Close the bag."""
        self.close()

    @property
    def reader(self) -> Reader:
        """The underlying rosbags reader."""
        if self._resolved is None:
            raise BagError(self.shown, "the bag is not open")
        if self._reader is None:
            return self._open_rosbags(self._resolved)
        return self._reader

    @property
    def start_time(self) -> int:
        """Log time of the first message, ns since the epoch (0 for an empty bag)."""
        return self.reader.start_time if self.message_count else 0

    @property
    def end_time(self) -> int:
        """Log time of the last message, ns since the epoch (0 for an empty bag)."""
        return self.reader.end_time - 1 if self.message_count else 0

    @property
    def duration(self) -> int:
        """Time from the first to the last message, ns."""
        return self.end_time - self.start_time

    @property
    def message_count(self) -> int:
        """Number of messages."""
        return int(self.reader.message_count)

    @property
    def custom_data(self) -> dict[str, str]:
        """metadata.yaml's ``custom_data`` (empty for a bare MCAP file)."""
        meta = getattr(self.reader.storage, "metadata", None)
        return dict(getattr(meta, "custom", None) or {})

    @property
    def storage_files(self) -> list[Path]:
        """The storage files of the bag."""
        if self.path.is_dir() or self.path.name == "metadata.yaml":
            base = self.path if self.path.is_dir() else self.path.parent
            entries = getattr(self.reader.storage, "files", None) or []
            files = [base / f["path"] for f in entries if isinstance(f, dict) and isinstance(f.get("path"), str)]
            return files or sorted(base.glob("*.mcap"), key=split_order)  # (recording order: _2 before _10)
        return [self.path]

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Every message (of the given topics, all if None) in log-time order.

        Raises:
            BagReadError: A chunk is corrupt.
        """
        from rosbags.rosbag2.errors import ReaderError

        wanted = None if topics is None else set(topics)
        conns = [c for c in self.reader.connections if wanted is None or c.topic in wanted]
        if not conns:
            return
        try:
            for conn, log_time, data in self.reader.messages(connections=conns):
                yield RawMessage(conn.topic, log_time, data)
        except ReaderError as exc:
            raise BagReadError(self.shown, f"corrupt data ({exception_text(exc)})") from None
        except (GeneratorExit, KeyboardInterrupt):
            raise
        except Exception as exc:  # the decompressors' own classes (zstandard.ZstdError, lz4's RuntimeError)
            raise BagReadError(self.shown, self._corrupt_chunk(exc)) from None

    def _corrupt_chunk(self, exc: BaseException) -> str:
        """What to say of a chunk rosbags' reader could not read: which chunk, when the mcap library finds it."""
        for f in self.storage_files:
            bad = first_corrupt_chunk(f)
            if bad:
                return bad
        return f"corrupt data ({type(exc).__name__}: {exception_text(exc)})"

    def decoding(self, topic: str) -> Decoding:
        """How a topic's messages are decoded: with the bag's own definition of its type.

        Raises:
            ReplayError: The type is not one of bike_rig's, or its definition in the bag cannot
                be read by field name (see :func:`bike_rig.bag.schemas.decoding_for`).
        """
        made = self._decodings.get(topic)
        if made is None:
            info = self.topics[topic]
            made = decoding_for(self.shown, topic, info.msgtype, info.schemas, info.type_hash)
            self._decodings[topic] = made
        return made

    def check_type(self, topic: str) -> str:
        """The type of a topic, after checking that it was recorded with the installed definition.

        (What a republication into a live graph needs: the bytes go out as they are.)

        Raises:
            ReplayError: The type is unknown to bike_rig, or was recorded with another definition.
        """
        info = self.topics[topic]
        decoding = self.decoding(topic)
        if not decoding.installed:
            raise ReplayError(
                self.shown,
                f"topic {topic}: {info.msgtype} was recorded with another definition than the installed one "
                f"(hash {decoding.bag_hash[:23]}…): its bytes cannot be published as they are",
            )
        return info.msgtype

    def decoded(self, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, Any]]:
        """Every message of the given topics (all if None), deserialized, in log-time order.

        Each topic with its own definition in the bag (:meth:`decoding`).

        Yields:
            ``(topic, log_time_ns, message)``.

        Raises:
            ReplayError: A type cannot be decoded (see :meth:`decoding`).
            BagReadError: A message does not deserialize.
        """
        names = list(self.topics) if topics is None else [t for t in topics if t in self.topics]
        decoders = {t: partial(self.decoding(t).store.deserialize_cdr, typename=self.topics[t].msgtype) for t in names}
        for msg in self.messages(names):
            try:
                yield msg.topic, msg.log_time, decoders[msg.topic](msg.data)
            except Exception as exc:  # rosbags raises several kinds for bad CDR
                msgtype = self.topics[msg.topic].msgtype
                raise BagReadError(
                    self.shown, f"a {msgtype} message on {msg.topic} does not deserialize ({exc})"
                ) from None

    def records(self, topics: Iterable[str]) -> list[Record] | None:
        """Every message of ``topics`` in log-time order, read with the ``mcap`` library.

        Messages of equal log time are in the recorder's order of storage.

        Returns:
            The messages; None when the bag is not one the library reads as rosbags does (a
            storage file that is not MCAP, messages compressed one by one, a channel rosbags
            leaves out): then :meth:`decoded` reads it or says what is wrong.

        Raises:
            BagReadError: A chunk is corrupt.
        """
        names = [t for t in topics if t in self.topics]
        files = self.storage_files
        meta = getattr(getattr(self.reader, "storage", None), "metadata", None)
        if getattr(meta, "compression_mode", "") == "message" or any(f.suffix != ".mcap" for f in files):
            return None
        accepted = self._read_channels()
        if accepted is None:
            return None
        with no_collection():
            return self._records(names, files, accepted)

    def _records(self, names: list[str], files: list[Path], accepted: dict[str, set[int]]) -> list[Record] | None:
        """:meth:`records` of ``names``, its checks done."""
        out: list[Record] = []
        for f in sorted(files, key=split_order):
            base, ids = len(out), accepted.get(f.name, set())
            try:
                with f.open("rb") as stream:
                    found = file_messages(stream, set(names))
                    out += [
                        Record(channel.topic, message.log_time, message.sequence, base + k, message.data)
                        for k, (channel, message) in enumerate(found)
                        if channel.id in ids
                    ]
            except (GeneratorExit, KeyboardInterrupt):
                raise
            except Exception:  # the mcap library's own errors
                bad = first_corrupt_chunk(f)
                if bad:
                    raise BagReadError(self.shown, bad) from None
                return None
        counts = dict.fromkeys(names, 0)
        for r in out:
            counts[r.topic] += 1
        if any(counts[t] != self.topics[t].count for t in names):
            return None
        times = np.fromiter((r.log_time for r in out), dtype=np.uint64, count=len(out))
        if len(out) > 1 and np.any(times[1:] < times[:-1]) or any(r.stream != k for k, r in enumerate(out)):
            ranks = np.fromiter((r.stream for r in out), dtype=np.int64, count=len(out))
            out = [out[i] for i in np.lexsort((ranks, times)).tolist()]
        return out

    def _read_channels(self) -> dict[str, set[int]] | None:
        """The channel ids rosbags' reader reads of each storage file (by name); None if it does not say."""
        out: dict[str, set[int]] = {}
        wanted = self.reader.connections
        inner = getattr(self.reader, "storage", None)  # (the storage reader of the bag: its files' readers)
        storages = getattr(inner, "storages", None) or ([inner] if hasattr(inner, "channels") else None)
        if not storages:
            return None
        for storage in storages:
            path = getattr(storage, "path", None)
            conns = getattr(storage, "connections", None)
            if not isinstance(path, Path) or conns is None:
                return None
            out[path.name] = {
                x.id
                for x in conns
                if any(
                    y.topic == x.topic
                    and y.msgtype == x.msgtype
                    and y.ext == x.ext
                    and (not x.digest or not y.digest or y.digest == x.digest)
                    for y in wanted
                )
            }  # (rosbags' Reader.messages keeps the channels that match one of its connections so)
        return out

    def stamped(self, topics: Iterable[str]) -> list[Record] | None:
        """Every message of ``topics`` with its publication sequence, in the recorder's order of storage.

        Returns:
            The messages; None when that order cannot be read (see :meth:`records`).

        Raises:
            BagReadError: A chunk is corrupt.
        """
        found = self.records(topics)
        if found is None:
            return None
        return sorted(found, key=lambda r: r.stream)


def _try_rosbags(resolved: Path) -> tuple[Reader | None, str]:
    """Open rosbags' reader of the bag: the reader, or None and why it cannot be opened (one line)."""
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    try:
        reader = Reader(resolved)
        reader.open()
    except ReaderError as exc:
        return None, exception_text(exc)
    except (GeneratorExit, KeyboardInterrupt):
        raise
    except Exception as exc:  # its parsers' and decompressors' own classes (zstd, ruamel, struct)
        return None, f"{type(exc).__name__}: {exception_text(exc)}"
    return reader, ""


def open_bag(path: str | Path) -> BagReader:
    """Open a bag for reading (use as a context manager).

    Raises:
        BagError: not a bag, an unfinished recording, unreadable or corrupt files.
    """
    return BagReader(path).open()
