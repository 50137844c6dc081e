"""A free-decay segment's measured eigenvalue with σ, and segments at one speed combined.

Each segment is fitted with the trial fitter (:func:`bike_rig.core.period.fit.fit_period`,
Eq 23: offset + e^{−ζωt}(B sin ω_d t + C cos ω_d t)) on the whole segment (no lead-in, no
cut to whole cycles: a ride's segment is one to a few cycles): its validity, flags and
(α, ω_d). The fit is then refined with a linear trend added (model ``eq23_trend``,
:mod:`.realmode`: the capsize mode in the roll rate biases a short Eq 23 fit by several σ) or
with a real mode of free rate (``eq23_real``); ``eq23`` keeps the trial fitter's result. The
default ``auto`` fits both and keeps the real mode only where it lowers the residual sum of
squares significantly: an F test for one more parameter at :data:`AUTO_LEVEL` (a fast capsize
mode over a long segment), else the trend (a free μ over one or two cycles inflates the
spread of ω_d beyond its linearised σ).
The measured eigenvalue is

    λ = −ζω ± i ω_d,   ω_d = ω sqrt(1 − ζ²) = 2π / T   (Eq 25)

with σ(Re λ) the fitter's σ of ζω and σ(Im λ) = 2π σ_T / T² (the drift-robust sandwich with
two or more whole cycles, Eq 27 with a Student-t factor below). A segment with fewer than
:data:`MIN_SEGMENT_CYCLES` cycles has no eigenvalue, one with fewer than
:data:`FLAG_SEGMENT_CYCLES` is flagged (both ``too_few_cycles``); the fitter's flags (no
oscillation, poor fit, ...) are kept.

Segments at one speed combine as trials do (:mod:`bike_rig.core.period.combine`): the weighted
mean of the unflagged ones, σ widened by the Birge ratio when they scatter more than their σ.
Units: times s, eigenvalues 1/s, speeds m/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..period.combine import weighted_mean
from ..period.fit import fit_period
from ..period.oscillation import TWO_PI
from ..period.result import FlagCode, PeriodFit
from ..period.window import WindowPolicy
from .realmode import RealModeFit, RealModeFitFailed, fit_with_real_mode, search_frequency

__all__ = [
    "FLAG_SEGMENT_CYCLES",
    "MIN_SEGMENT_CYCLES",
    "MODELS",
    "CombinedEigenvalue",
    "MeasuredEigenvalue",
    "combine_eigenvalues",
    "eigenvalue_of_fit",
    "fit_segment",
]

#: The trial fitter's fewest cycles for a period (below, its spectrum's first guess is unreliable).
TRIAL_MIN_CYCLES = 1.0
#: A segment with fewer cycles has no eigenvalue (from the frequency search: simulated segments of
#: 0.8–1.0 cycles gave an eigenvalue in 78 of 80, ±σ covering 69 % and 65 % of the parts).
MIN_SEGMENT_CYCLES = 0.8
#: A segment with fewer cycles is flagged ``too_few_cycles`` (kept out of the means): measured on
#: simulated segments of 1.0–1.2 cycles, the spread of Im λ is 1.8 times its σ; from 1.2 cycles
#: on ±σ covers 60–75 % (test_calibration).
FLAG_SEGMENT_CYCLES = 1.2
#: The segment models: Eq 23 with a trend, with one real mode (:mod:`.realmode`), or alone (the trial fitter).
MODELS = ("auto", "eq23_trend", "eq23_real", "eq23")
#: ``auto`` keeps the real mode when the F test's p-value is below 1 − this (a conventional 10 % test:
#: over simulated 1.2–2 cycle segments of two bicycles it gave 66 % within ±1σ for both parts;
#: 0.99 left a fast capsize mode to the trend, 0.5 chose the real mode where it was not needed).
AUTO_LEVEL = 0.9
#: A fit with a lower r² is flagged ``poor_fit``.
MIN_R2 = 0.9
#: The trial fitter's flags of a segment too short for its spectrum (the frequency search then tries).
SHORT_CODES = frozenset({FlagCode.TOO_FEW_CYCLES, FlagCode.NO_OSCILLATION})
#: Longer segments are not searched (the trial fitter's spectrum resolves them; the search's cost
#: grows with the square of the length).
SEARCH_MAX_S = 5.0
#: A frequency with a larger relative σ is not determined (as the trial fitter's period).
MAX_RELATIVE_SIGMA = 0.05
#: Segments whose speeds differ by less than this are at one speed [m/s].
SPEED_TOLERANCE = 0.05


@dataclass(frozen=True)
class MeasuredEigenvalue:
    """One segment's measured eigenvalue.

    Attributes:
        source: The record's file or bag.
        index: The segment's number in its record (from 1).
        start: The segment's first time [s] on the record's axis.
        stop: Its last time [s].
        speed: The forward speed [m/s] (NaN if unknown).
        real: Re λ = −ζω [1/s].
        real_sigma: Its σ [1/s].
        imag: Im λ = ω_d > 0 [rad/s].
        imag_sigma: Its σ [rad/s].
        valid: Whether an eigenvalue was determined.
        flags: The fitter's flags (``code: reason``).
        n_cycles: Cycles in the segment.
        fit: The trial fitter's result.
        model: The model fitted (:data:`MODELS`; ``auto`` gives the one it chose).
        notes: How the eigenvalue was found when not by the trial fitter (a short segment).
    """

    source: str
    index: int
    start: float
    stop: float
    speed: float
    real: float
    real_sigma: float
    imag: float
    imag_sigma: float
    valid: bool
    flags: tuple[str, ...]
    n_cycles: float
    fit: PeriodFit
    model: str = "eq23"
    notes: tuple[str, ...] = ()

    @property
    def clean(self) -> bool:
        """Valid, with finite σ and no flags."""
        return self.valid and not self.flags and self.real_sigma > 0 and self.imag_sigma > 0


def eigenvalue_of_fit(fit: PeriodFit) -> tuple[float, float, float, float]:
    """(Re λ, σ, Im λ, σ) of Eq 23's fit: −ζω ± i 2π/T (Eq 25) [1/s]; NaN without a period."""
    if not fit.valid:
        return math.nan, math.nan, math.nan, math.nan
    imag = TWO_PI / fit.period
    return -fit.zeta * fit.omega, fit.alpha_sigma, imag, TWO_PI * fit.period_sigma / fit.period**2


def fit_segment(
    times: ArrayLike,
    signal: ArrayLike,
    *,
    speed: float = math.nan,
    source: str = "",
    index: int = 1,
    model: str = "auto",
) -> MeasuredEigenvalue:
    """The measured eigenvalue of one free-decay segment (module docstring).

    Args:
        times: Sample times [s] (increasing; jitter and gaps are fine).
        signal: The samples (roll rate, rad/s).
        speed: The forward speed [m/s].
        source: The record's name.
        index: The segment's number.
        model: ``auto`` (default), ``eq23_trend``, ``eq23_real`` or ``eq23`` (:data:`MODELS`).

    Raises:
        ValueError: An unknown model (a programming mistake; the CLI offers the choices).
    """
    if model not in MODELS:
        raise ValueError(f"unknown segment model {model!r}, expected one of {MODELS}")
    t = np.asarray(times, dtype=float)
    fit = fit_period(
        signal,
        times=t,
        window=WindowPolicy.lead_in(0.0, whole_cycles=False),
        min_cycles=FLAG_SEGMENT_CYCLES,
        min_valid_cycles=TRIAL_MIN_CYCLES,
    )
    real, real_sigma, imag, imag_sigma = eigenvalue_of_fit(fit)
    flags = tuple(str(f) for f in fit.flags)
    valid = fit.valid
    if model != "eq23" and fit.valid:
        explained = (FlagCode.POOR_FIT, FlagCode.DRIFT)  # what the real mode may account for
        kept = [str(f) for f in fit.flags if f.code not in explained]
        try:
            rm, model = _refine(t, np.asarray(signal, dtype=float), -real, imag, model)
            real, real_sigma, imag, imag_sigma = -rm.alpha, rm.alpha_sigma, rm.omega_d, rm.omega_d_sigma
            if not rm.r2 >= MIN_R2:
                kept.append(f"{FlagCode.POOR_FIT.value}: r² = {rm.r2:.3f} < {MIN_R2:g} ({model})")
        except RealModeFitFailed as exc:
            valid, real, real_sigma, imag, imag_sigma = False, math.nan, math.nan, math.nan, math.nan
            kept.append(f"{FlagCode.FIT_FAILED.value}: {exc}")
        flags = tuple(kept)
    n_cycles, notes = fit.n_cycles, tuple[str, ...]()
    if model != "eq23" and not fit.valid and {f.code for f in fit.flags} <= SHORT_CODES:
        short = _short_segment(t, np.asarray(signal, dtype=float), model, fit)
        if short is not None:
            (real, real_sigma, imag, imag_sigma, n_cycles), model, flags, notes = short
            valid = True
    return MeasuredEigenvalue(
        source=source,
        index=index,
        start=float(t[0]) if t.size else math.nan,
        stop=float(t[-1]) if t.size else math.nan,
        speed=float(speed),
        real=real,
        real_sigma=real_sigma,
        imag=imag,
        imag_sigma=imag_sigma,
        valid=valid,
        flags=flags,
        n_cycles=n_cycles,
        fit=fit,
        model=model,
        notes=notes,
    )


def _short_segment(
    t: NDArray[np.float64], y: NDArray[np.float64], model: str, fit: PeriodFit
) -> tuple[tuple[float, float, float, float, float], str, tuple[str, ...], tuple[str, ...]] | None:
    """A segment of about one cycle that the trial fitter's spectrum cannot resolve: the frequency search.

    Returns:
        ((Re λ, σ, Im λ, σ, cycles), model, flags, notes), or None when no oscillation stands out
        of the trend (:func:`~.realmode.search_frequency`), the segment is longer than
        :data:`SEARCH_MAX_S`, it spans fewer than
        :data:`MIN_SEGMENT_CYCLES` cycles or its frequency is not determined (σ above
        :data:`MAX_RELATIVE_SIGMA` of it).
    """
    if t.size < 8 or not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))) or t[-1] - t[0] > SEARCH_MAX_S:
        return None
    try:
        search = search_frequency(t, y)
        if not search.found:
            return None
        rm, model = _refine(t, y, 0.0, search.omega_d, model)
    except RealModeFitFailed:
        return None
    duration = float(t[-1] - t[0]) * t.size / max(1, t.size - 1)
    cycles = rm.omega_d * duration / TWO_PI
    if cycles < MIN_SEGMENT_CYCLES or not rm.omega_d_sigma < MAX_RELATIVE_SIGMA * rm.omega_d:
        return None
    flags = []
    if cycles < FLAG_SEGMENT_CYCLES:
        flags.append(f"{FlagCode.TOO_FEW_CYCLES.value}: {cycles:.2f} cycles, at least {FLAG_SEGMENT_CYCLES:g} wanted")
    if not rm.r2 >= MIN_R2:
        flags.append(f"{FlagCode.POOR_FIT.value}: r² = {rm.r2:.3f} < {MIN_R2:g} ({model})")
    why = "; ".join(str(f) for f in fit.flags)
    note = f"the trial fitter found no period ({why}); frequency search: false alarm {search.false_alarm:.1e}"
    eig = (-rm.alpha, rm.alpha_sigma, rm.omega_d, rm.omega_d_sigma, cycles)
    return eig, model, tuple(flags), (note,)


def _refine(t: NDArray[np.float64], y: NDArray[np.float64], alpha: float, omega_d: float, model: str) -> tuple[
    RealModeFit, str
]:
    """The refined fit and the model chosen (module docstring)."""
    if model != "auto":
        return fit_with_real_mode(t, y, alpha, omega_d, free_mu=model == "eq23_real"), model
    from scipy.stats import f as f_distribution

    trend = fit_with_real_mode(t, y, alpha, omega_d)
    try:
        real = fit_with_real_mode(t, y, trend.alpha, trend.omega_d, free_mu=True)
    except RealModeFitFailed:
        return trend, "eq23_trend"
    sse_trend, sse_real = t.size * trend.residual_rms**2, t.size * real.residual_rms**2
    dof = t.size - 7
    if sse_real > 0 and (sse_trend - sse_real) / (sse_real / dof) > f_distribution.ppf(AUTO_LEVEL, 1, dof):
        return real, "eq23_real"
    return trend, "eq23_trend"


@dataclass(frozen=True)
class CombinedEigenvalue:
    """The segments at one speed combined.

    Attributes:
        speed: Their mean speed [m/s].
        real: Weighted mean of Re λ [1/s].
        real_sigma: Its σ [1/s].
        imag: Weighted mean of Im λ [rad/s].
        imag_sigma: Its σ [rad/s].
        n_used: Clean segments in the mean.
        n_left_out: Flagged or invalid segments left out.
    """

    speed: float
    real: float
    real_sigma: float
    imag: float
    imag_sigma: float
    n_used: int
    n_left_out: int


def combine_eigenvalues(segments: Sequence[MeasuredEigenvalue]) -> list[CombinedEigenvalue]:
    """The clean segments grouped by speed (within :data:`SPEED_TOLERANCE`) and combined, by speed."""
    groups: list[list[MeasuredEigenvalue]] = []
    for seg in sorted((s for s in segments if math.isfinite(s.speed)), key=lambda s: s.speed):
        if groups and seg.speed - groups[-1][0].speed <= SPEED_TOLERANCE:
            groups[-1].append(seg)
        else:
            groups.append([seg])
    out = []
    for group in groups:
        used = [s for s in group if s.clean]
        if not used:
            nan = math.nan
            out.append(CombinedEigenvalue(float(np.mean([s.speed for s in group])), nan, nan, nan, nan, 0, len(group)))
            continue
        re, re_s, *_ = weighted_mean([s.real for s in used], [s.real_sigma for s in used])
        im, im_s, *_ = weighted_mean([s.imag for s in used], [s.imag_sigma for s in used])
        speed = float(np.mean([s.speed for s in used]))
        out.append(CombinedEigenvalue(speed, re, re_s, im, im_s, len(used), len(group) - len(used)))
    return out
