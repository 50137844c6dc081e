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
from collections.abc import Callable, Collection, Iterable
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
#: A field a message does not carry.
_ABSENT = object()
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


#: Per record type: (name, read, write) of each field its constructor takes.
_PLANS: dict[type, tuple[tuple[str, Callable[[Any], Any], Callable[[Message, str, Any], None]], ...]] = {}


def _float_array(value: Any) -> FloatArray:
    """A float64 array field: rosbags' own 1-D array is kept, other containers copied."""
    if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim == 1:
        return value
    return floats(value)


def _conversions(kind: Any) -> tuple[Callable[[Any], Any], Callable[[Message, str, Any], None]] | None:
    """How a record field of type ``kind`` is read from and written to a message field (None: no copy).

    Enums are read from their value (a bad one raises ValueError) and written as it.
    """
    if kind in (str, bool, int, float):
        return kind, lambda msg, name, value: setattr(msg, name, kind(value))
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        raw = int if issubclass(kind, int) else str
        return (lambda value: kind(raw(value))), (lambda msg, name, value: setattr(msg, name, value.value))
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is tuple and args == (str, Ellipsis):
        return strings, lambda msg, name, value: setattr(msg, name, [str(v) for v in value])
    if origin is tuple and args == (float, Ellipsis):
        return (lambda value: tuple(float(x) for x in floats(value))), set_floats
    if kind is np.ndarray or origin is np.ndarray:
        return _float_array, set_floats
    return None


def _plan(record_type: type) -> tuple[tuple[str, Callable[[Any], Any], Callable[[Message, str, Any], None]], ...]:
    """The (name, read, write) of each field of a record type (built once per type)."""
    plan = _PLANS.get(record_type)
    if plan is None:
        hints = typing.get_type_hints(record_type)
        steps = []
        for f in (f for f in dataclasses.fields(record_type) if f.init):
            refuse = _no_copy(record_type, f.name)
            read, write = _conversions(hints[f.name]) or (refuse, refuse)
            steps.append((f.name, read, write))
        plan = _PLANS[record_type] = tuple(steps)
    return plan


def _no_copy(record_type: type, name: str) -> Callable[..., Any]:
    """For a field of a type with no copy: raises TypeError if a message carries a field of that name."""

    def refuse(*_: Any) -> Any:
        raise TypeError(f"{record_type.__name__}.{name}: no copy between its type and a message field")

    return refuse


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
    for name, read, _ in _plan(record_type):
        if name in skip:
            continue
        value = getattr(msg, name, _ABSENT)
        if value is not _ABSENT:
            try:
                out[name] = read(value)
            except ValueError:
                raise MessageError(f"{_message_name(msg)}.{name}: unknown {value!r}") from None
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
    for name, _, write in _plan(type(record)):
        if name in skip:
            continue
        if hasattr(msg, name):
            write(msg, name, getattr(record, name))
        elif header is not None and name == "stamp_ns":
            set_stamp(msg, getattr(record, name))
        elif header is not None and name == "frame_id":
            header.frame_id = str(getattr(record, name))
