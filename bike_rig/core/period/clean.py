"""Stage 1 of the period fit (:mod:`~bike_rig.core.period.fit`): the samples and times it can use.

Non-finite samples (and samples with non-finite timestamps) are left out and flagged; given
timestamps must increase (gaps are noted). Bad data never raise out of the fit: they end in
:class:`Invalid`, which the fit turns into a result with ``valid=False`` and its flags.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .result import Flag, FlagCode

__all__ = ["Invalid", "clean_samples"]

FloatArray = NDArray[np.float64]


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
    samples: ArrayLike, rate: float | None, times: ArrayLike | None, flags: list[Flag], notes: list[str]
) -> tuple[FloatArray | None, FloatArray, NDArray[np.intp] | None, float | None, float]:
    """The finite samples, their times and positions.

    Returns:
        The times from the first finite sample [s], or None with their even spacing [s]
        (given a rate and no sample left out); the finite samples; their positions in the
        input (None: all); the time of the first finite sample on the caller's axis [s].

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
        return None, y, None, even, 0.0
    t, t0 = _check_times(t, index, rate, notes)
    return t, y, index, None, t0


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
