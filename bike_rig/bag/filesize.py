"""A storage file being written: its bookkeeping and its size on disk once closed.

:class:`~bike_rig.bag.writer.BagWriter` splits a bag by size (``max_bytes``) on these
estimates: the bytes written, the chunk in progress (at the file's compression ratio so far, or
bounded as if nothing in it compressed) and the closing records (rosbag2 metadata, summary,
footer). All sizes in bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = [
    "CHUNK_INDEX_BYTES",
    "CHUNK_RECORD_BYTES",
    "CLOSING_MARGIN",
    "MESSAGE_RECORD_OVERHEAD",
    "PENDING_SAFETY",
    "RATIO_MIN_BYTES",
    "FileStats",
]


PENDING_SAFETY = 1.25
"""Factor on the estimated size of the chunk in progress (chunks compress unevenly)."""

RATIO_MIN_BYTES = 16 << 10
"""Message bytes a file's chunks must hold before their size on disk sets the compression ratio."""

CHUNK_RECORD_BYTES = 256
"""Bytes of a chunk record and its message index records besides the messages, and the largest
growth of incompressible data in a zstd or lz4 frame beyond its 1/255."""

CLOSING_MARGIN = 1024
"""Bytes of a file's closing records besides the repeated schemas and channels, the rosbag2
metadata and the chunk indexes: statistics, summary offsets, footer, growth of the metadata."""

CHUNK_INDEX_BYTES = 100
"""Bytes of a chunk index record (plus 10 per channel)."""

MESSAGE_RECORD_OVERHEAD = 31 + 16
"""Bytes of an MCAP Message record besides its data (opcode, length, channel, sequence, times),
and of its entry in the chunk's message index."""


@dataclass
class FileStats:
    """One storage file: its name, log-time range [ns] and message count; bytes for the size estimate."""

    name: str
    start: int = 2**63 - 1
    end: int = 0
    count: int = 0
    size: int = 0
    """Bytes on disk at the last flush (the final size once closed)."""
    header: int = 0
    """Bytes of the MCAP header, schemas and channels (no message data)."""
    raw_flushed: int = 0
    """Message bytes (records, uncompressed) flushed into chunks."""
    raw_pending: int = 0
    """Message bytes (records, uncompressed) in the chunk not yet written."""
    ratio: float = 1.0
    """Bytes on disk per message byte, as measured on the chunks written (or the previous file's)."""
    writes: int = 0
    """How many times the file grew by chunks (each chunk gets an index entry in the summary)."""

    def entry(self) -> dict[str, Any]:
        """The file's entry in metadata.yaml's ``files``."""
        start = self.start if self.count else 0
        return {
            "path": self.name,
            "starting_time": {"nanoseconds_since_epoch": start},
            "duration": {"nanoseconds": self.end - self.start if self.count else 0},
            "message_count": self.count,
        }

    def estimated_size(self, extra: int = 0, worst: bool = False) -> int:
        """Bytes the file will take with its pending chunk and ``extra`` more message bytes.

        Args:
            extra: Message bytes (records) to add to the chunk in progress.
            worst: Bound them as if nothing compressed (else: at the file's ratio, on the safe side).
        """
        pending = self.raw_pending + extra
        if worst:
            return self.size + pending + pending // 255 + CHUNK_RECORD_BYTES
        return self.size + int(pending * self.ratio * PENDING_SAFETY)

    def estimated_closed(self, size: int, closing: int, channels: int, worst: bool = False) -> int:
        """Bytes the file would take on disk, closed, with one more message of ``size`` bytes.

        Args:
            size: The message's data, bytes.
            closing: Bytes of the closing records known to the writer: the rosbag2 metadata
                record and the schemas and channels that the summary repeats.
            channels: Channels in the file (each chunk index lists them).
            worst: The chunk in progress as if nothing in it compressed (else at the file's ratio).
        """
        # the summary indexes every chunk (one more for the last)
        closing += CLOSING_MARGIN + (self.writes + 1) * (CHUNK_INDEX_BYTES + 10 * channels)
        return self.estimated_size(size + MESSAGE_RECORD_OVERHEAD, worst) + closing

    def written(self, size: int) -> None:
        """The file has grown to ``size`` bytes: the pending chunk is on its way to the disk."""
        if size == self.size:
            return
        self.size = size
        self.writes += 1
        self.raw_flushed += self.raw_pending
        self.raw_pending = 0
        if self.raw_flushed >= RATIO_MIN_BYTES:  # a few small chunks are mostly chunk overhead
            self.ratio = (self.size - self.header) / self.raw_flushed
