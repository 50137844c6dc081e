"""An MCAP file read chunk by chunk with the ``mcap`` library: messages of some topics, the first corrupt chunk."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from ..core.errors import one_line

if TYPE_CHECKING:
    from mcap.records import Channel, Message

__all__ = ["exception_text", "file_messages", "first_corrupt_chunk", "no_collection"]


@contextmanager
def no_collection() -> Iterator[None]:
    """No cyclic garbage collection meanwhile (a bag's messages are many objects and no cycles)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def file_messages(stream: BinaryIO, topics: set[str]) -> list[tuple[Channel, Message]]:
    """The messages of ``topics`` in an MCAP file, as the mcap library's reader gives them in file order.

    (``iter_messages(topics, log_time_order=False)``: chunk by chunk as the summary lists them;
    a file without chunk indexes read by the library's reader.)
    """
    from mcap.reader import make_reader
    from mcap.records import Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    reader = make_reader(stream)
    summary = reader.get_summary()
    if summary is None or not summary.chunk_indexes:
        return [(c, m) for _, c, m in reader.iter_messages(topics=list(topics), log_time_order=False)]
    channels = summary.channels
    out = []
    for index in summary.chunk_indexes:
        if index.message_index_offsets and all(channels[c].topic not in topics for c in index.message_index_offsets):
            continue
        stream.seek(index.chunk_start_offset)
        chunk = next(StreamReader(stream, skip_magic=True, emit_chunks=True).records)
        if not isinstance(chunk, Chunk):
            raise ValueError(f"a {type(chunk).__name__} record where the index puts a chunk")
        for record in breakup_chunk(chunk):
            if isinstance(record, Message):
                channel = channels[record.channel_id]
                if channel.topic in topics:
                    out.append((channel, record))
    return out


def first_corrupt_chunk(path: Path) -> str:
    """``"<file>: chunk at byte N is corrupt (why)"``: the first chunk the mcap library cannot unpack ("" if none)."""
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader, breakup_chunk

    try:
        with path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
            indexes = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset) if summary else []
            for index in indexes:
                stream.seek(index.chunk_start_offset)
                try:
                    record = next(StreamReader(stream, skip_magic=True, emit_chunks=True).records)
                    if not isinstance(record, Chunk):
                        raise ValueError(f"a {type(record).__name__} record where the index puts a chunk")
                    for _ in breakup_chunk(record, validate_crc=True):
                        pass
                except (GeneratorExit, KeyboardInterrupt):
                    raise
                except Exception as exc:  # the decompressors' and the library's own classes
                    reason = f"{type(exc).__name__}: {exception_text(exc)}"
                    return f"{path.name}: chunk at byte {index.chunk_start_offset} is corrupt ({reason})"
    except OSError:
        return ""
    except Exception:  # its summary does not read: rosbags' reader says what is wrong
        return ""
    return ""


def exception_text(exc: BaseException) -> str:
    """The exception's message on one line, at most 400 characters (rosbags passes on multi-line YAML errors)."""
    text = one_line(str(exc)).rstrip(".")
    return text[:400] + "..." if len(text) > 400 else text or type(exc).__name__
