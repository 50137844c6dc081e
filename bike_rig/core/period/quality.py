"""Quality tests of a fitted trial: clipping, held (gap-filled) samples, beating, drift.

Each test returns a :class:`~bike_rig.core.period.result.Flag` with a reason, or None. They
work on the samples of the fit window and their residuals (sample-level tests), or on per-cycle
sums (beating, drift).

* **Clipping** (ADC saturation): runs of at least 3 samples equal to the window's largest (or
  smallest) value, over which the fitted curve arches on beyond that value (from the run's
  edges to its middle) by more than 1.5 quantisation steps and the noise. A natural peak of a
  quantised signal also repeats its top value for a few samples, but there the curve stays
  within a step; an offset drift shifts the curve but does not make it arch.
* **Held samples** (a DAQ filling gaps by repeating the last value): runs of at least
  ``MIN_HELD_RUN`` equal samples, away from the extremes, over which the fitted curve moves by
  more than 4 × the noise and 1.5 quantisation steps.
* **Beating** (paper Fig. 7): a second mode close in frequency makes the envelope and the phase
  wander, smoothly from cycle to cycle. Per cycle, the residual is projected on the fitted
  oscillation: the cycle's complex amplitude deviation from Eq 23 (real part: envelope,
  imaginary part: phase). Its smooth part is measured twice — a cubic trend over the record
  (a beat longer than the record) and 3-cycle means (faster beats) — against the noise of the
  deviations, which their cycle-to-cycle differences give (a smooth modulation hardly changes
  them). Flagged when the smooth part is significant (cubic χ² above ``CHI2_LIMIT`` or a
  3-cycle mean above ``MA_LIMIT`` times its noise) and larger than ``max_modulation`` of the
  amplitude (default 2 %). Noise alone reaches about half the significance limit; a second
  mode of relative amplitude ρ makes a depth of about ρ. (The two-frequency fit of the paper's
  Eq 24 is not attempted: as the paper found, it cannot tell which mode is the torsion.)
* **Drift**: the per-cycle means of the residuals (the offset's slow wander, which Eq 23's
  constant A cannot follow), peak to peak, against the oscillation's peak to peak at the window
  centre.
"""

from __future__ import annotations

import math
from collections.abc import Callable
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
    "smallest_step",
    "steady_phase",
    "two_mode_flag",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Shortest run of equal samples considered as held (gap-filled).
MIN_HELD_RUN = 4
#: Pairs of consecutive samples used to estimate the noise and the quantum.
_PAIRS = 2048


def noise_and_quantum(y: FloatArray, residuals: FloatArray) -> tuple[float, float]:
    """Sample-to-sample noise of the residuals, and the smallest non-zero step of the samples.

    Returns:
        The noise ``std(diff(r)) / sqrt(2)`` (blind to slow drift and to model error) and the
        step (the ADC's quantum when the samples are quantised; 0 when all samples are equal),
        both from at most ``_PAIRS`` pairs of consecutive samples spread over the window (all
        pairs when none of those differ).
    """
    stride = max(1, (y.size - 1) // _PAIRS)
    dr = residuals[1::stride] - residuals[:-1:stride]
    dr -= np.mean(dr)
    noise = math.sqrt(float(np.einsum("i,i->", dr, dr)) / (2.0 * dr.size)) if dr.size > 1 else 0.0
    return noise, smallest_step(y, stride)


def smallest_step(y: FloatArray, stride: int = 1) -> float:
    """The smallest non-zero step between consecutive samples (the ADC's quantum when quantised; 0: none).

    With ``stride`` > 1 only every ``stride``-th pair is looked at (all pairs when none of those differ).
    """
    steps = np.abs(y[1::stride] - y[:-1:stride])
    steps = steps[steps > 0]
    if steps.size == 0 and stride > 1:
        steps = np.abs(np.diff(y))
        steps = steps[steps > 0]
    return float(np.min(steps)) if steps.size else 0.0


def _clip_tolerance(noise: float, quantum: float) -> float:
    """How much the fit may rise over a run of samples at the extreme value, edges to middle.

    An unclipped peak stays within one quantum of its top (noise only shortens the run).
    """
    return 1.5 * quantum + noise


def _held_tolerance(noise: float, quantum: float) -> float:
    """How far the fit may move during a run of equal samples without contradicting them."""
    return 4.0 * noise + 1.5 * quantum


def _run_bounds(positions: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """First and last element of each run of consecutive integers in sorted ``positions``."""
    ends = np.flatnonzero(positions[1:] - positions[:-1] > 1)
    firsts = np.empty(ends.size + 1, dtype=np.intp)
    firsts[0] = 0
    np.add(ends, 1, out=firsts[1:])
    lasts = np.append(ends, positions.size - 1)
    return positions[firsts], positions[lasts]


def clipping_flag(
    y: FloatArray,
    residuals: FloatArray,
    noise: float,
    quantum: float,
    extremes: tuple[float, float],
    units: tuple[float, float] = (1.0, 0.0),
) -> Flag | None:
    """Flag runs of samples stuck at the record's extreme values over which the fit arches on.

    Args:
        y: The samples.
        residuals: Their residuals from the fit.
        noise: See :func:`noise_and_quantum`.
        quantum: See :func:`noise_and_quantum`.
        extremes: The smallest and largest sample of the window.
        units: (scale, offset) converting ``y`` back to the samples' units, for the message.
    """
    tol = _clip_tolerance(noise, quantum)
    scale, offset = units
    messages = []
    for side, extreme, sign in (("maximum", extremes[1], 1.0), ("minimum", extremes[0], -1.0)):
        at = np.flatnonzero(y == extreme)
        if at.size < 3 or not np.any(at[2:] - at[:-2] == 2):
            continue  # the common case: no three consecutive samples at the extreme
        first, last = _run_bounds(at)
        long = last - first >= 2
        first, last = first[long], last[long]
        # the fitted curve y − r at the run's middle against its ends
        rise = sign * (0.5 * (residuals[first] + residuals[last]) - residuals[(first + last) // 2])
        clipped = rise > tol
        stuck = int(np.sum(last[clipped] - first[clipped])) + int(np.count_nonzero(clipped))
        if stuck >= 3:
            messages.append(
                f"{stuck} samples in {int(np.count_nonzero(clipped))} runs stuck at the {side} "
                f"{extreme * scale + offset:.6g} while the fit arches beyond it"
            )
    if not messages:
        return None
    return Flag(FlagCode.CLIPPED, "; ".join(messages) + ": the sensor or ADC saturated, use a smaller swing")


def held_flag(
    y: FloatArray,
    residuals: FloatArray,
    noise: float,
    quantum: float,
    extremes: tuple[float, float],
    time_of: Callable[[int], float],
) -> Flag | None:
    """Flag runs of repeated samples during which the fitted curve moves (held / gap-filled).

    ``extremes`` are the window's smallest and largest samples (runs there are the clipping
    test's business); ``time_of(i)`` the time of sample i, for the message.
    """
    same = y[1:] == y[:-1]
    three = same[:-2] & same[1:-1]
    three &= same[2:]  # sample i starts three equal steps (MIN_HELD_RUN = 4 equal samples)
    candidates = np.flatnonzero(three)
    if candidates.size == 0:
        return None  # the common case
    starts, last = _run_bounds(candidates)
    last += MIN_HELD_RUN - 1  # runs of samples [start, last]
    # the fitted curve y − r is y[start] − r inside a run: its moves are the residuals' moves
    r0 = residuals[starts]
    moves = np.maximum(np.abs(residuals[last] - r0), np.abs(residuals[(starts + last) // 2] - r0))
    level = y[starts]
    bad = np.flatnonzero((moves > _held_tolerance(noise, quantum)) & (level != extremes[0]) & (level != extremes[1]))
    if bad.size == 0:
        return None
    longest = bad[np.argmax(last[bad] - starts[bad])]
    a, b = int(starts[longest]), int(last[longest]) + 1
    return Flag(
        FlagCode.GAP_FILLED,
        f"{bad.size} runs of repeated samples while the signal moves (longest: {b - a} samples at "
        f"t = {time_of(a):.3f} s): samples were held or gap-filled, record again",
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
    step = deviation[1:] - deviation[:-1]
    noise2 = max(float(np.vdot(step, step).real) / (2.0 * (n - 1)), float(np.finfo(float).tiny))  # E|noise|²
    q = _cubic_basis(n)
    coef = deviation @ q
    chi2 = 2.0 * float(np.vdot(coef, coef).real) / noise2
    sum3 = deviation[:-2] + deviation[1:-1]
    sum3 += deviation[2:]
    mean3 = np.abs(sum3) / 3.0
    peak3 = float(np.max(mean3)) / math.sqrt(noise2 / 3.0)
    depth = max(float(np.max(np.abs(q @ coef) / amplitude)), float(np.max(mean3 / amplitude[1:-1])))
    return Modulation(depth, max(chi2 / CHI2_LIMIT, peak3 / MA_LIMIT))


def steady_phase(deviation: ComplexArray) -> ComplexArray:
    """The per-cycle deviations with a quadratic trend of their phase (imaginary) part taken out.

    A period that moves steadily along the record (a compound pendulum's finite swing shortens
    its period as the swing decays) makes the phase depart from Eq 23 smoothly and
    monotonically: a quadratic phase. Two close modes make envelope and phase wander together
    beyond that, which is what is left.
    """
    n = deviation.size
    if n < 6:
        return deviation
    q = _cubic_basis(n)[:, :3]  # (orthonormal, nested: its first 3 columns span degree ≤ 2)
    imag = deviation.imag - q @ (q.T @ deviation.imag)
    return np.asarray(deviation.real + 1j * imag, dtype=np.complex128)


def two_mode_flag(viscous: Modulation, model: Modulation, max_modulation: float) -> Flag | None:
    """Flag beating: a modulation beyond both Eq 23 and the damping model with a steady phase.

    Args:
        viscous: The beating statistics of Eq 23's fit (an envelope and a phase wandering
            from Eq 23).
        model: Those of the chosen damping model's fit, with the phase's quadratic trend taken
            out (:func:`steady_phase`): what a linear envelope (dry friction) or a steadily
            moving period (a finite swing) cannot explain.
        max_modulation: The relative depth above which a significant modulation is flagged.
    """
    if beating_flag(viscous, max_modulation) is None:
        return None
    return beating_flag(model, max_modulation)


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
