"""Dropouts: stretches where the signal reads one value outside its swing (a connector or link that dropped).

A gyro read through an ADC whose connector drops reads 0 V (or an ADC rail, or any value the
input floats to) for tens of ms to seconds. Those samples are not measurements of the
oscillation; the fit leaves them out as it leaves out other gaps. A stretch is a dropout when

* it is a run of at least :data:`MIN_RUN` samples within one step of its first value (the
  smallest step between consecutive samples: the ADC's), among the record's lowest or highest
  :data:`TAIL_FRACTION` of samples; and
* its level lies **far outside** the range of the other samples (beyond it by more than
  :data:`FAR_STEPS` steps and :data:`FAR_FRACTION` of its peak to peak): the oscillation never
  goes there, so any such run is a dropout; or it lies **at the edge** of that range (within
  :data:`EDGE_STEPS` steps, or beyond) and lasts longer than a period: no swing holds any
  value that long (a peak holds for a fraction of a period, a clipped one less than half),
  while the signal swings beside it (by :data:`LOCAL_SWING` of the range within a period
  before or after: a slow drift's staircase also holds its extreme values, but creeps on).

The range is that of the samples outside the candidate stretches (those at or beyond its edge
first widened over their neighbours within a step: a reading that toggles), less one sample
per stretch end at each side (a transition sample). The period of the edge rule is that of the highest
spectral peak of the other samples, when it stands out as the fit's initial guess must. A level
inside the range is never a dropout: a rate signal's zero crossing, or a swing that died into
the sensor's resolution, is not (a hold there is :func:`~.quality.held_flag`'s business).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .quality import smallest_step
from .result import Flag, FlagCode
from .spectrum import block_sums, block_times, peak_of_blocks, spectrum_block

__all__ = ["Dropout", "dropout_duration", "dropout_flag", "find_dropouts"]

FloatArray = NDArray[np.float64]

#: Fewest samples in a dropout.
MIN_RUN = 2
#: Candidates: runs among this share of the lowest (or highest) samples.
TAIL_FRACTION = 0.02
#: A level beyond the others' range by more than this many steps (and FAR_FRACTION) is far outside.
FAR_STEPS = 4.0
#: ... and by more than this fraction of their peak to peak.
FAR_FRACTION = 0.25
#: A level within this many steps of the others' range (or beyond) is at its edge.
EDGE_STEPS = 2.0
#: Runs of one level (within a step) this many samples apart or closer are one stretch.
JOIN_GAP = 8
#: Samples beside a stretch looked at in one go when widening it.
REACH = 32
#: About this many samples (every k-th) give the tails' bounds and the step.
SUBSAMPLE = 4096
#: A stretch at the edge is a dropout only beside a swing of this share of the others' range.
LOCAL_SWING = 0.25
#: Fewest samples outside the candidate stretches to judge them by.
MIN_REST = 16
#: Spectral prominence of the other samples' oscillation below which no level is judged at the
#: edge (the fit's initial guess needs as much).
MIN_PROMINENCE = 40.0
#: Dropouts listed by time in the flag's reason.
LISTED = 3


@dataclass(frozen=True)
class Dropout:
    """One dropout: samples ``start`` to ``stop`` (exclusive) of the series read ``level``.

    Attributes:
        start: First sample of the dropout.
        stop: One past its last sample.
        level: The value read (the run's first sample), in the samples' units.
    """

    start: int
    stop: int
    level: float


def find_dropouts(y: FloatArray, t: FloatArray | None, even: float | None) -> tuple[list[Dropout], tuple[float, float]]:
    """The dropouts of a series (module docstring), and the range of the other samples.

    Args:
        y: The finite samples.
        t: Their times [s], or None with ``even``.
        even: The even sample interval [s], or None with ``t``.

    Returns:
        The dropouts in time order (usually none) and the (low, high) range the levels were
        judged against (NaN when nothing was judged).
    """
    none: tuple[list[Dropout], tuple[float, float]] = ([], (math.nan, math.nan))
    found = _tail_runs(y)
    if found is None:
        return none  # the common case
    starts, stops, levels, step, top = found
    tol = step + 1e-12 * float(np.max(np.abs(levels)))  # (one step, whatever the rounding)
    for widened in (False, True):
        rest = _outside(y.size, starts, stops)
        others = y[rest]
        if others.size < MIN_REST:
            return none
        trim = min(2 * starts.size, others.size // 1000)  # (a transition sample at each end)
        ends = np.partition(others, (trim, others.size - 1 - trim))
        lo, hi = float(ends[trim]), float(ends[-1 - trim])
        if not hi > lo:
            return none
        beyond = np.maximum(lo - levels, levels - hi)
        near = beyond >= -1.5 * tol
        if widened or not np.any(near):
            break
        # (a reading that toggles by a step leaves samples of its own beside the runs: take them in)
        starts, stops, levels, top = _widen(y, starts, stops, levels, top, near, tol)
    dropout = beyond > max(FAR_STEPS * step, FAR_FRACTION * (hi - lo))
    edge = ~dropout & (beyond >= -EDGE_STEPS * step)
    if np.any(edge) and hi - lo > 2.0 * FAR_STEPS * step:
        # (natural peaks last less than the half cycles from one side's tail to the other's)
        crossings = (starts[1:] - stops[:-1])[top[1:] != top[:-1]]
        if crossings.size < 2 or np.max((stops - starts)[edge]) > np.median(crossings):
            times = np.asarray(np.flatnonzero(rest) * float(even or 0.0) if t is None else t[rest], dtype=np.float64)
            period = _period(others, times)
            for i in np.flatnonzero(edge & (_durations(starts, stops, t, even, y.size) > period)):
                dropout[i] = _swings_beside(y, t, even, int(starts[i]), int(stops[i]), period, LOCAL_SWING * (hi - lo))
    starts, stops, levels, _ = _widen(y, starts[dropout], stops[dropout], levels[dropout], top[dropout], None, tol)
    return [Dropout(int(a), int(b), float(v)) for a, b, v in zip(starts, stops, levels, strict=True)], (lo, hi)


def _tail_runs(y: FloatArray) -> tuple[NDArray[np.intp], NDArray[np.intp], FloatArray, float, NDArray[np.bool_]] | None:
    """Runs of :data:`MIN_RUN` equal samples or more among the lowest or highest (None: there are none).

    Returns:
        Their starts, stops (exclusive) and levels, runs of one level a few samples apart
        joined; the samples' step; whether each is among the highest.
    """
    n = y.size
    if n < MIN_REST:
        return None
    bounds = np.flatnonzero(y[1:] != y[:-1]) + 1  # (runs of equal samples: bounds[i] to bounds[i + 1])
    long = np.flatnonzero(np.diff(bounds) >= MIN_RUN)
    starts, stops = bounds[long], bounds[long + 1]
    if bounds.size == 0 or bounds[0] >= MIN_RUN:
        starts, stops = np.append(0, starts), np.append(bounds[:1] if bounds.size else n, stops)
    if bounds.size and n - bounds[-1] >= MIN_RUN:
        starts, stops = np.append(starts, bounds[-1]), np.append(stops, n)
    if starts.size == 0:
        return None  # unquantised samples
    levels = y[starts]
    stride = max(1, n // SUBSAMPLE)
    sub = y[::stride]
    k = int(TAIL_FRACTION * (sub.size - 1))
    low, high = np.partition(sub, (k, sub.size - 1 - k))[[k, sub.size - 1 - k]]
    top = levels >= high
    tails = (levels <= low) | top
    if not np.any(tails):
        return None
    starts, stops, levels, top = starts[tails], stops[tails], levels[tails], top[tails]
    step = smallest_step(y, stride)
    # runs of one level (within a step) a few samples apart are one stretch (a reading that toggles)
    join = (starts[1:] - stops[:-1] <= JOIN_GAP) & (np.abs(np.diff(levels)) <= step * (1.0 + 1e-9))
    first, last = np.append(True, ~join), np.append(~join, True)
    return starts[first], stops[last], levels[first], step, top[first]


def _outside(n: int, starts: NDArray[np.intp], stops: NDArray[np.intp]) -> NDArray[np.bool_]:
    """Which of ``n`` samples lie outside the (sorted, disjoint) stretches."""
    edges = np.empty(2 * starts.size + 2, dtype=np.intp)
    edges[0], edges[1:-1:2], edges[2:-1:2], edges[-1] = 0, starts, stops, n
    return np.repeat(np.resize(np.array([True, False]), edges.size - 1), np.diff(edges))


def _widen(
    y: FloatArray,
    starts: NDArray[np.intp],
    stops: NDArray[np.intp],
    levels: FloatArray,
    top: NDArray[np.bool_],
    which: NDArray[np.bool_] | None,
    tol: float,
) -> tuple[NDArray[np.intp], NDArray[np.intp], FloatArray, NDArray[np.bool_]]:
    """The stretches (``which``: those; None: all) widened over their neighbours within ``tol`` of their level.

    Stretches of one level (within ``tol``) that then meet become one; of other levels, the
    later one begins where the earlier ends.
    """
    if starts.size == 0:
        return starts, stops, levels, top
    chosen = np.flatnonzero(which) if which is not None else np.arange(starts.size)
    starts, stops = starts.copy(), stops.copy()
    starts[chosen] = _reach_all(y, starts[chosen], -1, levels[chosen], tol)
    stops[chosen] = _reach_all(y, stops[chosen] - 1, 1, levels[chosen], tol) + 1
    order = np.argsort(starts, kind="stable")
    starts, stops, levels, top = starts[order], stops[order], levels[order], top[order]
    meet = (starts[1:] <= np.maximum.accumulate(stops)[:-1]) & (np.abs(np.diff(levels)) <= tol)
    first = np.flatnonzero(np.append(True, ~meet))
    starts, stops, levels, top = starts[first], np.maximum.reduceat(stops, first), levels[first], top[first]
    starts = np.maximum(starts, np.append(0, np.maximum.accumulate(stops)[:-1]))  # (levels apart: no overlap)
    kept = stops > starts
    return starts[kept], stops[kept], levels[kept], top[kept]


def _reach_all(y: FloatArray, at: NDArray[np.intp], direction: int, levels: FloatArray, tol: float) -> NDArray[np.intp]:
    """:func:`_reach` from each of ``at`` at its level: the first :data:`REACH` samples at once, then one by one."""
    n = y.size
    steps = np.arange(1, REACH + 1) * direction
    look = at[:, None] + steps[None, :]
    inside = (look >= 0) & (look < n)
    away = ~inside | (np.abs(y[np.clip(look, 0, n - 1)] - levels[:, None]) > tol)
    reached = at + direction * np.argmax(away, axis=1)
    for i in np.flatnonzero(~np.any(away, axis=1)):  # (still within a step after REACH samples)
        reached[i] = _reach(y, int(at[i]), direction, float(levels[i]), tol)
    return reached


def _reach(y: FloatArray, i: int, direction: int, level: float, tol: float) -> int:
    """The last sample from ``i`` in ``direction`` (±1) before one farther than ``tol`` from ``level``."""
    n = y.size
    span = 64
    while True:
        lo, hi = (i + 1, min(n, i + 1 + span)) if direction > 0 else (max(0, i - span), i)
        part = y[lo:hi] if direction > 0 else y[lo:hi][::-1]
        if part.size == 0:
            return i
        away = np.flatnonzero(np.abs(part - level) > tol)
        if away.size:
            return i + direction * int(away[0])
        i += direction * part.size
        span *= 4


def dropout_duration(d: Dropout, t: FloatArray | None, even: float | None, n: int) -> float:
    """How long a dropout lasted [s]: from its first sample to the next good one (of ``n`` samples)."""
    return float(_durations(np.array([d.start]), np.array([d.stop]), t, even, n)[0])


def _durations(
    starts: NDArray[np.intp], stops: NDArray[np.intp], t: FloatArray | None, even: float | None, n: int
) -> FloatArray:
    """How long stretches last [s]: from their first sample to the next one (of ``n`` samples)."""
    if t is None:
        return np.asarray((stops - starts) * float(even or 0.0), dtype=np.float64)
    ends = np.append(t, t[-1] + float(t[-1] - t[0]) / max(1, n - 1))
    return np.asarray(ends[stops] - t[starts], dtype=np.float64)


def _swings_beside(
    y: FloatArray, t: FloatArray | None, even: float | None, a: int, b: int, period: float, swing: float
) -> bool:
    """Whether the samples within a ``period`` [s] before ``a`` or after ``b`` (exclusive) swing by ``swing``."""
    if t is None:
        w = math.ceil(period / float(even or 1.0))
        before, after = y[max(0, a - w) : a], y[b : b + w]
    else:
        before = y[int(np.searchsorted(t, t[a] - period)) : a]
        after = y[b : int(np.searchsorted(t, t[b - 1] + period, side="right"))]
    return any(side.size > 1 and float(np.ptp(side)) >= swing for side in (before, after))


def _period(y: FloatArray, t: FloatArray) -> float:
    """The period [s] of the spectrum's highest peak of samples ``y`` at times ``t`` (∞: no clear peak)."""
    duration = float(t[-1] - t[0])
    if not duration > 0.0:
        return math.inf
    k = spectrum_block(y.size, duration / (y.size - 1))
    sums, sizes = block_sums(y, k)
    peak = peak_of_blocks(block_times(t, k, sizes), sums / sizes, duration)
    if peak is None or not peak.prominence >= MIN_PROMINENCE:
        return math.inf
    return 2.0 * math.pi / peak.omega


def dropout_flag(
    dropouts: list[Dropout],
    swing: tuple[float, float],
    time_of: Callable[[int], float],
    duration: Callable[[Dropout], float],
    total: float,
) -> Flag:
    """The ``gap_filled`` flag that says where the signal dropped out, and for how long.

    Args:
        dropouts: The dropouts (at least one).
        swing: The range of the other samples.
        time_of: Time of a sample on the caller's axis [s].
        duration: How long a dropout lasted [s].
        total: The record's length [s].
    """
    parts = [f"{d.level:.6g} from {time_of(d.start):.3f} s to {time_of(d.start) + duration(d):.3f} s" for d in dropouts]
    swing_text = f"outside its swing {swing[0]:.6g} to {swing[1]:.6g}"
    samples = sum(d.stop - d.start for d in dropouts)
    if len(dropouts) == 1:
        what = f"the signal read {parts[0]} ({duration(dropouts[0]):.3g} s, {samples} samples), {swing_text}: a dropout"
    else:
        listed = "; ".join(parts[:LISTED]) + (f"; and {len(parts) - LISTED} more" if len(parts) > LISTED else "")
        lost = sum(duration(d) for d in dropouts)
        what = (
            f"the signal dropped out {len(dropouts)} times ({lost:.3g} s of {total:.3g} s, {samples} samples), "
            f"{swing_text}: it read {listed}; dropouts"
        )
    return Flag(FlagCode.GAP_FILLED, f"{what}, left out (not measurements of the swing)")
