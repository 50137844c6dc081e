"""Field helpers shared by the converters: float arrays, strings, header stamps."""

from __future__ import annotations

import array
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.errors import BikeRigError
from ..pipeline.acquire import NS_PER_S
from .protocols import FloatField, HeaderMsg

__all__ = ["MessageError", "check_length", "floats", "set_floats", "set_stamp", "stamp_ns", "strings"]

FloatArray = NDArray[np.float64]


class MessageError(BikeRigError):
    """A message whose fields do not describe a valid record (wrong lengths, unknown names)."""


def floats(values: FloatField) -> FloatArray:
    """A float message field (list, ``array.array`` or numpy array) as a new 1-D float64 array."""
    return np.array(values, dtype=np.float64).reshape(-1)


def strings(values: Iterable[Any]) -> tuple[str, ...]:
    """A ``string[]`` field as a tuple of str."""
    return tuple(str(v) for v in values)


def set_floats(msg: object, name: str, values: ArrayLike) -> None:
    """Write floats into field ``name`` in the container type the field already holds."""
    data = np.asarray(values, dtype=np.float64).reshape(-1)
    current = getattr(msg, name)
    if isinstance(current, np.ndarray):
        setattr(msg, name, data.copy())
    elif isinstance(current, array.array):
        setattr(msg, name, array.array("d", data.tobytes()))
    else:
        setattr(msg, name, [float(x) for x in data])


def stamp_ns(header: HeaderMsg) -> int:
    """A ``std_msgs/Header`` stamp as integer nanoseconds since the epoch."""
    return int(header.stamp.sec) * NS_PER_S + int(header.stamp.nanosec)


def set_stamp(msg: Any, ns: int) -> None:
    """Set ``msg.header.stamp`` from integer nanoseconds since the epoch."""
    msg.header.stamp.sec = int(ns // NS_PER_S)
    msg.header.stamp.nanosec = int(ns % NS_PER_S)


def check_length(what: str, n: int, expected: int) -> None:
    """Raise :class:`MessageError` unless a field holds ``expected`` entries."""
    if n != expected:
        raise MessageError(f"{what}: {n} entries, expected {expected}")
