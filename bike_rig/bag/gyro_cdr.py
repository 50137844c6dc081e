"""Decode the rig's ``GyroBatch`` messages straight from their CDR bytes, many at once.

rosbags builds one message object per message and one numpy array per field; a session holds
tens of thousands of batches. Here every field of every batch is read with a handful of numpy
operations over the whole set, and the samples are copied once into one array (runs of
batches recorded back to back are one strided copy each); the raw volts likewise, but only when
first asked for (a replay fits the rates alone: the chunks' buffer is kept until then). The result is what rosbags' CDR
deserializer gives, field for field and bit for bit; anything this decoder does not read
exactly as rosbags would (another layout of the type, big-endian CDR, a malformed message)
raises :class:`~bike_rig.bag.fastread.Unusual`, and the caller decodes with rosbags instead.

Layout (little-endian CDR after the 4-byte encapsulation header; offsets from its end,
64-bit values aligned to 8, strings and sequence lengths to 4)::

    int32 sec, uint32 nanosec, string frame_id       (std_msgs/Header)
    string trial_id
    uint64 first_index, float64 sample_rate_hz
    float64[] rates, float64[] raw_volts
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..pipeline.acquire import NS_PER_S, SampleBatch, SampleBlock
from .fastread import Unusual
from .msgtable import read_le

__all__ = ["GYRO_TYPE", "GyroColumns", "decode_gyro", "is_our_layout"]

GYRO_TYPE = "bike_rig_msgs/msg/GyroBatch"

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The field definitions this decoder reads (rosbags' ``fielddefs`` form: 1 base type,
#: 2 message, 4 sequence).
_LAYOUT: dict[str, Any] = {
    GYRO_TYPE: [
        ("header", (2, "std_msgs/msg/Header")),
        ("trial_id", (1, ("string", 0))),
        ("first_index", (1, ("uint64", 0))),
        ("sample_rate_hz", (1, ("float64", 0))),
        ("rates", (4, ((1, ("float64", 0)), 0))),
        ("raw_volts", (4, ((1, ("float64", 0)), 0))),
    ],
    "std_msgs/msg/Header": [("stamp", (2, "builtin_interfaces/msg/Time")), ("frame_id", (1, ("string", 0)))],
    "builtin_interfaces/msg/Time": [("sec", (1, ("int32", 0))), ("nanosec", (1, ("uint32", 0)))],
}


def _plain(desc: Any) -> Any:
    """A field description with rosbags' enums as ints (to compare with :data:`_LAYOUT`)."""
    if isinstance(desc, tuple | list):
        return type(desc)(_plain(x) for x in desc) if not isinstance(desc, list) else [_plain(x) for x in desc]
    return int(desc) if hasattr(desc, "value") and isinstance(desc.value, int) else desc


def is_our_layout(fielddefs: dict[str, Any]) -> bool:
    """Whether a typestore's definitions of GyroBatch, Header and Time are the ones decoded here."""
    try:
        return all(_plain(list(fielddefs[name][1])) == fields for name, fields in _LAYOUT.items())
    except (KeyError, TypeError, IndexError):
        return False


@dataclass(frozen=True)
class GyroColumns:
    """Decoded GyroBatch messages, one entry per message, in the order given.

    Attributes:
        trial_ids: The distinct trial ids.
        frame_ids: The distinct header frame ids.
        trial: Each message's trial (index into ``trial_ids``).
        frame: Each message's frame id (index into ``frame_ids``).
        stamp_ns: Each header stamp, ns since the epoch.
        first_index: Each batch's first sample index (uint64, as recorded).
        sample_rate_hz: Each batch's sample rate, Hz.
        rate_start: Where each batch's samples start in ``rates`` (one more entry: the end).
        rates: Every batch's samples, rad/s, one after the other (read-only).
        volts: Copies the raw volts out of the messages when first asked for (a replay
            never does): :attr:`volt_start` and :attr:`raw_volts`.
    """

    trial_ids: tuple[str, ...]
    frame_ids: tuple[str, ...]
    trial: IntArray
    frame: IntArray
    stamp_ns: IntArray
    first_index: NDArray[np.uint64]
    sample_rate_hz: FloatArray
    rate_start: IntArray
    rates: FloatArray
    volts: Callable[[], tuple[IntArray, FloatArray]]

    @cached_property
    def _volt_columns(self) -> tuple[IntArray, FloatArray]:
        return self.volts()

    @property
    def volt_start(self) -> IntArray:
        """Where each batch's raw volts start in :attr:`raw_volts` (one more entry: the end)."""
        return self._volt_columns[0]

    @property
    def raw_volts(self) -> FloatArray:
        """Every batch's raw volts, V, one after the other (read-only)."""
        return self._volt_columns[1]

    def __len__(self) -> int:
        """Number of batches."""
        return len(self.trial)

    def batches(self) -> list[SampleBatch]:
        """The batches as records (each array a view into ``rates``/``raw_volts``)."""
        rates = _split(self.rates, self.rate_start)
        volts = _split(self.raw_volts, self.volt_start)
        tids = [self.trial_ids[i] for i in self.trial.tolist()]
        fids = [self.frame_ids[i] for i in self.frame.tolist()]
        return list(
            map(SampleBatch, tids, self.first_index.tolist(), self.sample_rate_hz.tolist(), rates, volts,
                self.stamp_ns.tolist(), fids)
        )  # fmt: skip

    def blocks(self) -> list[tuple[str, SampleBlock]]:
        """Each trial's batches as one block, in the order of each trial's first batch."""
        order = np.argsort(self.trial, kind="stable")
        cuts = np.flatnonzero(np.diff(self.trial[order])) + 1
        first = self.first_index.astype(np.int64)
        out = []
        for rows in np.split(order, cuts) if len(order) else []:
            a, b = int(rows[0]), int(rows[-1])
            if b - a + 1 == len(rows):  # one after the other: views
                sel: slice | IntArray = slice(a, b + 1)
                rates, bounds = self.rates, self.rate_start[a : b + 2]
            else:
                sel = rows
                bounds, rates = _gather(self.rates, self.rate_start, rows)
            tid = self.trial_ids[int(self.trial[a])]
            block = SampleBlock(tid, first[sel], self.sample_rate_hz[sel], bounds, rates, partial(self._volts_of, rows),
                                self.stamp_ns[sel], self.frame_ids, self.frame[sel])  # fmt: skip
            out.append((a, tid, block))
        return [(tid, block) for _, tid, block in sorted(out, key=lambda x: x[0])]

    def _volts_of(self, rows: IntArray) -> tuple[IntArray, FloatArray]:
        """The raw volts of the batches ``rows`` (increasing): where each starts (then the end), and them."""
        a, b = int(rows[0]), int(rows[-1])
        if b - a + 1 == len(rows):
            return self.volt_start[a : b + 2], self.raw_volts
        return _gather(self.raw_volts, self.volt_start, rows)


def _gather(flat: FloatArray, start: IntArray, rows: IntArray) -> tuple[IntArray, FloatArray]:
    """Where each of some batches starts (then the end), and their samples one after the other."""
    parts = [flat[int(start[r]) : int(start[r + 1])] for r in rows.tolist()]
    bounds = np.zeros(len(rows) + 1, dtype=np.int64)
    np.cumsum([len(x) for x in parts], out=bounds[1:])
    out = np.concatenate(parts) if parts else flat[:0]
    out.flags.writeable = False
    return bounds, out


def _split(flat: FloatArray, start: IntArray) -> list[FloatArray]:
    """``flat[start[i]:start[i + 1]]`` for every i (runs of equal length split at once)."""
    n = np.diff(start)
    out: list[FloatArray] = []
    if not len(n):
        return out
    cut = np.flatnonzero(np.diff(n)) + 1
    for a, b in zip([0, *cut.tolist()], [*cut.tolist(), len(n)], strict=True):
        size = int(n[a])
        lo = int(start[a])
        if size == 0:
            out += [flat[lo:lo]] * (b - a)
        else:
            out += list(flat[lo : lo + size * (b - a)].reshape(b - a, size))
    return out


def _need(ok: Any, why: str) -> None:
    if not bool(np.all(ok)):
        raise Unusual(f"GyroBatch: {why}")


def _align(pos: IntArray, to: int) -> IntArray:
    return (pos + (to - 1)) & -to


@dataclass
class _Fields:
    """Every field's value, or where it is in the buffer, for each message."""

    stamp_ns: IntArray
    first: NDArray[np.uint64]
    rate: FloatArray
    frame_at: IntArray
    frame_len: IntArray
    trial_at: IntArray
    trial_len: IntArray
    n: IntArray
    rates_at: IntArray
    m: IntArray
    volts_at: IntArray


def _fields(buf: NDArray[np.uint8], start: IntArray, size: IntArray, max_sequence_length: int) -> _Fields:
    """Read and check the messages at ``buf[start:start + size]`` as rosbags' deserializer does."""
    _need((start >= 0) & (start + size <= len(buf)), "beyond its chunk")
    _need(size >= 4 + 12, "too short")
    _need((buf[start] == 0) & (buf[start + 1] == 1), "not little-endian CDR")
    p, plen = start + 4, size - 4
    frame_len = read_le(buf, "<u4", p + 8).astype(np.int64)
    _need((frame_len >= 1) & (12 + frame_len <= plen), "bad frame_id length")
    _need(buf[p + 11 + frame_len] == 0, "frame_id without terminator")
    q = _align(12 + frame_len, 4)
    _need(q + 4 <= plen, "truncated before trial_id")
    trial_len = read_le(buf, "<u4", p + q).astype(np.int64)
    _need((trial_len >= 1) & (q + 4 + trial_len <= plen), "bad trial_id length")
    _need(buf[p + q + 3 + trial_len] == 0, "trial_id without terminator")
    r = _align(q + 4 + trial_len, 8)
    _need(r + 20 <= plen, "truncated before rates")
    n = read_le(buf, "<u4", p + r + 16).astype(np.int64)
    _need((n <= max_sequence_length) & (r + 20 + 8 * n <= plen), "bad rates length")
    s = np.where(n > 0, r + 24, r + 20)
    _need(s + 8 * n <= plen, "rates beyond the message")
    t = s + 8 * n
    _need(t + 4 <= plen, "truncated before raw_volts")
    m = read_le(buf, "<u4", p + t).astype(np.int64)
    _need((m <= max_sequence_length) & (t + 4 + 8 * m <= plen), "bad raw_volts length")
    u = np.where(m > 0, _align(t + 4, 8), t + 4)
    _need(u + 8 * m <= plen, "raw_volts beyond the message")
    _need(plen - (u + 8 * m) <= 3, "bytes left over")
    first = read_le(buf, "<u8", p + r)
    _need(first < 2**63, "first_index beyond 2**63")
    sec = read_le(buf, "<i4", p).astype(np.int64)
    return _Fields(
        stamp_ns=sec * NS_PER_S + read_le(buf, "<u4", p + 4).astype(np.int64),
        first=first,
        rate=read_le(buf, "<f8", p + r + 8),
        frame_at=p + 12,
        frame_len=frame_len - 1,
        trial_at=p + q + 4,
        trial_len=trial_len - 1,
        n=n,
        rates_at=p + s,
        m=m,
        volts_at=p + u,
    )


class _Strings:
    """Distinct strings found so far, each with its index."""

    def __init__(self) -> None:
        self.found: dict[str, int] = {}

    def codes(self, buf: NDArray[np.uint8], at: IntArray, length: IntArray) -> IntArray:
        """The index of the UTF-8 string of ``length`` bytes at each ``at``.

        Only a string that differs from the one before it is decoded.
        """
        head = np.ones(len(at), dtype=bool)
        if len(at) > 1:
            same = length[1:] == length[:-1]
            width = int(length.max(initial=0))
            for w in range(0, width, 8):  # compare 8 bytes at a time, masked to each string's length
                valid = np.clip(length - w, 0, 8)
                mask = np.where(valid >= 8, np.uint64(2**64 - 1), (np.uint64(1) << (8 * valid).astype(np.uint64)) - 1)
                word = np.zeros(len(at), dtype=np.uint64)
                read = valid > 0
                word[read] = read_le(buf, "<u8", at[read] + w) if len(buf) >= 8 else 0
                word &= mask.astype(np.uint64)
                same &= word[1:] == word[:-1]
            head[1:] = ~same
        heads = np.flatnonzero(head)
        try:
            codes = [
                self.found.setdefault(buf[a : a + ln].tobytes().decode(), len(self.found))
                for a, ln in zip(at[heads].tolist(), length[heads].tolist(), strict=True)
            ]
        except UnicodeDecodeError:
            raise Unusual("GyroBatch: a string that is not UTF-8") from None
        return np.asarray(codes, dtype=np.int64)[np.cumsum(head) - 1]


#: Runs of linked batches at least this long are copied as strided blocks (one numpy call each).
_MIN_RUN = 8


def _copy_runs(
    buf: NDArray[np.uint8], at: IntArray, n: IntArray, link: NDArray[np.bool_]
) -> tuple[IntArray, FloatArray]:
    """Every message's ``n`` float64 at ``at``, one message after the other, in one array.

    Linked rows (same layout, each record right after the previous one) are one strided copy;
    rows in short runs (batches of varying sizes: each its own run) are gathered at once.
    """
    bounds = np.zeros(len(n) + 1, dtype=np.int64)
    np.cumsum(n, out=bounds[1:])
    out = np.empty(int(bounds[-1]), dtype=np.float64)
    heads = np.flatnonzero(~link)
    ends = np.append(heads[1:], len(n))
    busy = n[heads] > 0
    long = ends - heads >= _MIN_RUN
    rows = np.flatnonzero(~long[np.cumsum(~link) - 1] & (n > 0))  # the rows of the short runs
    if rows.size:  # every sample's byte offset, gathered in one indexing
        count = n[rows]
        shift = np.repeat(at[rows] - 8 * bounds[rows], count)  # sample g of its message is at shift + 8 g
        if int(count.sum()) == out.size:  # (no long run: every sample, in order)
            out[:] = read_le(buf, "<f8", shift + 8 * np.arange(out.size))
        else:
            g = np.arange(shift.size) + np.repeat(bounds[rows] - (np.cumsum(count) - count), count)
            out[g] = read_le(buf, "<f8", shift + 8 * g)
    busy &= long
    for a, b in zip(heads[busy].tolist(), ends[busy].tolist(), strict=True):
        size, k = int(n[a]), b - a
        stride = int(at[a + 1] - at[a]) if k > 1 else 8 * size
        src = np.ndarray(shape=(k, size), dtype="<f8", buffer=buf, offset=int(at[a]), strides=(stride, 8))
        out[int(bounds[a]) : int(bounds[b])].reshape(k, size)[...] = src
    out.flags.writeable = False
    return bounds, out


def decode_gyro(
    buf: NDArray[np.uint8], start: IntArray, size: IntArray, max_sequence_length: int = 2**32 - 1
) -> GyroColumns:
    """Decode the GyroBatch messages whose CDR bytes are ``buf[start[i]:start[i] + size[i]]``.

    Raises:
        Unusual: A message rosbags would read differently or reject.
    """
    f = _fields(buf, start, size, max_sequence_length)
    frames, trials = _Strings(), _Strings()
    frame = frames.codes(buf, f.frame_at, f.frame_len)
    trial = trials.codes(buf, f.trial_at, f.trial_len)
    # a batch continues a run when it has the previous one's layout and its record follows directly
    link = np.zeros(len(start), dtype=bool)
    if len(start) > 1:
        link[1:] = (size[1:] == size[:-1]) & (start[1:] - start[:-1] == size[:-1] + 31)
        link[1:] &= (f.n[1:] == f.n[:-1]) & (f.m[1:] == f.m[:-1])
        link[1:] &= f.rates_at[1:] - start[1:] == f.rates_at[:-1] - start[:-1]
        link[1:] &= f.volts_at[1:] - start[1:] == f.volts_at[:-1] - start[:-1]
    rate_start, rates = _copy_runs(buf, f.rates_at, f.n, link)
    return GyroColumns(
        trial_ids=tuple(trials.found),
        frame_ids=tuple(frames.found),
        trial=trial,
        frame=frame,
        stamp_ns=f.stamp_ns,
        first_index=f.first,
        sample_rate_hz=f.rate,
        rate_start=rate_start,
        rates=rates,
        volts=partial(_copy_runs, buf, f.volts_at, f.m, link),
    )
