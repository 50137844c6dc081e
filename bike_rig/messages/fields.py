"""Field helpers shared by the converters: the copy by name, float arrays, strings, header stamps.

A record's fields travel in the message fields of the same names (:func:`record_fields`,
:func:`fill_fields`), converted by the record's annotated types; ``stamp_ns`` and ``frame_id``
travel in ``header``. The converters write explicitly only what is not a copy.
"""

from __future__ import annotations

import array
import dataclasses
import enum
import typing
from collections.abc import Collection, Iterable
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.errors import BikeRigError
from ..pipeline.acquire import NS_PER_S

__all__ = [
    "Message",
    "MessageError",
    "check_length",
    "fill_fields",
    "floats",
    "record_fields",
    "set_floats",
    "set_stamp",
    "stamp_ns",
    "strings",
]

FloatArray = NDArray[np.float64]
#: A message object: rclpy's generated class, rosbags' deserialised dataclass, or a stand-in.
Message: TypeAlias = Any


class MessageError(BikeRigError):
    """A message whose fields do not describe a valid record (wrong lengths, unknown names)."""


def floats(values: Iterable[float]) -> FloatArray:
    """A float message field (list, ``array.array`` or numpy array) as a new 1-D float64 array."""
    return np.array(values, dtype=np.float64).reshape(-1)


def strings(values: Iterable[Any]) -> tuple[str, ...]:
    """A ``string[]`` field as a tuple of str."""
    return tuple(str(v) for v in values)


def set_floats(msg: Message, name: str, values: ArrayLike) -> None:
    """Write floats into field ``name`` in the container type the field already holds."""
    data = np.asarray(values, dtype=np.float64).reshape(-1)
    current = getattr(msg, name)
    if isinstance(current, np.ndarray):
        setattr(msg, name, data.copy())
    elif isinstance(current, array.array):
        setattr(msg, name, array.array("d", data.tobytes()))
    else:
        setattr(msg, name, [float(x) for x in data])


def stamp_ns(header: Message) -> int:
    """A ``std_msgs/Header`` stamp as integer nanoseconds since the epoch."""
    return int(header.stamp.sec) * NS_PER_S + int(header.stamp.nanosec)


def set_stamp(msg: Message, ns: int) -> None:
    """Set ``msg.header.stamp`` from integer nanoseconds since the epoch."""
    msg.header.stamp.sec = int(ns // NS_PER_S)
    msg.header.stamp.nanosec = int(ns % NS_PER_S)


def check_length(what: str, n: int, expected: int) -> None:
    """Raise :class:`MessageError` unless a field holds ``expected`` entries."""
    if n != expected:
        raise MessageError(f"{what}: {n} entries, expected {expected}")


_ANNOTATED: dict[type, tuple[tuple[str, Any], ...]] = {}


def _annotated_fields(record_type: type) -> tuple[tuple[str, Any], ...]:
    """(name, resolved type) of each field a record type's constructor takes (cached per type)."""
    known = _ANNOTATED.get(record_type)
    if known is None:
        hints = typing.get_type_hints(record_type)
        known = tuple((f.name, hints[f.name]) for f in dataclasses.fields(record_type) if f.init)
        _ANNOTATED[record_type] = known
    return known


def _item_type(kind: Any) -> Any:
    """``str`` or ``float`` for ``tuple[str, ...]``/``tuple[float, ...]`` and float arrays, else None."""
    origin = typing.get_origin(kind)
    if origin is tuple:
        args = typing.get_args(kind)
        return args[0] if len(args) == 2 and args[1] is Ellipsis and args[0] in (str, float) else None
    return float if kind is np.ndarray or origin is np.ndarray else None


def _read(value: Any, kind: Any, where: str) -> Any:
    """A message field's value as the record's type ``kind``."""
    if kind in (str, bool, int, float):
        return kind(value)
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        try:
            return kind(int(value) if issubclass(kind, int) else str(value))
        except ValueError:
            raise MessageError(f"{where}: unknown {value!r}") from None
    item = _item_type(kind)
    if item is str:
        return strings(value)
    if item is float and typing.get_origin(kind) is tuple:
        return tuple(float(x) for x in floats(value))
    if item is float:  # a float64 array: rosbags' own array is kept, other containers copied
        ok = isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim == 1
        return value if ok else floats(value)
    raise TypeError(f"{where}: no copy between a message field and a record field of type {kind}")


def _write(msg: Message, name: str, value: Any, kind: Any) -> None:
    """Write a record's value of type ``kind`` into the message field ``name``."""
    if isinstance(value, enum.Enum):
        setattr(msg, name, value.value)
    elif kind in (str, bool, int, float):
        setattr(msg, name, kind(value))
    elif _item_type(kind) is str:
        setattr(msg, name, [str(v) for v in value])
    elif _item_type(kind) is float:
        set_floats(msg, name, value)
    else:
        raise TypeError(f"{name}: no copy between a record field of type {kind} and a message field")


def _message_name(msg: Message) -> str:
    return type(msg).__name__.rsplit("__", 1)[-1]


def record_fields(record_type: type, msg: Message, skip: Collection[str] = ()) -> dict[str, Any]:
    """The fields of ``record_type`` that ``msg`` carries, by name, as the record's types.

    ``stamp_ns`` (ns) and ``frame_id`` come from ``msg.header``; fields the message lacks, and
    those in ``skip``, are left out (the caller converts them, or the record's default holds).

    Raises:
        MessageError: An enum field holds a value the enum does not know.
    """
    out: dict[str, Any] = {}
    header = getattr(msg, "header", None)
    for name, kind in _annotated_fields(record_type):
        if name in skip:
            continue
        if hasattr(msg, name):
            out[name] = _read(getattr(msg, name), kind, f"{_message_name(msg)}.{name}")
        elif header is not None and name == "stamp_ns":
            out[name] = stamp_ns(header)
        elif header is not None and name == "frame_id":
            out[name] = str(header.frame_id)
    return out


def fill_fields(msg: Message, record: object, skip: Collection[str] = ()) -> None:
    """Write each field of ``record`` that ``msg`` carries (``skip`` aside) into it, by name.

    ``stamp_ns`` (ns) and ``frame_id`` go into ``msg.header``; enums are written as their value,
    float arrays in the container the field holds.
    """
    header = getattr(msg, "header", None)
    for name, kind in _annotated_fields(type(record)):
        if name in skip:
            continue
        value = getattr(record, name)
        if hasattr(msg, name):
            _write(msg, name, value, kind)
        elif header is not None and name == "stamp_ns":
            set_stamp(msg, value)
        elif header is not None and name == "frame_id":
            header.frame_id = str(value)
