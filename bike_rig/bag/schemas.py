"""Which definition decodes a topic: the bag's own schema, compared with the installed ``.msg`` files.

:func:`decoding_for` parses a channel's schema (``ros2msg`` or ``ros2idl``) with rosbags and
compares it field by field and constant by constant with the rig's typestore
(:func:`bike_rig.bag.typestore.rig_typestore`): the same decodes with ours; one that still has
every field and constant of ours with the same types (reordered, fields added; those of
:data:`OPTIONAL_FIELDS` may be absent) decodes with a typestore from the bag's schema;
anything else is refused in one line naming the type and both RIHS01 hashes. The schema
decides; metadata.yaml's type hash is used only for a bag without schemas (SQLite storage).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

from .errors import ReplayError
from .typestore import rig_typestore, type_hash

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["OPTIONAL_FIELDS", "SCHEMA_ENCODINGS", "Decoding", "RecordedSchema", "decoding_for"]

#: MCAP schema encodings of ROS 2 message definitions (rosbag2 writes ``ros2msg``).
SCHEMA_ENCODINGS = ("ros2msg", "ros2idl")

#: Per type, the fields added after bags were recorded without them: a bag's definition may lack
#: them (its messages are decoded with it, and the records keep their defaults, NaN).
OPTIONAL_FIELDS: dict[str, frozenset[str]] = {
    "bike_rig_msgs/msg/FitDetails": frozenset({"ends_period", "ends_period_sigma", "small_swing_systematic"}),
}


@dataclass(frozen=True)
class RecordedSchema:
    """A type's definition as a bag stores it.

    Attributes:
        msgtype: The type's full name, e.g. ``bike_rig_msgs/msg/GyroBatch``.
        encoding: The MCAP schema encoding (``ros2msg``, ``ros2idl``; "" when the bag has none).
        text: The schema's text (the type's definition, then each dependency's).
    """

    msgtype: str
    encoding: str
    text: str


@dataclass(frozen=True)
class Decoding:
    """How a topic's messages are decoded.

    Attributes:
        store: The typestore that deserializes them.
        installed: The bag's definition equals the installed one (the fast decoders may be used).
        bag_hash: The RIHS01 hash of the bag's definition ("" when the bag has no schema).
    """

    store: Typestore
    installed: bool
    bag_hash: str


def _plain(value: Any) -> Any:
    """A field or constant description with rosbags' enums as ints and lists as tuples (comparable)."""
    if isinstance(value, list | tuple):
        return tuple(_plain(x) for x in value)
    if hasattr(value, "value") and isinstance(value.value, int):
        return int(value.value)
    return value


def _type_text(desc: Any) -> str:
    """A field type as a .msg file writes it (``float64[]``, ``std_msgs/msg/Header``, ``string[4]``)."""
    nodetype, spec = desc
    if nodetype == 1:
        return str(spec[0])
    if nodetype == 2:
        return str(spec)
    (inner, length) = spec
    return f"{_type_text(inner)}[{length if nodetype == 3 else ''}]"


def _uses(fields: Iterable[Any]) -> list[str]:
    """The message types a type's fields name."""
    out = []
    for _, (nodetype, spec) in fields:
        if nodetype == 2:
            out.append(spec)
        elif nodetype in (3, 4) and spec[0][0] == 2:
            out.append(spec[0][1])
    return out


def _closure(defs: dict[str, Any], msgtype: str) -> list[str]:
    """``msgtype`` and every type it uses (as far as ``defs`` knows them), in order of first use."""
    out, todo = [], [msgtype]
    while todo:
        name = todo.pop(0)
        if name in out or name not in defs:
            continue
        out.append(name)
        todo += _uses(defs[name][1])
    return out


def _same(bag: dict[str, Any], ours: dict[str, Any], msgtype: str) -> bool:
    """Whether the bag defines ``msgtype`` and every type it uses exactly as we do."""
    names = _closure(ours, msgtype)
    return all(name in bag and _plain(bag[name][:2]) == _plain(ours[name][:2]) for name in names)


def _missing(bag: dict[str, Any], ours: dict[str, Any], msgtype: str) -> str:
    """What of our definition of ``msgtype`` the bag's lacks ("" nothing: it can be read by field name)."""
    for name in _closure(ours, msgtype):
        short = name.replace("/msg/", "/")
        if name not in bag:
            return f"no definition of {short}"
        (bag_consts, bag_fields), (our_consts, our_fields) = bag[name][:2], ours[name][:2]
        theirs_c = {c[0]: _plain(c) for c in bag_consts}
        for const in our_consts:
            if theirs_c.get(const[0]) != _plain(const):
                return f"{short}: constant {const[0]} is not {const[1]} {const[0]}={const[2]}"
        theirs_f = dict(bag_fields)
        optional = OPTIONAL_FIELDS.get(name, frozenset())
        for field, desc in our_fields:
            if field not in theirs_f and field in optional:
                continue
            if field not in theirs_f:
                return f"{short} has no field {field}"
            if _plain(theirs_f[field]) != _plain(desc):
                return f"{short}.{field} is {_type_text(theirs_f[field])}, here {_type_text(desc)}"
    return ""


def _text_hash(text: str) -> str:
    """A hash of a schema rosbags cannot parse: sha256 of its text, comments and blank lines left out."""
    lines = (line.split("#", 1)[0].strip() for line in text.splitlines())
    return "sha256:" + hashlib.sha256("\n".join(x for x in lines if x).encode()).hexdigest()


@dataclass(frozen=True)
class _Parsed:
    """A schema parsed: its definitions, or why not."""

    defs: dict[str, Any]
    error: str


@lru_cache(maxsize=64)
def _parse(msgtype: str, encoding: str, text: str) -> _Parsed:
    try:
        if encoding == "ros2idl":
            defs = dict(get_types_from_idl(text))
        else:
            defs = dict(get_types_from_msg(text, msgtype))
    except Exception as exc:  # rosbags raises several kinds for a bad definition
        return _Parsed({}, " ".join(str(exc).split())[:200] or type(exc).__name__)
    if msgtype not in defs:
        return _Parsed({}, f"it does not define {msgtype}")
    return _Parsed(defs, "")


@lru_cache(maxsize=16)
def _bag_store(schema: RecordedSchema) -> Typestore:
    """A typestore of the bag's definitions (the types its schema does not define: ours)."""
    ours = rig_typestore().fielddefs
    defs = dict(_parse(schema.msgtype, schema.encoding, schema.text).defs)
    for name in _closure({**ours, **defs}, schema.msgtype):
        if name not in defs:
            defs[name] = ours[name]
    store = get_typestore(Stores.EMPTY)
    store.register(defs)
    return store


def _short_hash(h: str) -> str:
    return h if len(h) <= 23 else f"{h[:23]}…"


def decoding_for(
    shown: str, topic: str, msgtype: str, schemas: Sequence[RecordedSchema], recorded_hash: str = ""
) -> Decoding:
    """The typestore that decodes a topic's messages as they were written.

    Args:
        shown: The bag, as the user named it (for the error).
        topic: The topic.
        msgtype: Its type.
        schemas: The schemas its channels carry (one per storage file; none for SQLite storage).
        recorded_hash: The type hash metadata.yaml records for it ("" none).

    Raises:
        ReplayError: The type is not one of bike_rig's, the bag defines it in several ways, or its
            definition lacks what bike_rig reads (a field, a constant, a type), or cannot be parsed.
    """
    rig = rig_typestore()
    if msgtype not in rig.fielddefs:
        raise ReplayError(shown, f"topic {topic}: type {msgtype} is not one of bike_rig's")
    ours = type_hash(msgtype)
    known = list(dict.fromkeys(s for s in schemas if s.encoding))
    if not known:
        if recorded_hash and recorded_hash != ours:
            raise ReplayError(
                shown,
                f"topic {topic}: {msgtype} was recorded with another definition, and the bag does not "
                f"hold it (hash {_short_hash(recorded_hash)}, here {_short_hash(ours)})",
            )
        return Decoding(rig, True, recorded_hash)
    if len(known) > 1:
        hashes = ", ".join(_short_hash(_hash_of(s)) for s in known)
        raise ReplayError(shown, f"topic {topic}: {msgtype} is defined in {len(known)} ways in the bag ({hashes})")
    (schema,) = known
    parsed = _parse(schema.msgtype, schema.encoding, schema.text)
    if parsed.error:
        theirs = recorded_hash or _text_hash(schema.text)
        raise ReplayError(
            shown,
            f"topic {topic}: the bag's {schema.encoding} definition of {msgtype} cannot be read "
            f"({parsed.error}; hash {_short_hash(theirs)}, here {_short_hash(ours)})",
        )
    if _same(parsed.defs, rig.fielddefs, msgtype):
        return Decoding(rig, True, ours)
    lacking = _missing(parsed.defs, rig.fielddefs, msgtype)
    theirs = _hash_of(schema)
    if lacking:
        raise ReplayError(
            shown,
            f"topic {topic}: {msgtype} was recorded with another definition, which bike_rig cannot read "
            f"({lacking}; hash {_short_hash(theirs)}, here {_short_hash(ours)})",
        )
    try:
        store = _bag_store(schema)
    except Exception as exc:  # rosbags cannot generate its classes
        raise ReplayError(
            shown,
            f"topic {topic}: the bag's definition of {msgtype} cannot be built ({' '.join(str(exc).split())[:200]}; "
            f"hash {_short_hash(theirs)}, here {_short_hash(ours)})",
        ) from None
    return Decoding(store, False, theirs)


def _hash_of(schema: RecordedSchema) -> str:
    """The RIHS01 hash of a bag's definition (sha256 of its text when rosbags cannot build it)."""
    if not _parse(schema.msgtype, schema.encoding, schema.text).error:
        try:
            return str(_bag_store(schema).hash_rihs01(schema.msgtype))
        except Exception:  # rosbags cannot register or hash it (e.g. a type it uses is unknown)
            pass
    return _text_hash(schema.text)
