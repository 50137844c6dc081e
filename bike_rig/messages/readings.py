"""Converters of ``ReadingEntry``: one static reading entered during a session.

The message's ``header.stamp`` is the entry's wall time (:attr:`ReadingEntry.stamp_ns`); the
other fields are the record's. The converters do not check the reading: that is
:func:`bike_rig.pipeline.readings.check_entry`'s job, where the parameter node applies it.
"""

from __future__ import annotations

from ..pipeline.readings import ReadingEntry
from .fields import set_stamp, stamp_ns
from .protocols import ReadingEntryMsg

__all__ = ["fill_reading_entry", "reading_entry_from_msg"]


def reading_entry_from_msg(msg: ReadingEntryMsg) -> ReadingEntry:
    """A ``ReadingEntry`` message as a :class:`ReadingEntry` (stamp in ns, value and σ in the key's unit)."""
    return ReadingEntry(str(msg.key), float(msg.value), float(msg.sigma), stamp_ns(msg.header), str(msg.note))


def fill_reading_entry(msg: ReadingEntryMsg, entry: ReadingEntry) -> ReadingEntryMsg:
    """Write an entry into a ``ReadingEntry`` message (its stamp too) and return the message."""
    set_stamp(msg, entry.stamp_ns)
    msg.key = entry.key
    msg.value = float(entry.value)
    msg.sigma = float(entry.sigma)
    msg.note = entry.note
    return msg
