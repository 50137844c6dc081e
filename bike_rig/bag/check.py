"""Checks of a bag's files before any parser allocates or recurses on what they claim.

A damaged bag ends in one :class:`~bike_rig.bag.errors.BagReadError` naming the file, place and
reason, never a traceback of rosbags, PyYAML or zstandard. :func:`check_metadata` reads
``metadata.yaml`` within :mod:`bike_rig.core.safe_yaml`'s limits and checks the type of every
value rosbags reads; :func:`check_mcap` checks every record length the MCAP reader will trust
(header, summary, chunk indexes and chunks) against the file's size, and each chunk's
uncompressed size against :data:`MAX_CHUNK_BYTES`, before anything is read.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, BinaryIO

import yaml

from ..core.errors import one_line
from ..core.safe_yaml import LIMITS, YamlLimitError, compose_bounded, construct, yaml_error_reason
from .errors import BagReadError

__all__ = ["MAX_CHUNK_BYTES", "Metadata", "check_mcap", "check_metadata", "within_limits"]

#: The largest uncompressed chunk accepted [bytes]; bike_rig's recorder closes a chunk every
#: second or at 1 MiB, rosbags' and ros2 bag's at 1 MiB by default.
MAX_CHUNK_BYTES = 1 << 30

#: The largest integer a count or a time [ns] may hold (uint64 in the file formats).
_MAX_INT = (1 << 64) - 1

_HEAD = struct.Struct("<BQ")
_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")
_MAGIC = b"\x89MCAP0\r\n"
_FOOTER_LENGTH = 9 + 8 + 8 + 4 + 8  # opcode, length, summary start, summary offset start, crc, magic
_OP_HEADER, _OP_FOOTER, _OP_CHANNEL, _OP_CHUNK, _OP_CHUNK_INDEX = 0x01, 0x02, 0x04, 0x06, 0x08


# --------------------------------------------------------------------------------------------
# metadata.yaml
# --------------------------------------------------------------------------------------------


class _Bad(Exception):
    """A metadata value of the wrong type: ``place`` (dotted keys) and ``reason``."""

    def __init__(self, place: str, reason: str) -> None:
        super().__init__(f"{place}: {reason}")
        self.place, self.reason = place, reason


def _shown(value: object) -> str:
    try:
        text = repr(value)
    except ValueError:  # an integer of more than 4,300 digits inside
        return f"a {type(value).__name__} holding a huge integer"
    return text if len(text) <= 40 else text[:37] + "..."


def _int(value: object, place: str) -> None:
    """An integer; a string is let through (YAML 1.1, read here, and 1.2, read by rosbags, may differ on it)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise _Bad(place, f"{_shown(value)} is not a finite count or time")
    if isinstance(value, str | bool):
        return
    if not isinstance(value, int):
        raise _Bad(place, f"{_shown(value)} is not an integer")
    if not -_MAX_INT <= value <= _MAX_INT:
        raise _Bad(place, f"an integer of {value.bit_length()} bits does not fit in 64")


def _count(value: object, place: str) -> None:
    _int(value, place)
    if isinstance(value, int) and not isinstance(value, bool) and value < 0:
        raise _Bad(place, f"{value} is a negative count")


def _str(value: object, place: str) -> None:
    """A scalar (YAML 1.1 reads ``yes`` as true where rosbags' YAML 1.2 reads a string): not a list or mapping."""
    if isinstance(value, list | dict):
        raise _Bad(place, f"{_shown(value)} is not a string")


def _map(value: object, place: str) -> dict[Any, Any]:
    if not isinstance(value, dict):
        raise _Bad(place, f"{_shown(value)} is not a mapping")
    return value


def _list(value: object, place: str) -> list[Any]:
    if not isinstance(value, list):
        raise _Bad(place, f"{_shown(value)} is not a list")
    return value


def _time(value: object, place: str, key: str) -> None:
    d = _map(value, place)
    if key in d:
        _int(d[key], f"{place}.{key}")


def _qos_profiles(value: object, place: str) -> None:
    """Offered QoS profiles: YAML text (rosbag2 before version 9) or a list of mappings of scalars."""
    if value is None or isinstance(value, str):
        return
    for i, profile in enumerate(_list(value, place)):
        here = f"{place}[{i}]"
        for key, item in _map(profile, here).items():
            if isinstance(item, dict):
                for part in ("sec", "nsec"):
                    if part in item:
                        _int(item[part], f"{here}.{key}.{part}")
            elif isinstance(item, list) or (key == "depth" and not isinstance(item, int | str)):
                raise _Bad(f"{here}.{key}", f"{_shown(item)} is not a QoS policy")


def _topics(value: object, place: str) -> None:
    for i, entry in enumerate(_list(value, place)):
        here = f"{place}[{i}]"
        e = _map(entry, here)
        if "message_count" in e:
            _count(e["message_count"], f"{here}.message_count")
        meta = _map(e.get("topic_metadata", {}), f"{here}.topic_metadata")
        for key in ("name", "type", "serialization_format", "type_description_hash", "offered_qos_profiles_text"):
            if key in meta:
                _str(meta[key], f"{here}.topic_metadata.{key}")
        _qos_profiles(meta.get("offered_qos_profiles"), f"{here}.topic_metadata.offered_qos_profiles")


def _files(value: object, place: str) -> None:
    if value is None:
        return
    for i, entry in enumerate(_list(value, place)):
        here = f"{place}[{i}]"
        e = _map(entry, here)
        if "path" in e:
            _str(e["path"], f"{here}.path")
        if "message_count" in e:
            _count(e["message_count"], f"{here}.message_count")
        if "starting_time" in e:
            _time(e["starting_time"], f"{here}.starting_time", "nanoseconds_since_epoch")
        if "duration" in e:
            _time(e["duration"], f"{here}.duration", "nanoseconds")


def _check_info(info: dict[Any, Any]) -> None:
    """Check the values of ``rosbag2_bagfile_information`` that rosbags reads (a missing one it reports)."""
    p = "rosbag2_bagfile_information"
    if "version" in info:
        _int(info["version"], f"{p}.version")
    for key in ("storage_identifier", "compression_format", "compression_mode", "ros_distro"):
        if key in info:
            _str(info[key], f"{p}.{key}")
    if "relative_file_paths" in info:
        for i, name in enumerate(_list(info["relative_file_paths"], f"{p}.relative_file_paths")):
            _str(name, f"{p}.relative_file_paths[{i}]")
    if "duration" in info:
        _time(info["duration"], f"{p}.duration", "nanoseconds")
    if "starting_time" in info:
        _time(info["starting_time"], f"{p}.starting_time", "nanoseconds_since_epoch")
    if "message_count" in info:
        _count(info["message_count"], f"{p}.message_count")
    if "topics_with_message_count" in info:
        _topics(info["topics_with_message_count"], f"{p}.topics_with_message_count")
    _files(info.get("files"), f"{p}.files")
    custom = info.get("custom_data")
    if custom is not None:
        for key, item in _map(custom, f"{p}.custom_data").items():
            _str(key, f"{p}.custom_data key")
            _str(item, f"{p}.custom_data.{key}")


def within_limits(text: str) -> bool:
    """Check a YAML text's nesting and size on libyaml's events (its parser does not recurse).

    Returns:
        True if libyaml may load it (no alias, at most ``LIMITS.max_nodes`` events); False if
        it needs the bounded loader (aliases, or no libyaml).

    Raises:
        YamlLimitError: It is larger than ``LIMITS.max_bytes`` or nested deeper than ``LIMITS.max_depth``.
        yaml.YAMLError: It is not YAML.
    """
    loader = getattr(yaml, "CSafeLoader", None)
    if len(text) > LIMITS.max_bytes:
        raise YamlLimitError(f"{len(text)} characters: larger than {LIMITS.max_bytes} bytes")
    if loader is None:
        return False
    depth = events = 0
    for event in yaml.parse(text, Loader=loader):
        events += 1
        if isinstance(event, yaml.MappingStartEvent | yaml.SequenceStartEvent):
            depth += 1
            if depth > LIMITS.max_depth:
                mark = event.start_mark
                raise YamlLimitError(f"nested deeper than {LIMITS.max_depth} levels", mark.line + 1 if mark else None)
        elif isinstance(event, yaml.MappingEndEvent | yaml.SequenceEndEvent):
            depth -= 1
        elif isinstance(event, yaml.AliasEvent) or events > LIMITS.max_nodes:
            return False
    return True


@dataclass(frozen=True)
class Metadata:
    """A bag's ``metadata.yaml`` as :func:`check_metadata` read it.

    Attributes:
        text: The file's text.
        doc: The loaded document (type-checked; not to be modified).
        plain: Loaded by libyaml: within the limits, without aliases.
        duplicate_keys: Some mapping repeats a key (libyaml keeps the last; other readers refuse).
    """

    text: str
    doc: Any
    plain: bool
    duplicate_keys: bool


@lru_cache(maxsize=1)
def _libyaml_loader() -> Any:
    """The libyaml loader that notes (instead of refusing) a mapping that repeats a key."""

    class Loader(yaml.CSafeLoader):
        duplicates = False

        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            made = super().construct_mapping(node, deep)
            if len(made) < len(node.value):  # (keys equal in Python collapse too: noted, never missed)
                type(self).duplicates = True
            return made

    return Loader


def _load(text: str) -> tuple[Any, bool, bool]:
    """``text`` loaded within :data:`~bike_rig.core.safe_yaml.LIMITS`, by libyaml when it can be.

    libyaml's events are counted first (its parser keeps its own stack; only its composer
    recurses, and would crash the process on a document a few thousand levels deep); a document
    within the limits and without aliases is then loaded by libyaml (the faster loader); one with
    aliases by the bounded loader.

    Returns:
        The document, whether libyaml loaded it, and whether a mapping repeats a key (libyaml only).
    """
    if len(text) > LIMITS.max_bytes or getattr(yaml, "CSafeLoader", None) is None or not within_limits(text):
        return construct(*compose_bounded(text)), False, False
    loader: Any = type("Load", (_libyaml_loader(),), {"duplicates": False})  # (its own flag)
    return yaml.load(text, Loader=loader), True, bool(loader.duplicates)


def check_metadata(path: Path, shown: str) -> Metadata:
    """Read ``metadata.yaml`` within bike_rig's YAML limits and check its values' types.

    Args:
        path: The bag's ``metadata.yaml``.
        shown: The bag as the user named it (for the error).

    Returns:
        The text and the document (for the fast reader, which then need not load it again).

    Raises:
        BagReadError: It cannot be read, is not YAML within the limits, or holds a value of
            the wrong type (a list or an infinite number where a count belongs, ...).
    """
    name = path.name
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise BagReadError(shown, f"{name}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise BagReadError(shown, f"{name}: byte {exc.start}: not UTF-8 text") from None
    try:
        doc, plain, duplicates = _load(text)
    except YamlLimitError as exc:
        where = f" line {exc.line}" if exc.line else ""
        raise BagReadError(shown, f"{name}{where}: {exc.reason}") from None
    except (ValueError, OverflowError, TypeError, AttributeError) as exc:
        # a scalar PyYAML's constructors cannot convert: a date, a long integer, a bad explicit tag
        reason = f"a value cannot be read ({type(exc).__name__}: {one_line(str(exc))})"
        raise BagReadError(shown, f"{name}: {reason}") from None
    except yaml.YAMLError as exc:
        reason, line = yaml_error_reason(exc, text)
        raise BagReadError(shown, f"{name}{f' line {line}' if line else ''}: {reason}") from None
    try:
        top = _map(doc, "the document")
        _check_info(_map(top.get("rosbag2_bagfile_information"), "rosbag2_bagfile_information"))
    except _Bad as exc:
        raise BagReadError(shown, f"{name}: {exc.place}: {exc.reason}") from None
    return Metadata(text, doc, plain, duplicates)


# --------------------------------------------------------------------------------------------
# MCAP record lengths
# --------------------------------------------------------------------------------------------


def _read_at(f: BinaryIO, offset: int, n: int) -> bytes:
    f.seek(offset)
    return f.read(n)


def _chunk_index(body: bytes, at: int, summary_start: int, f: BinaryIO) -> str:
    """The problem of one chunk index record (at byte ``at``) and the chunk it points to ("" if none)."""
    if len(body) < 36:
        return f"chunk index at byte {at}: shorter than its fields"
    offset, length = struct.unpack_from("<QQ", body, 16)
    pairs = _U32.unpack_from(body, 32)[0]
    if 36 + pairs + 8 + 4 > len(body):
        return f"chunk index at byte {at}: message index offsets of {pairs} bytes beyond its record"
    index_length = _U64.unpack_from(body, 36 + pairs)[0]
    name_length = _U32.unpack_from(body, 44 + pairs)[0]
    if 48 + pairs + name_length + 16 > len(body):
        return f"chunk index at byte {at}: compression name of {name_length} bytes beyond its record"
    uncompressed = _U64.unpack_from(body, 56 + pairs + name_length)[0]
    if offset + length + index_length > summary_start or length < 9:
        return f"chunk index at byte {at}: a chunk of {length} bytes at byte {offset} beyond the data section"
    if uncompressed > MAX_CHUNK_BYTES:
        return f"chunk at byte {offset}: {uncompressed} bytes uncompressed, more than {MAX_CHUNK_BYTES}"
    head = _read_at(f, offset, 9)
    if len(head) < 9 or head[0] != _OP_CHUNK or _HEAD.unpack(head)[1] != length - 9:
        return f"chunk at byte {offset}: not the chunk record of {length} bytes its index says"
    return ""


def _channel_qos(body: bytes, at: int) -> str:
    """The problem of a channel record's offered QoS text (YAML that rosbags' parser would load), "" if none."""
    try:
        pos = 4
        for _ in range(2):  # topic, message encoding
            pos += 4 + _U32.unpack_from(body, pos)[0]
        end = pos + 4 + _U32.unpack_from(body, pos)[0]
        pos += 4
        while pos < end:
            n = _U32.unpack_from(body, pos)[0]
            key = body[pos + 4 : pos + 4 + n]
            pos += 4 + n
            n = _U32.unpack_from(body, pos)[0]
            value = body[pos + 4 : pos + 4 + n]
            pos += 4 + n
            if key == b"offered_qos_profiles":
                within_limits(value.decode("utf-8", "replace"))
    except struct.error:
        return ""  # a malformed record: the readers say so
    except YamlLimitError as exc:
        return f"channel at byte {at}: offered QoS profiles: {exc.reason}"
    except yaml.YAMLError:
        return ""  # not YAML: rosbags says so
    return ""


def _walk(f: BinaryIO, start: int, stop: int, summary_start: int) -> str:
    """The first problem of the records from ``start`` to ``stop`` ("" if none)."""
    pos = start
    while pos < stop:
        head = _read_at(f, pos, 9)
        if len(head) < 9:
            return f"record at byte {pos}: cut"
        op, length = _HEAD.unpack(head)
        if op == _OP_FOOTER:
            return ""
        if length > stop - pos - 9:
            return f"record at byte {pos}: a length of {length} bytes beyond the end of its section (byte {stop})"
        if op == _OP_CHUNK and length >= 24:
            uncompressed = _U64.unpack(_read_at(f, pos + 9 + 16, 8))[0]
            if uncompressed > MAX_CHUNK_BYTES:
                return f"chunk at byte {pos}: {uncompressed} bytes uncompressed, more than {MAX_CHUNK_BYTES}"
        if op == _OP_CHANNEL:
            problem = _channel_qos(_read_at(f, pos + 9, length), pos)
            if problem:
                return problem
        if op == _OP_CHUNK_INDEX:
            problem = _chunk_index(_read_at(f, pos + 9, length), pos, summary_start, f)
            if problem:
                return problem
        pos += 9 + length
    return ""


def check_mcap(path: Path, shown: str) -> None:
    """Check an MCAP file's record lengths against its size before a reader allocates them.

    Checked: the header record, every record of the summary section, each chunk index (its
    chunk and message indexes within the data section, its uncompressed size at most
    :data:`MAX_CHUNK_BYTES`) and the chunk record it points to. A file without a summary is
    walked record by record.

    Args:
        path: The MCAP file (its magic and footer magic already checked).
        shown: The bag as the user named it (for the error).

    Raises:
        BagReadError: A length or offset points beyond the file or its section.
    """
    try:
        with path.open("rb") as f:
            problem = _check_open(f, f.seek(0, 2))
    except OSError as exc:
        raise BagReadError(shown, f"cannot read {path.name} ({exc.strerror or exc})") from None
    if problem:
        raise BagReadError(shown, f"{path.name}: {problem} (corrupt)")


def _check_open(f: BinaryIO, size: int) -> str:
    footer_at = size - _FOOTER_LENGTH
    if footer_at < len(_MAGIC) + 9:
        return "shorter than an MCAP header and footer"
    op, header_length = _HEAD.unpack(_read_at(f, len(_MAGIC), 9))
    if op != _OP_HEADER or header_length > footer_at - len(_MAGIC) - 9:
        return (
            f"header record at byte {len(_MAGIC)}: opcode 0x{op:02x}, length {header_length}, in a file of {size} bytes"
        )
    footer = _read_at(f, footer_at, _FOOTER_LENGTH)
    op, length = _HEAD.unpack_from(footer)
    if op != _OP_FOOTER or length != 20:
        return f"footer at byte {footer_at}: opcode 0x{op:02x}, length {length}"
    summary_start = _U64.unpack_from(footer, 9)[0]
    data_start = len(_MAGIC) + 9 + header_length
    if not summary_start:
        return _walk(f, data_start, footer_at, footer_at)
    if not data_start <= summary_start <= footer_at:
        return f"footer: summary at byte {summary_start}, outside the file's {size} bytes"
    return _walk(f, summary_start, footer_at, summary_start)
