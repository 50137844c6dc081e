"""Decode rig ``GyroBatch`` messages from their CDR bytes, with numpy views for the samples.

What rosbags' deserializer gives for the installed definition, field for field and bit for bit,
without a message object per batch: one message (:func:`gyro_batch`), or a recording's at once
as each trial's columns (:func:`gyro_columns`). Layout (little-endian CDR after the 4-byte
encapsulation header; offsets from its end, 64-bit values aligned to 8, strings and lengths to 4)::

    int32 sec, uint32 nanosec, string frame_id       (std_msgs/Header)
    string trial_id
    uint64 first_index, float64 sample_rate_hz
    float64[] rates, float64[] raw_volts
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..pipeline.acquire import NS_PER_S, SampleBatch, SampleBlock

__all__ = ["GyroColumns", "gyro_batch", "gyro_columns"]

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]
U8Rows = NDArray[np.uint8]

_HEAD = struct.Struct("<iII")
_U32 = struct.Struct("<I")
_FIRST_RATE_N = struct.Struct("<QdI")


def _string(data: bytes, at: int) -> tuple[str, int]:
    """The CDR string at ``at`` (offset in ``data``) and the offset after it."""
    (n,) = _U32.unpack_from(data, at)
    if n < 1 or at + 4 + n > len(data) or data[at + 3 + n] != 0:
        raise ValueError("bad string")
    return data[at + 4 : at + 3 + n].decode(), at + 4 + n


def _align(at: int, size: int) -> int:
    """The offset ``at`` (in the message) moved on to a multiple of ``size`` after the header."""
    return 4 + ((at - 4 + size - 1) & ~(size - 1))


def _volts_at(after_rates: int, m: int) -> int:
    """Where the raw volts start, after their uint32 count at ``after_rates``."""
    return 4 + (((after_rates + 7) & ~7) if m else after_rates)


def gyro_batch(data: bytes) -> SampleBatch | None:
    """The batch a little-endian CDR ``GyroBatch`` holds, or None when it is not one this reads exactly."""
    try:
        if data[:2] != b"\x00\x01":
            return None
        sec, nanosec, _ = _HEAD.unpack_from(data, 4)
        frame_id, at = _string(data, 12)
        trial_id, at = _string(data, _align(at, 4))
        at = _align(at, 8)
        first, rate_hz, n = _FIRST_RATE_N.unpack_from(data, at)
        at += 20 + (4 if n else 0)
        rates = np.frombuffer(data, "<f8", n, at)
        at += 8 * n
        (m,) = _U32.unpack_from(data, at)
        at = _volts_at(at, m)
        volts = np.frombuffer(data, "<f8", m, at)
        if len(data) - (at + 8 * m) > 3 or first >= 2**63:
            return None
    except (ValueError, struct.error, UnicodeDecodeError):
        return None
    return SampleBatch(trial_id, first, rate_hz, rates, volts, sec * NS_PER_S + nanosec, frame_id)


# ---------------------------------------------------------------- many messages at once


class _IrregularError(Exception):
    """A message :func:`gyro_batch` would not read (then none is read as columns)."""


def _column(rows: U8Rows, at: int, dtype: str) -> NDArray[Any]:
    """The value of type ``dtype`` at offset ``at`` of every row."""
    size = np.dtype(dtype).itemsize
    if at + size > rows.shape[1]:
        raise _IrregularError
    return np.ascontiguousarray(rows[:, at : at + size]).view(dtype)[:, 0]


def _split(rows: U8Rows, at: int) -> Iterator[tuple[int, NDArray[np.bool_] | slice]]:
    """Each value of the uint32 at offset ``at`` of the rows, with the rows that hold it (a slice: all)."""
    values = _column(rows, at, "<u4")
    distinct = np.unique(values).tolist()
    for v in distinct:
        yield v, (values == v) if len(distinct) > 1 else slice(None)


def _strings(rows: U8Rows, at: int, n: int) -> tuple[list[str], IntArray]:
    """The CDR strings of length field ``n`` at offset ``at``: the distinct ones, and each row's."""
    if n < 1 or at + 4 + n > rows.shape[1] or np.any(rows[:, at + 3 + n] != 0):
        raise _IrregularError
    if n == 1:
        return [""], np.zeros(len(rows), dtype=np.int64)
    keys = np.ascontiguousarray(rows[:, at + 4 : at + 3 + n]).view(f"V{n - 1}")[:, 0]
    distinct, which = np.unique(keys, return_inverse=True)
    try:
        return [bytes(k).decode() for k in distinct], which.astype(np.int64)
    except UnicodeDecodeError:
        raise _IrregularError from None


@dataclass(frozen=True)
class _Layout:
    """Messages of one layout (the same lengths of message, strings and arrays), one row each.

    Attributes:
        index: Their places in the input.
        rows: Their bytes.
        frames: The distinct frame ids, and each row's.
        trials: The distinct trial ids, and each row's.
        first_at: Offset of first_index (then sample_rate_hz).
        rates_at: Offset of the rates; ``n`` of them.
        volts_at: Offset of the raw volts; ``m`` of them.
    """

    index: IntArray
    rows: U8Rows
    frames: tuple[list[str], IntArray]
    trials: tuple[list[str], IntArray]
    first_at: int
    rates_at: int
    n: int
    volts_at: int
    m: int

    def copy_into(self, out: FloatArray, starts: IntArray, at: int, count: int) -> None:
        """Put each row's ``count`` float64 at offset ``at`` into ``out`` from ``starts`` on (one start a row)."""
        raw, width = out.view(np.uint8), 8 * count
        runs = np.flatnonzero(np.diff(starts) != count) + 1  # (rows that follow each other in ``out``: one copy)
        for a, b in zip([0, *runs.tolist()], [*runs.tolist(), len(starts)], strict=True):
            first = int(starts[a]) * 8
            raw[first : first + (b - a) * width].reshape(b - a, width)[...] = self.rows[a:b, at : at + width]


def _layouts(datas: Sequence[bytes]) -> list[_Layout]:
    """The messages by layout, each field where :func:`gyro_batch` finds it.

    Raises:
        _IrregularError: One is not a message :func:`gyro_batch` reads.
    """
    lengths = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
    out = []
    for length in np.unique(lengths).tolist():
        index = np.flatnonzero(lengths == length)
        rows = np.frombuffer(b"".join([datas[i] for i in index.tolist()]), np.uint8).reshape(len(index), length)
        if length < 16 or np.any(rows[:, 0] != 0) or np.any(rows[:, 1] != 1):
            raise _IrregularError
        for n1, in1 in _split(rows, 12):
            rows1, index1 = rows[in1], index[in1]
            frame_ids, frame1 = _strings(rows1, 12, n1)
            at = _align(16 + n1, 4)
            for n2, in2 in _split(rows1, at):
                rows2, index2, frame2 = rows1[in2], index1[in2], frame1[in2]
                trial_ids, trial2 = _strings(rows2, at, n2)
                first_at = _align(at + 4 + n2, 8)
                if np.any(_column(rows2, first_at, "<u8") >= 2**63):
                    raise _IrregularError
                for n, in3 in _split(rows2, first_at + 16):
                    rates_at = first_at + 20 + (4 if n else 0)
                    rows3 = rows2[in3]
                    for m, in4 in _split(rows3, rates_at + 8 * n):
                        volts_at = _volts_at(rates_at + 8 * n, m)
                        if not 0 <= length - (volts_at + 8 * m) <= 3:
                            raise _IrregularError
                        pick = np.arange(len(rows2))[in3][in4]
                        out.append(
                            _Layout(
                                index2[pick],
                                rows3[in4],
                                (frame_ids, frame2[pick]),
                                (trial_ids, trial2[pick]),
                                first_at,
                                rates_at,
                                n,
                                volts_at,
                                m,
                            )
                        )
    return out


def _codes(k: int, parts: list[tuple[IntArray, tuple[list[str], IntArray]]]) -> tuple[list[str], IntArray]:
    """The distinct strings in order of first message, and each of the ``k`` messages' (its place among them)."""
    names: dict[str, int] = {}
    code = np.zeros(k, dtype=np.int64)
    for index, (distinct, which) in parts:
        ids = np.array([names.setdefault(s, len(names)) for s in distinct], dtype=np.int64)
        code[index] = ids[which]
    _, first = np.unique(code, return_index=True)
    order = np.argsort(first)
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    listed = list(names)
    return [listed[c] for c in order.tolist()], rank[code]


@dataclass(frozen=True)
class GyroColumns:
    """GyroBatch messages decoded together: each trial's batches as one block.

    Attributes:
        trial_ids: The trials in the order of their first message ("" for batches outside any).
        first: Each trial's first message (its place in the input).
        blocks: Each trial's batches, in input order.
    """

    trial_ids: tuple[str, ...]
    first: tuple[int, ...]
    blocks: tuple[SampleBlock, ...]


def gyro_columns(datas: Sequence[bytes]) -> GyroColumns | None:
    """Each trial's batches in little-endian CDR ``GyroBatch`` messages, as :func:`gyro_batch` reads each.

    Returns:
        The trials' blocks, or None when one message is not one :func:`gyro_batch` reads.
    """
    try:
        layouts = _layouts(datas)
    except _IrregularError:
        return None
    k = len(datas)
    trial_ids, trial = _codes(k, [(g.index, g.trials) for g in layouts])
    frame_ids, frame = _codes(k, [(g.index, g.frames) for g in layouts])
    first_index = np.zeros(k, dtype=np.int64)
    rate_hz = np.zeros(k, dtype=np.float64)
    stamp = np.zeros(k, dtype=np.int64)
    n_rates = np.zeros(k, dtype=np.int64)
    n_volts = np.zeros(k, dtype=np.int64)
    for g in layouts:
        first_index[g.index] = _column(g.rows, g.first_at, "<u8")
        rate_hz[g.index] = _column(g.rows, g.first_at + 8, "<f8")
        stamp[g.index] = _column(g.rows, 4, "<i4").astype(np.int64) * NS_PER_S + _column(g.rows, 8, "<u4")
        n_rates[g.index], n_volts[g.index] = g.n, g.m
    order = np.argsort(trial, kind="stable")  # (each trial's messages together, in input order)
    rank = np.empty(k, dtype=np.int64)
    rank[order] = np.arange(k)
    starts = np.zeros(len(trial_ids) + 1, dtype=np.int64)
    np.cumsum(np.bincount(trial, minlength=len(trial_ids)), out=starts[1:])

    def gather(count: IntArray, field: str) -> tuple[IntArray, FloatArray]:
        bounds = np.zeros(k + 1, dtype=np.int64)
        np.cumsum(count[order], out=bounds[1:])
        out = np.empty(int(bounds[-1]), dtype="<f8")
        for g in layouts:
            at, n = (g.rates_at, g.n) if field == "rates" else (g.volts_at, g.m)
            if n:
                g.copy_into(out, bounds[rank[g.index]], at, n)
        return bounds, out.astype(np.float64, copy=False)

    bounds, rates = gather(n_rates, "rates")
    all_volts = cache(lambda: gather(n_volts, "volts"))
    blocks = []
    for t, tid in enumerate(trial_ids):
        s, e = int(starts[t]), int(starts[t + 1])
        mine = order[s:e]
        distinct, seen, which = np.unique(frame[mine], return_index=True, return_inverse=True)
        by_seen = np.argsort(seen)
        local = np.empty(len(distinct), dtype=np.int64)
        local[by_seen] = np.arange(len(distinct))

        def volts(s: int = s, e: int = e) -> tuple[IntArray, FloatArray]:
            vb, v = all_volts()
            return vb[s : e + 1] - vb[s], v[vb[s] : vb[e]]

        blocks.append(
            SampleBlock(
                tid,
                first_index[mine],
                rate_hz[mine],
                bounds[s : e + 1] - bounds[s],
                rates[bounds[s] : bounds[e]],
                volts,
                stamp[mine],
                tuple(frame_ids[int(distinct[j])] for j in by_seen.tolist()),
                local[which],
            )
        )
    return GyroColumns(tuple(trial_ids), tuple(int(order[s]) for s in starts[:-1].tolist()), tuple(blocks))
