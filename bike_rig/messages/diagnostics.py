"""Converters of ``/diagnostics`` (``DiagnosticArray``) to and from :class:`~bike_rig.pipeline.diagnostics.Status`.

``level`` is a ``byte`` field: rclpy holds it as ``bytes`` of length 1, rosbags as an int; both
are read and written. The nested ``DiagnosticStatus`` and ``KeyValue`` objects are built with the
classes given (rclpy's or rosbags'), so this module imports no ROS package.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..pipeline.diagnostics import Level, Status
from .fields import MessageError

__all__ = ["fill_diagnostic_array", "statuses_from_msg"]


def _level_field(level: Level, current: object) -> object:
    return bytes([int(level)]) if isinstance(current, bytes | bytearray) else int(level)


def fill_diagnostic_array(
    msg: Any, statuses: Sequence[Status], status_type: Callable[[], Any], key_value_type: Callable[[], Any]
) -> Any:
    """Write ``statuses`` into a ``DiagnosticArray`` (the header is left to the caller).

    Args:
        msg: The array message.
        statuses: The node's statuses, in order.
        status_type: Makes an empty ``DiagnosticStatus``.
        key_value_type: Makes an empty ``KeyValue``.
    """
    out = []
    for s in statuses:
        st = status_type()
        st.level = _level_field(s.level, st.level)
        st.name, st.message, st.hardware_id = s.name, s.message, s.hardware_id
        pairs = []
        for key, value in s.values:
            kv = key_value_type()
            kv.key, kv.value = key, value
            pairs.append(kv)
        st.values = pairs
        out.append(st)
    msg.status = out
    return msg


def statuses_from_msg(msg: Any) -> list[Status]:
    """The statuses of a ``DiagnosticArray``.

    Raises:
        MessageError: A level outside OK, WARN, ERROR, STALE.
    """
    out = []
    for st in msg.status:
        raw = st.level
        number = raw[0] if isinstance(raw, bytes | bytearray) else int(raw)
        try:
            level = Level(number)
        except ValueError:
            raise MessageError(f"DiagnosticStatus {st.name!r}: level {number} is not 0..3") from None
        values = tuple((str(kv.key), str(kv.value)) for kv in st.values)
        out.append(Status(str(st.name), level, str(st.message), values, str(st.hardware_id)))
    return out
