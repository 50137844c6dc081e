"""The messages of some topics of a bag opened by the fast path, as one table.

:func:`read_table` reads them in the order rosbags' reader yields them (log time, then chunk
offset, then position in the chunk): every chunk that holds one is read, checked (size and
checksum) and decompressed into one buffer (the chunks on every core: zstd releases the GIL;
the checksum is ISA-L's crc32, about 20 GB/s, where binascii's takes a third of a chunk's
decompression time), and its message records are found from the chunk's message index (the records
between them are walked, so that none is missed). The table holds positions into that buffer:
no Python object per message. Anything rosbags would read differently raises
:class:`~bike_rig.bag.fastread.Unusual`. Beside rosbags' order, each message's publication
sequence number (as the recorder stored it) and its rank in the recorder's order of storage
(the file by the split index in its name, then the record's place in the file) are kept.
"""

from __future__ import annotations

import os
import struct
import threading
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .fastread import Chunk, FastBag, Unusual, need, split_order

try:
    from isal.isal_zlib import crc32
except ImportError:  # (the same checksum, slower: no ISA-L wheel for this platform)
    from binascii import crc32

__all__ = ["CorruptChunk", "MessageTable", "read_le", "read_table"]


class CorruptChunk(Unusual):
    """A chunk that does not decompress: its file, its offset [bytes] and the decompressor's reason."""

    def __init__(self, path: Path, offset: int, reason: str) -> None:
        """Keep where the chunk is and why it cannot be read."""
        super().__init__(f"{path.name}: chunk at byte {offset}: {reason}")
        self.path, self.offset, self.reason = path, offset, reason


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()).rstrip(".") or type(exc).__name__

IntArray = NDArray[np.int64]

#: Bytes before a message record's data: opcode, record length, channel, sequence, log and publish time.
_MESSAGE_HEAD = 1 + 8 + 2 + 4 + 8 + 8

#: Threads that decompress and check chunks at once.
_WORKERS = max(1, min(len(os.sched_getaffinity(0)), 4))

_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


@dataclass(frozen=True)
class MessageTable:
    """Messages of some topics in rosbags' order, as positions into the decompressed chunks.

    Attributes:
        buffer: Every chunk read, decompressed, one after the other (read-only).
        topics: The topics, indexed by ``topic``.
        topic: Each message's topic (index into ``topics``).
        log_time: Each message's log time, ns.
        start: Where its data (CDR bytes) start in ``buffer``.
        size: Its length, bytes.
        sequence: Its publication sequence number as the recorder stored it (0: none).
        stream: Its rank in the recorder's order of storage: the storage files by the split
            index in their names (``NAME_2`` before ``NAME_10``, whatever order metadata.yaml
            lists them in), then the chunks by offset and the records in each chunk.
    """

    buffer: NDArray[np.uint8]
    topics: tuple[str, ...]
    topic: IntArray
    log_time: IntArray
    start: IntArray
    size: IntArray
    sequence: IntArray
    stream: IntArray

    def __len__(self) -> int:
        """Number of messages."""
        return len(self.topic)

    def data(self, i: int) -> bytes:
        """The data of message ``i``."""
        a = int(self.start[i])
        return self.buffer[a : a + int(self.size[i])].tobytes()


def read_le(buf: NDArray[np.uint8], dtype: str, at: IntArray) -> NDArray[Any]:
    """The little-endian ``dtype`` value at each byte offset ``at`` of ``buf`` (offsets checked by the caller)."""
    width = np.dtype(dtype).itemsize
    need(len(buf) >= width, "record beyond its chunk")
    return np.ndarray(shape=(len(buf) - width + 1,), dtype=dtype, buffer=buf, strides=(1,))[at]


_PER_THREAD = threading.local()


def _zstd() -> Any:
    """This thread's zstd decompressor (one may not be shared between threads)."""
    made = getattr(_PER_THREAD, "zstd", None)
    if made is None:
        try:
            import zstandard
        except ImportError:
            raise Unusual("no zstandard") from None
        made = _PER_THREAD.zstd = zstandard.ZstdDecompressor()
    return made


def _decompress_into(out: memoryview, data: memoryview, compression: str) -> None:
    """Decompress one chunk's records into ``out`` (exactly filled)."""
    if compression == "zstd":
        reader = _zstd().stream_reader(data, read_across_frames=True)
        got = 0
        while got < len(out):
            n = reader.readinto(out[got:])
            if not n:
                break
            got += n
        need(got == len(out) and not reader.read(1), "chunk size mismatch")
    elif compression == "lz4":
        from lz4.frame import decompress  # type: ignore[import-untyped]

        records = decompress(data)
        need(len(records) == len(out), "chunk size mismatch")
        out[:] = records
    elif compression == "":
        need(len(data) == len(out), "chunk size mismatch")
        out[:] = data
    else:
        raise Unusual(f"chunk compression {compression!r}")


@dataclass(frozen=True)
class _Read:
    """A chunk as read from its file: the compressed records, checksum and message index records."""

    chunk: Chunk
    data: memoryview
    crc: int
    index: memoryview


def _spans(f: Any, chunks: list[Chunk]) -> list[memoryview]:
    """Each chunk's record and message index, read with its neighbours in one call per 64 MiB.

    (A recording's chunks follow one another in the file: thousands of them, one read.)
    """
    out: list[memoryview] = []
    i = 0
    while i < len(chunks):
        j, start = i, chunks[i].offset
        while j + 1 < len(chunks):
            nxt = chunks[j + 1]
            if nxt.offset < _end(chunks[j]) or _end(nxt) > start + _SPAN_BYTES:
                break
            j += 1
        f.seek(start)
        data = memoryview(f.read(_end(chunks[j]) - start))
        out += [data[c.offset - start : _end(c) - start] for c in chunks[i : j + 1]]
        i = j + 1
    return out


def _end(chunk: Chunk) -> int:
    """Where a chunk's record and its message index end in the file, bytes."""
    return chunk.offset + chunk.length + chunk.index_length


#: Bytes read at once for the chunks of :func:`_spans`.
_SPAN_BYTES = 64 << 20


def _read_chunk(chunk: Chunk, raw: memoryview) -> _Read:
    """A chunk from its bytes in the file (its record, then its message index)."""
    head = 9 + 40 + len(chunk.compression.encode())
    need(len(raw) == chunk.length + chunk.index_length and raw[0] == 0x06, "truncated chunk")
    need(head + chunk.compressed_size <= chunk.length, "chunk data beyond its record")
    crc = _U32.unpack_from(raw, 9 + 24)[0]
    return _Read(chunk, raw[head : head + chunk.compressed_size], crc, raw[chunk.length :])


def _indexed_offsets(index: memoryview) -> IntArray:
    """Every message record's offset in its chunk, from the chunk's message index records."""
    parts, pos = [], 0
    while pos < len(index):
        need(index[pos] == 0x07 and pos + 15 <= len(index), "not a message index record")
        size = _U64.unpack_from(index, pos + 1)[0]
        n = _U32.unpack_from(index, pos + 11)[0]
        need(size == 6 + n and n % 16 == 0 and pos + 9 + size <= len(index), "bad message index record")
        pairs = np.frombuffer(index, dtype="<u8", count=n // 8, offset=pos + 15)
        parts.append(pairs[1::2].astype(np.int64))
        pos += 9 + size
    return np.sort(np.concatenate(parts)) if parts else np.empty(0, np.int64)


def _walk(records: memoryview, start: int, stop: int) -> list[int]:
    """Offsets of the message records among the records in ``records[start:stop]``."""
    out, pos = [], start
    while pos < stop:
        need(pos + 9 <= stop, "truncated record in a chunk")
        size = _U64.unpack_from(records, pos + 1)[0]
        if records[pos] == 0x05:
            need(size >= _MESSAGE_HEAD - 9, "message record too short")
            out.append(pos)
        pos += 9 + size
    need(pos == stop, "records overrun")
    return out


def _keys_of_chunks(
    buffer: NDArray[np.uint8], reads: list[_Read], bases: list[int], lut: IntArray
) -> tuple[IntArray, ...]:
    """The wanted messages of a file's decompressed chunks (each at its ``bases`` in ``buffer``).

    Every message record of a chunk, in file order: its message index gives them, and the
    records between them (schemas, channels) are walked so that none the index leaves out is
    missed. The numpy work is done once for all the chunks (a recording flushed every 0.5 s
    holds thousands of small ones).

    Returns:
        Columns: log time, chunk offset, position in the chunk, topic, data start, data size,
        publication sequence.
    """
    local = [_indexed_offsets(r.index) for r in reads]
    lengths = np.array([r.chunk.uncompressed_size for r in reads], dtype=np.int64)
    counts = np.array([o.size for o in local], dtype=np.int64)
    at = np.concatenate(local) if local else np.empty(0, np.int64)
    cid = np.repeat(np.arange(len(reads)), counts)
    need(bool(np.all((at >= 0) & (at + _MESSAGE_HEAD <= lengths[cid]))), "index beyond the chunk")
    glob = at + np.array(bases, dtype=np.int64)[cid]
    need(bool(np.all(buffer[glob] == 0x05)), "index points at a non-message record")
    ends = at + 9 + (read_le(buffer, "<u8", glob + 1).astype(np.int64) if at.size else at)
    same = cid[1:] == cid[:-1]
    last = np.flatnonzero(np.append(~same, True)) if at.size else at  # each chunk's last message
    first = np.flatnonzero(np.insert(~same, 0, True)) if at.size else at
    need(bool(np.all(ends - at >= _MESSAGE_HEAD)) and bool(np.all(ends[:-1][same] <= at[1:][same])), "records overlap")
    need(bool(np.all(ends[last] <= lengths[cid[last]])), "record beyond the chunk")
    # the gaps: before each chunk's first message (or all of an empty chunk), between, after the last
    empty = np.flatnonzero(counts == 0)
    gap_chunk = np.concatenate((empty, cid[first], cid[:-1][same], cid[last]))
    gap_from = np.concatenate((np.zeros(empty.size + first.size, np.int64), ends[:-1][same], ends[last]))
    gap_to = np.concatenate((lengths[empty], at[first], at[1:][same], lengths[cid[last]]))
    unlisted = False
    for c, a, b in zip(*(x[gap_from < gap_to].tolist() for x in (gap_chunk, gap_from, gap_to)), strict=True):
        extra = _walk(buffer.data[bases[c] : bases[c] + int(lengths[c])], a, b)
        if extra:  # messages the index does not list: that chunk's messages in file order
            local[c] = np.sort(np.concatenate((local[c], np.array(extra, dtype=np.int64))))
            unlisted = True
    if unlisted:
        counts = np.array([o.size for o in local], dtype=np.int64)
        at = np.concatenate(local)
        cid = np.repeat(np.arange(len(reads)), counts)
        glob = at + np.array(bases, dtype=np.int64)[cid]
    if not at.size:
        return tuple(np.empty(0, np.int64) for _ in range(7))
    log_time = read_le(buffer, "<u8", glob + 15)
    need(bool(np.all(log_time < 2**63)), "log time beyond 2**63")
    log_time = log_time.astype(np.int64)
    topic = lut[read_le(buffer, "<u2", glob + 9)]
    start_time = np.array([r.chunk.start_time for r in reads], dtype=np.int64)[cid]
    end_time = np.array([r.chunk.end_time for r in reads], dtype=np.int64)[cid]
    keep = np.flatnonzero((topic >= 0) & (log_time >= start_time) & (log_time <= end_time))
    where = np.array([r.chunk.offset for r in reads], dtype=np.int64)[cid[keep]]
    position = keep - np.repeat(np.cumsum(counts) - counts, counts)[keep]
    size = read_le(buffer, "<u8", glob[keep] + 1).astype(np.int64) - (_MESSAGE_HEAD - 9)
    sequence = read_le(buffer, "<u4", glob[keep] + 11).astype(np.int64)
    return log_time[keep], where, position, topic[keep], glob[keep] + _MESSAGE_HEAD, size, sequence


def _unpack(records: memoryview, read: _Read, path: Path) -> None:
    """Decompress one chunk into ``records`` and check its checksum.

    Raises:
        CorruptChunk: It does not decompress.
        Unusual: Its size or checksum is not the recorded one.
    """
    try:
        _decompress_into(records, read.data, read.chunk.compression)
    except Unusual:
        raise
    except Exception as exc:  # the decompressor's own errors
        raise CorruptChunk(path, read.chunk.offset, f"does not decompress: {_one_line(exc)}") from None
    need(not read.crc or crc32(records) == read.crc, "chunk checksum mismatch")


def _unpack_all(jobs: list[tuple[memoryview, _Read, Path]]) -> None:
    """:func:`_unpack` every chunk, on every core (zstd releases the GIL), in a few groups of chunks.

    Raises:
        CorruptChunk, Unusual: as :func:`_unpack`, for the first failing chunk in file order.
    """
    if len(jobs) < 2 or _WORKERS < 2:
        for job in jobs:
            _unpack(*job)
        return
    step = max(1, len(jobs) // (4 * _WORKERS))  # (a task per chunk costs more than a small chunk takes)

    def unpack(first: int) -> None:
        for job in jobs[first : first + step]:
            _unpack(*job)

    with ThreadPoolExecutor(max_workers=_WORKERS) as pool:
        for _ in pool.map(unpack, range(0, len(jobs), step)):  # (in order: the first failure raises)
            pass


def read_table(bag: FastBag, topics: Iterable[str]) -> MessageTable:
    """Every message of ``topics`` in the order rosbags' reader yields them.

    Raises:
        Unusual: A chunk cannot be read as rosbags would (it then raises the error).
    """
    names = tuple(dict.fromkeys(topics))
    code = {t: i for i, t in enumerate(names)}
    ranks = {p: r for r, p in enumerate(sorted((s.path for s in bag.storages), key=split_order))}
    files: list[tuple[IntArray, list[_Read], Path]] = []
    for storage, route in zip(bag.storages, bag.routes, strict=True):
        wanted = {cid: code[t] for cid, t in route.items() if t in code}
        if not wanted:
            continue
        lut = np.full(65536, -1, dtype=np.int64)
        for cid, c in wanted.items():
            lut[cid] = c
        chunks = [ch for ch in storage.chunks if any(ch.channel_count.get(c, 0) for c in wanted)]
        with storage.path.open("rb") as f:
            reads = [_read_chunk(ch, raw) for ch, raw in zip(chunks, _spans(f, chunks), strict=True)]
        files.append((lut, reads, storage.path))
    buffer = np.empty(sum(r.chunk.uncompressed_size for _, reads, _ in files for r in reads), dtype=np.uint8)
    jobs: list[tuple[memoryview, _Read, Path]] = []
    bases: list[list[int]] = []
    base = 0
    for _, reads, path in files:
        bases.append([])
        for read in reads:
            jobs.append((buffer.data[base : base + read.chunk.uncompressed_size], read, path))
            bases[-1].append(base)
            base += read.chunk.uncompressed_size
    _unpack_all(jobs)
    parts = []
    for (lut, reads, path), at in zip(files, bases, strict=True):
        if reads:
            cols = list(_keys_of_chunks(buffer, reads, at, lut))
            order = np.lexsort((cols[2], cols[1], cols[0]))  # log time, then chunk offset, then position
            rank = np.full(len(order), ranks[path], dtype=np.int64)
            parts.append((*(cols[i][order] for i in (3, 0, 4, 5, 6, 1, 2)), rank))
    buffer.flags.writeable = False
    if not parts:
        empty = np.empty(0, np.int64)
        return MessageTable(buffer, names, empty, empty, empty, empty, empty, empty)
    topic, log_time, start, size, sequence, where, position, rank = (
        np.concatenate(c) for c in zip(*parts, strict=True)
    )
    stream = np.empty(len(topic), dtype=np.int64)
    stream[np.lexsort((position, where, rank))] = np.arange(len(topic))
    return MessageTable(buffer, names, topic, log_time, start, size, sequence, stream)
