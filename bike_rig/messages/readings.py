"""Converters of ``ReadingEntry``: one static reading entered during a session.

The message's ``header.stamp`` is the entry's wall time (:attr:`ReadingEntry.stamp_ns`); the
other fields are the record's, copied by name. The converters do not check the reading: that is
:func:`bike_rig.pipeline.readings.check_entry`'s job, where the parameter node applies it.
"""

from __future__ import annotations

from ..pipeline.readings import ReadingEntry
from .fields import Message, fill_fields, record_fields

__all__ = ["fill_reading_entry", "reading_entry_from_msg"]


def reading_entry_from_msg(msg: Message) -> ReadingEntry:
    """A ``ReadingEntry`` message as a :class:`ReadingEntry` (stamp in ns, value and σ in the key's unit)."""
    return ReadingEntry(**record_fields(ReadingEntry, msg))


def fill_reading_entry(msg: Message, entry: ReadingEntry) -> Message:
    """Write an entry into a ``ReadingEntry`` message (its stamp too) and return the message."""
    fill_fields(msg, entry)
    return msg
