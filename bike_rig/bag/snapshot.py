"""The recorder's snapshot buffer: the last seconds of serialized messages, in memory.

As rosbag2's snapshot mode: every message is also kept, as received bytes, in a ring buffer
bounded in time (``duration_s`` of log time) and bytes (``max_bytes``), oldest out first;
:func:`write_snapshot` writes it (or its last ``seconds``) into a new bag. The newest message of
each latched topic (readings, parameter set, model) is kept apart and written into every
snapshot at its own log time, so a snapshot can always be replayed.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from rosbags.interfaces import Qos

from .errors import BagError
from .writer import BagWriter, Compression

__all__ = ["MESSAGE_OVERHEAD", "BufferedMessage", "SnapshotBuffer", "SnapshotTopic", "write_snapshot"]

MESSAGE_OVERHEAD = 240
"""Bytes of memory a buffered message takes besides its data (the tuple, the bytes object and
the integers: 241 measured with tracemalloc for a 92-byte gyro batch), counted against ``max_bytes``."""


class BufferedMessage(NamedTuple):
    """One message as the recorder took it: topic, log and publish time [ns], sequence, CDR bytes."""

    topic: str
    log_time: int
    publish_time: int
    sequence: int
    data: bytes


@dataclass(frozen=True)
class SnapshotTopic:
    """A topic as a snapshot bag declares it: name, type and the QoS profiles its publishers offered."""

    name: str
    msgtype: str
    offered_qos: tuple[Qos, ...]


class SnapshotBuffer:
    """A ring buffer of the last ``duration_s`` seconds, in at most ``max_bytes`` of memory.

    Args:
        duration_s: Log time kept back from the newest message, s (> 0).
        max_bytes: Memory kept at most, bytes (> 0): message data plus ``MESSAGE_OVERHEAD``
            per message; the oldest leave first.
        latched: Topics whose newest message is always kept (see the module docstring).

    Raises:
        ValueError: A limit that is not positive.
    """

    def __init__(self, duration_s: float, max_bytes: int, latched: Iterable[str] = ()) -> None:
        """An empty buffer with these limits."""
        if not (duration_s > 0 and max_bytes > 0):
            raise ValueError(f"snapshot limits must be positive, got {duration_s!r} s and {max_bytes!r} B")
        self.duration_ns = int(round(duration_s * 1e9))
        self.max_bytes = int(max_bytes)
        self.latched_topics = frozenset(latched)
        self._messages: deque[BufferedMessage] = deque()
        self._latched: dict[str, BufferedMessage] = {}
        self.bytes = 0
        """Memory the ring holds now, bytes (data plus ``MESSAGE_OVERHEAD`` per message)."""
        self.evicted = 0
        """Messages that left the ring (older than the window, or beyond the byte limit)."""

    def __len__(self) -> int:
        """Messages in the ring (the latched ones kept apart not counted)."""
        return len(self._messages)

    def push(self, message: BufferedMessage) -> None:
        """Keep a message; drop the oldest ones beyond the window or the byte limit."""
        self._messages.append(message)
        self.bytes += len(message.data) + MESSAGE_OVERHEAD
        if message.topic in self.latched_topics:
            self._latched[message.topic] = message
        oldest_kept = message.log_time - self.duration_ns
        ring = self._messages
        while ring and (self.bytes > self.max_bytes or ring[0].log_time < oldest_kept):
            self.bytes -= len(ring.popleft().data) + MESSAGE_OVERHEAD
            self.evicted += 1

    def window(self, seconds: float = 0.0) -> list[BufferedMessage]:
        """The messages of the last ``seconds`` (all the ring holds when 0), latched ones first, in log-time order.

        Raises:
            ValueError: ``seconds`` is negative or not finite.
        """
        if not (seconds >= 0 and seconds < float("inf")):
            raise ValueError(f"snapshot seconds must be 0 (all) or positive, got {seconds!r}")
        ring = list(self._messages)
        if ring and seconds > 0:
            first = ring[-1].log_time - int(round(seconds * 1e9))
            ring = [m for m in ring if m.log_time >= first]
        in_ring = {id(m) for m in ring}
        older = [m for m in self._latched.values() if id(m) not in in_ring]
        return sorted(older, key=lambda m: m.log_time) + ring


def write_snapshot(
    path: Path,
    messages: Sequence[BufferedMessage],
    topics: Sequence[SnapshotTopic],
    compression: Compression | str = Compression.ZSTD,
    custom_data: dict[str, str] | None = None,
) -> BagWriter:
    """Write ``messages`` into a new bag at ``path`` with every topic of ``topics`` declared.

    Returns:
        The closed writer (its counts and files).

    Raises:
        BagExistsError: ``path`` exists.
        BagError: A message's topic is not among ``topics``, or the bag cannot be written.
    """
    declared = {t.name for t in topics}
    unknown = sorted({m.topic for m in messages} - declared)
    if unknown:
        raise BagError(str(path), f"snapshot messages on undeclared topics {unknown}")
    writer = BagWriter(path, compression=compression, flush_period_s=3600.0, custom_data=custom_data)
    with writer:
        for t in topics:
            writer.add_topic(t.name, t.msgtype, offered_qos=t.offered_qos)
        for m in messages:
            writer.write(m.topic, m.log_time, m.data, m.publish_time, m.sequence)
    return writer
