"""Stage 1 of the period fit (:mod:`~bike_rig.core.period.fit`): the samples and times it can use.

Non-finite samples (and samples with non-finite timestamps) are left out and flagged; given
timestamps must increase (gaps are noted). A record that ends holding one value for
:data:`HELD_TAIL_S` or more is cut where the hold begins: flagged ``gap_filled`` when the signal
was swinging just before (the sensor or its link stopped), noted when the swing had died into
the sensor's resolution. Stretches where the signal reads one value outside its swing (a
dropout: :mod:`.dropout`) are left out and flagged ``gap_filled``. Bad data never raise out of
the fit: they end in :class:`Invalid`, which the fit turns into a result with ``valid=False``
and its flags.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .dropout import dropout_duration, dropout_flag, find_dropouts
from .quality import smallest_step
from .result import Flag, FlagCode

__all__ = ["HELD_TAIL_S", "Invalid", "clean_samples"]

FloatArray = NDArray[np.float64]

#: A record's last samples holding one value this long [s] (and 8 samples or more) are cut.
HELD_TAIL_S = 1.0
#: A hold after a swing of more than this many of the sensor's steps (over HELD_TAIL_S) is a stall.
STALL_STEPS = 10


class Invalid(Exception):
    """The trial has no period; carries the flags that say why (the fit turns it into an invalid result)."""

    def __init__(self, *flags: Flag):
        """Keep the flags."""
        super().__init__()
        self.flags = flags


def _as_series(values: ArrayLike, what: str) -> FloatArray:
    """``values`` as a contiguous 1-D float64 array, or an invalid result saying why not."""
    try:
        array = np.asarray(values)
    except (TypeError, ValueError) as exc:  # ragged nested sequences
        raise Invalid(Flag(FlagCode.EMPTY, f"the {what} are not an array of numbers ({exc})")) from None
    if array.dtype.kind not in "biuf":
        raise Invalid(Flag(FlagCode.EMPTY, f"the {what} are not real numbers (dtype {array.dtype})"))
    array = np.squeeze(array)
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1:
        raise Invalid(Flag(FlagCode.EMPTY, f"the {what} must be one series, got shape {np.shape(values)}"))
    return np.ascontiguousarray(array, dtype=np.float64)


def clean_samples(
    samples: ArrayLike,
    rate: float | None,
    times: ArrayLike | None,
    flags: list[Flag],
    notes: list[str],
    dropped: list[tuple[Flag, float]] | None = None,
) -> tuple[FloatArray | None, FloatArray, NDArray[np.intp] | None, float | None, float]:
    """The samples the fit can use (finite, no dropout), their times and positions.

    ``dropped`` receives the dropouts' flag (also in ``flags``) with the time their last one
    ends [s, on the returned times' axis; inf at the record's end]: one that ends before the
    fit's window changes nothing the fit uses.

    Returns:
        The times [s] from the first finite sample (the first dropout-free one when a
        dropout starts the record, though: a lead-in counts from the record's start), or
        None with their even spacing [s] (given a rate and no sample left out but at the
        end); the samples kept; their positions in the input (None: all); the time of the
        first finite sample on the caller's axis [s].

    Raises:
        Invalid: No usable samples or times (``flags`` holds what was flagged before).
    """
    y = _as_series(samples, "samples")
    n = y.size
    if n == 0:
        raise Invalid(Flag(FlagCode.EMPTY, "no samples"))
    t: FloatArray | None = None
    if rate is None:
        assert times is not None
        t = _as_series(times, "timestamps")
        if t.size != n:
            raise Invalid(Flag(FlagCode.BAD_TIMES, f"{t.size} timestamps for {n} samples"))
    # (a finite sum means finite samples; only otherwise are they checked one by one)
    finite = None if math.isfinite(float(np.sum(y))) else np.isfinite(y)
    if t is not None:
        finite = np.isfinite(t) if finite is None else finite & np.isfinite(t)
    index = None
    if finite is not None and not np.all(finite):
        index, y, t = _leave_out(finite, y, t, rate, flags)
    if t is None:
        assert rate is not None
        even = 1.0 / rate
        if not math.isfinite(n * even):
            raise Invalid(Flag(FlagCode.BAD_TIMES, "the times span more than the floating-point range"))
        keep = _held_tail(y, None, even, flags, notes)
        return _leave_out_dropouts(None, y[:keep], None, even, 0.0, flags, dropped)
    t, t0 = _check_times(t, index, rate, notes)
    keep = _held_tail(y, t, None, flags, notes)
    return _leave_out_dropouts(t[:keep], y[:keep], None if index is None else index[:keep], None, t0, flags, dropped)


def _leave_out_dropouts(
    t: FloatArray | None,
    y: FloatArray,
    index: NDArray[np.intp] | None,
    even: float | None,
    t0: float,
    flags: list[Flag],
    dropped: list[tuple[Flag, float]] | None = None,
) -> tuple[FloatArray | None, FloatArray, NDArray[np.intp] | None, float | None, float]:
    """Leave out (and flag) the dropouts (:mod:`.dropout`); the arguments and result as :func:`clean_samples`'s."""
    dropouts, swing = find_dropouts(y, t, even)
    if not dropouts:
        return t, y, index, even, t0
    n = y.size
    keep = np.ones(n, dtype=bool)
    for d in dropouts:
        keep[d.start : d.stop] = False

    def time_of(i: int) -> float:
        return t0 + (float(t[i]) if t is not None else i * float(even or 0.0))

    total = n * float(even or 0.0) if t is None else float(t[-1] - t[0]) * n / max(1, n - 1)
    flag = dropout_flag(dropouts, swing, time_of, lambda d: dropout_duration(d, t, even, n), total)
    flags.append(flag)
    if dropped is not None:
        last = max(d.stop for d in dropouts)
        dropped.append((flag, time_of(last) - t0 if last < n else math.inf))
    kept = np.flatnonzero(keep)  # (never empty: the dropouts were judged against other samples)
    if t is None and kept[0] == 0 and kept[-1] == kept.size - 1:  # (only at the end: still evenly spaced)
        return None, y[: kept.size], None, even, t0
    # (the times keep their origin: a lead-in still counts from the record's start)
    new_t = np.asarray(kept * float(even or 0.0) if t is None else t[kept], dtype=np.float64)
    return new_t, y[kept], kept if index is None else index[kept], None, t0


def _held_tail(y: FloatArray, t: FloatArray | None, even: float | None, flags: list[Flag], notes: list[str]) -> int:
    """How many samples to keep: all but a final hold of one value over :data:`HELD_TAIL_S` (module docstring)."""
    n = y.size
    if n < 16 or y[-1] != y[-2]:
        return n  # the common case
    changes = np.flatnonzero(y[1:] != y[:-1])
    if changes.size == 0:
        return n  # constant throughout: the window's constant check says so
    first = int(changes[-1]) + 1  # the hold's first sample

    def time(i: int) -> float:
        return float(t[i]) if t is not None else i * float(even or 0.0)

    held = time(n - 1) - time(first)
    if n - first < 8 or held < HELD_TAIL_S or first < 8:
        return n
    since = time(first) - HELD_TAIL_S
    if t is not None:
        lead = int(np.searchsorted(t[:first], since))
    else:
        lead = max(0, math.ceil(since / float(even or 1.0)))
    before = y[lead:first]
    step = smallest_step(y[:first])
    swing = float(np.ptp(before)) if before.size else 0.0
    what = f"the last {n - first} samples ({held:.3g} s from t = {time(first):.3f} s) hold {y[first]:.6g}"
    if step > 0.0 and swing > STALL_STEPS * step:
        flags.append(
            Flag(
                FlagCode.GAP_FILLED,
                f"{what} right after a swing of {swing:.3g}: the sensor or its link stopped; "
                "the fit uses the samples before",
            )
        )
    else:
        notes.append(f"{what}: the swing had died into the sensor's resolution; the fit uses the samples before")
    return first


def _leave_out(
    finite: NDArray[np.bool_], y: FloatArray, t: FloatArray | None, rate: float | None, flags: list[Flag]
) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """Leave out (and flag) the non-finite samples: their positions, samples and times [s]."""
    n = y.size
    n_finite = int(np.count_nonzero(finite))
    if n_finite == 0:
        raise Invalid(Flag(FlagCode.NON_FINITE, f"all {n} samples (or their times) are NaN or infinite"))
    bad = np.flatnonzero(~finite)
    flags.append(
        Flag(
            FlagCode.NON_FINITE,
            f"{bad.size} of {n} samples are NaN/infinite (first at index {bad[0]}); they were left out",
        )
    )
    index = np.flatnonzero(finite)
    y = y[finite]
    if t is None:
        assert rate is not None
        t = index.astype(float) * (1.0 / rate)
    else:
        t = t[finite]
    return index, y, t


def _check_times(
    t: FloatArray, index: NDArray[np.intp] | None, rate: float | None, notes: list[str]
) -> tuple[FloatArray, float]:
    """Given times must increase (gaps are noted): them from the first one, and the first [s]."""
    if rate is None and t.size > 1:  # (given times: they must increase)
        dt = np.diff(t)
        if not np.all(dt > 0):
            first = int(np.flatnonzero(~(dt > 0))[0]) + 1
            where = first if index is None else int(index[first])
            raise Invalid(Flag(FlagCode.BAD_TIMES, f"the timestamps do not increase at sample {where}"))
        typical = float(np.median(dt))
        gaps = np.flatnonzero(dt > 3.0 * typical)
        if gaps.size:
            longest = float(np.max(dt[gaps]))
            notes.append(f"{gaps.size} gaps in the timestamps (longest {longest:.3g} s), fitted as they are")
    t0 = float(t[0])
    if t0 != 0.0:
        t = t - t[0]
    if not math.isfinite(float(t[-1])):
        raise Invalid(Flag(FlagCode.BAD_TIMES, "the times span more than the floating-point range"))
    return t, t0
