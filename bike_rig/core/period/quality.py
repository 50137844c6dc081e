"""Quality tests of a fitted trial: clipping, held (gap-filled) samples, beating, drift.

Each test returns a :class:`~bike_rig.core.period.result.Flag` with a reason, or None. All work
on the samples of the fit window, scaled to about ±1, their fitted values and residuals.

* **Clipping** (ADC saturation): runs of at least 3 samples equal to the window's largest (or
  smallest) value, over which the fitted curve arches on beyond that value (from the run's
  edges to its middle) by more than 1.5 quantisation steps and the noise. A natural peak of a
  quantised signal also repeats its top value for a few samples, but there the curve stays
  within a step; an offset drift shifts the curve but does not make it arch.
* **Held samples** (a DAQ filling gaps by repeating the last value): runs of at least
  ``MIN_HELD_RUN`` equal samples, away from the extremes, over which the fitted curve moves by
  more than the noise and quantisation allow.
* **Beating** (paper Fig. 7): a second mode close in frequency makes the envelope and the
  phase wander. Per cycle b, the residual is projected on the fitted oscillation, which gives
  the cycle's relative complex amplitude deviation δ_b from Eq 23 (real part: envelope, imaginary
  part: phase). The statistic is the largest 3-cycle moving average of |δ_b|; noise makes it
  ~ noise / (amplitude sqrt(samples per cycle)), a second mode of relative amplitude ρ makes it
  ~ ρ. Flagged when it exceeds ``max_modulation`` and five times its noise level (estimated
  from the cycle-to-cycle differences of δ, which a smooth modulation hardly changes).
* **Drift**: the per-cycle means of the residuals (the offset's slow wander, which Eq 23's
  constant A cannot follow), peak to peak, against the oscillation's peak to peak at the window
  centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from .result import Flag, FlagCode

__all__ = [
    "MIN_HELD_RUN",
    "Modulation",
    "beating_flag",
    "clipping_flag",
    "drift_flag",
    "held_flag",
    "modulation_index",
    "noise_and_quantum",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Shortest run of equal samples considered as held (gap-filled).
MIN_HELD_RUN = 4
#: Pairs of consecutive samples used to estimate the noise and the quantum.
_PAIRS = 8192


def noise_and_quantum(y: FloatArray, residuals: FloatArray) -> tuple[float, float]:
    """Sample-to-sample noise of the residuals, and the smallest non-zero step of ``y``.

    The noise is ``std(diff(r)) / sqrt(2)`` (blind to slow drift and to model error), from at
    most ``_PAIRS`` pairs of consecutive samples spread over the window; the step is the ADC's
    quantum when the samples are quantised (0 when all samples are equal).
    """
    d = np.abs(np.diff(y))
    quantum = float(np.min(d, where=d > 0, initial=np.inf)) if d.size else math.inf
    stride = max(1, (y.size - 1) // _PAIRS)
    dr = residuals[1::stride] - residuals[:-1:stride]
    noise = float(np.std(dr)) / np.sqrt(2.0) if dr.size > 1 else 0.0
    return noise, (quantum if math.isfinite(quantum) else 0.0)


def _clip_tolerance(noise: float, quantum: float) -> float:
    """How much the fit may rise over a run of samples at the extreme value, edges to middle:
    an unclipped peak stays within one quantum of its top (noise only shortens the run)."""
    return 1.5 * quantum + noise


def _held_tolerance(noise: float, quantum: float) -> float:
    """How far the fit may move during a run of equal samples without contradicting them."""
    return 4.0 * noise + 1.5 * quantum


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Starts and stops (exclusive) of the runs of True in ``mask``."""
    if mask.size == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    bounds = np.concatenate(([0], np.flatnonzero(mask[1:] != mask[:-1]) + 1, [mask.size]))
    segments = bounds.size - 1  # alternating runs of True and False, starting with mask[0]
    first = 0 if mask[0] else 1
    return bounds[first:segments:2], bounds[first + 1 : segments + 1 : 2]


def clipping_flag(
    y: FloatArray, fitted: FloatArray, noise: float, quantum: float, scale: float, offset: float
) -> Flag | None:
    """Flag runs of samples stuck at the window's extreme values over which the fit arches on.

    ``scale`` and ``offset`` convert ``y`` back to the samples' units for the message.
    """
    tol = _clip_tolerance(noise, quantum)
    messages = []
    for side, extreme, sign in (("maximum", float(np.max(y)), 1.0), ("minimum", float(np.min(y)), -1.0)):
        at = np.flatnonzero(y == extreme)
        if at.size < 3:
            continue
        breaks = np.flatnonzero(np.diff(at) > 1)
        first = at[np.concatenate(([0], breaks + 1))]
        last = at[np.concatenate((breaks, [at.size - 1]))]
        long = last - first >= 2
        first, last = first[long], last[long]
        rise = sign * (fitted[(first + last) // 2] - 0.5 * (fitted[first] + fitted[last]))
        clipped = rise > tol
        stuck = int(np.sum(last[clipped] - first[clipped] + 1))
        if stuck >= 3:
            messages.append(
                f"{stuck} samples in {int(np.count_nonzero(clipped))} runs stuck at the {side} "
                f"{extreme * scale + offset:.6g} while the fit arches beyond it"
            )
    if not messages:
        return None
    return Flag(FlagCode.CLIPPED, "; ".join(messages) + ": the sensor or ADC saturated, use a smaller swing")


def held_flag(y: FloatArray, fitted: FloatArray, noise: float, quantum: float, times: FloatArray) -> Flag | None:
    """Flag runs of repeated samples during which the fitted curve moves (held / gap-filled)."""
    same = np.diff(y) == 0
    starts, stops = _runs(same)
    long = stops - starts >= MIN_HELD_RUN - 1
    if not np.any(long):
        return None
    starts, last = starts[long], stops[long]  # runs of samples [start, last]
    middle = (starts + last) // 2
    moves = np.maximum(np.abs(fitted[last] - fitted[starts]), np.abs(fitted[middle] - fitted[starts]))
    at_extreme = (y[starts] == np.max(y)) | (y[starts] == np.min(y))  # the clipping test's business
    bad = np.flatnonzero((moves > _held_tolerance(noise, quantum)) & ~at_extreme)
    if bad.size == 0:
        return None
    longest = bad[np.argmax(last[bad] - starts[bad])]
    a, b = int(starts[longest]), int(last[longest]) + 1
    return Flag(
        FlagCode.GAP_FILLED,
        f"{bad.size} runs of repeated samples while the signal moves (longest: {b - a} samples at "
        f"t = {times[a]:.3f} s): samples were held or gap-filled, record again",
    )


@dataclass(frozen=True)
class Modulation:
    """The beating statistics of a fit.

    Attributes:
        depth: Largest smooth deviation of a cycle's complex amplitude from Eq 23, relative to
            that cycle's amplitude [-].
        significance: How far the smooth deviation stands out of the cycle-to-cycle noise:
            the larger of the cubic trend's χ² (2 Σ|c_j|² / noise², ~χ²₈ for noise) divided by
            ``CHI2_LIMIT`` and the largest 3-cycle mean over its noise divided by ``MA_LIMIT``;
            above 1 is significant [-].
    """

    depth: float
    significance: float


#: χ² of the cubic trend of the per-cycle deviations above which it is significant (χ²₈:
#: probability 2e-4 for noise).
CHI2_LIMIT = 30.0
#: Largest 3-cycle mean of the per-cycle deviations, in units of its noise, that noise reaches.
MA_LIMIT = 5.0


@lru_cache(maxsize=64)
def _cubic_basis(n: int) -> FloatArray:
    """Orthonormal basis of the polynomials of degree ≤ 3 on n evenly spaced points (n ≥ 6)."""
    q, _ = np.linalg.qr(np.polynomial.legendre.legvander(np.linspace(-1.0, 1.0, n), 3))
    return q


def modulation_index(deviation: ComplexArray, amplitude: FloatArray) -> Modulation:
    """Beating statistics of the per-cycle complex amplitude deviations from Eq 23.

    Args:
        deviation: Per cycle, the residual's complex amplitude at the fitted frequency
            (least-squares projection on the cycle), in the samples' units.
        amplitude: Per cycle, the fitted oscillation's amplitude, same units.

    Returns:
        The depth and significance of the smooth part of ``deviation`` (NaN with fewer than
        6 cycles). The noise is measured by the cycle-to-cycle differences, which a smooth
        modulation hardly changes.
    """
    n = deviation.size
    if n < 6:
        return Modulation(math.nan, math.nan)
    noise2 = float(np.mean(np.abs(np.diff(deviation)) ** 2)) / 2.0  # E|noise|² per cycle
    if not noise2 > 0:
        noise2 = float(np.finfo(float).tiny)
    q = _cubic_basis(n)
    coef = q.T @ deviation
    trend = q @ coef
    chi2 = 2.0 * float(np.sum(np.abs(coef) ** 2)) / noise2
    mean3 = (deviation[:-2] + deviation[1:-1] + deviation[2:]) / 3.0
    peak3 = float(np.max(np.abs(mean3))) / math.sqrt(noise2 / 3.0)
    depth = max(float(np.max(np.abs(trend) / amplitude)), float(np.max(np.abs(mean3) / amplitude[1:-1])))
    return Modulation(depth, max(chi2 / CHI2_LIMIT, peak3 / MA_LIMIT))


def beating_flag(modulation: Modulation, max_modulation: float) -> Flag | None:
    """Flag a significant envelope/phase modulation (a second mode, paper Fig. 7)."""
    if not (modulation.depth > max_modulation and modulation.significance > 1.0):
        return None
    return Flag(
        FlagCode.BEATING,
        f"the envelope/phase wanders by up to {100 * modulation.depth:.0f} % of the amplitude from Eq 23 "
        f"(limit {100 * max_modulation:g} %): two close modes (swinging with the torsion?); "
        "steady the part and record again",
    )


def drift_flag(drift: float, max_drift: float) -> Flag | None:
    """Flag a slow offset drift that is large against the oscillation."""
    if not np.isfinite(drift) or drift <= max_drift:
        return None
    return Flag(
        FlagCode.DRIFT,
        f"the offset drifts by {100 * drift:.0f} % of the oscillation's peak to peak (limit "
        f"{100 * max_drift:g} %): let the gyro warm up or swing wider",
    )
