"""A free-decay segment's measured eigenvalue with σ, and segments at one speed combined.

Each segment goes through the trial fitter (:func:`bike_rig.core.period.fit.fit_period`,
Eq 23: offset + e^{−ζωt}(B sin ω_d t + C cos ω_d t), on the whole segment: no lead-in, no cut
to whole cycles): its validity, flags, cycle count and starting (α, ω_d); a segment that its
spectrum cannot resolve (about one cycle, or a fast decay that falls into the noise within the
segment) gets its start from a search over frequency and decay instead.
The eigenvalue is then fitted with :mod:`.choice` (Eq 23, or with a real mode, ``auto``; or the
model forced), with σ from the noise model of :mod:`.noise` (white sensor noise plus the weave
driven by the rider's steering), widened by the models' disagreement. The measured eigenvalue
is ``λ = −ζω ± i ω_d`` (Eq 25).

The cycle count that flags a segment comes from a frequency that does not depend on the model
judged: the trial fitter's ω_d, or the frequency search's. A segment with fewer than
:data:`MIN_SEGMENT_CYCLES` cycles has no eigenvalue, one with fewer than
:data:`FLAG_SEGMENT_CYCLES` is flagged (both ``too_few_cycles``); one whose half-cycle amplitudes do
not follow one exponential envelope is flagged ``not_free_decay`` (:mod:`.envelope`), as is one
whose fitted ω_d strays from that frequency beyond :data:`MAX_FREQUENCY_RATIO` or holds fewer than
:data:`MIN_SEGMENT_CYCLES` of its own cycles (a record of a bicycle falling over, its motor
saturated, fits as a fast growth with a slow "oscillation" and a tiny σ); the
fitter's flags (no oscillation, ...) are kept. :func:`pool_drive` lets the segments at one speed
share the rider's drive (raised where they scatter beyond their σ, when the record's segments
over all its speeds, or these alone, do so beyond chance), and recomputes their σ with it.

Segments at one speed combine as trials do (:mod:`bike_rig.core.period.combine`): the weighted
mean of the unflagged ones, σ widened by the Birge ratio when they scatter more than their σ.
Units: times s, eigenvalues 1/s, speeds m/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..period.combine import weighted_mean
from ..period.fit import fit_period
from ..period.oscillation import TWO_PI
from ..period.result import FlagCode, PeriodFit
from ..period.window import WindowPolicy
from .choice import ModelChoice, choose_model
from .envelope import envelope_problem
from .noise import pooled_drive, scatter_chi2, scatter_drive, scatter_significant
from .realmode import RealModeFitFailed, search_frequency
from .segment import noise_sigma

__all__ = [
    "FLAG_SEGMENT_CYCLES",
    "MIN_SEGMENT_CYCLES",
    "MODELS",
    "CombinedEigenvalue",
    "MeasuredEigenvalue",
    "combine_eigenvalues",
    "eigenvalue_of_fit",
    "fit_segment",
    "pool_drive",
    "speed_groups",
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
#: The segment models: chosen (:mod:`.choice`), Eq 23 with a trend, with one real mode, or alone (:mod:`.realmode`).
MODELS = ("auto", "eq23_trend", "eq23_real", "eq23")
#: A fit with a lower r² is flagged ``poor_fit``.
MIN_R2 = 0.9
#: The trial fitter's flags of a segment too short for its spectrum (the frequency search then tries).
SHORT_CODES = frozenset({FlagCode.TOO_FEW_CYCLES, FlagCode.NO_OSCILLATION})
#: Longer segments are not searched (the trial fitter's spectrum resolves them; the search's cost
#: grows with the square of the length).
SEARCH_MAX_S = 5.0
#: A frequency with a larger relative σ is not determined. Loose on purpose: a segment's own σ
#: grows with its fitted decay rate, so a tight bound keeps the draws that decay slowly (on
#: simulated raw logs with a rider, 1.2–2.5 cycles from the push's end, a bound of 5 % left out
#: 16 of 48 segments at 3.3 m/s and 36 of 48 at 1.7 m/s, the fastest decays, and moved the
#: speed's mean Re λ by +0.07 to +0.14 1/s; the trial fitter's path has no such bound) [-].
MAX_RELATIVE_SIGMA = 0.15
#: The fitted ω_d must lie within this factor of the frequency that counts the cycles (on
#: simulated rides with a rider, saturation and 0.9–2.6 cycles, 99 % of the clean segments lie
#: within 0.63–1.31; beyond, a record of a bicycle falling over with its motor saturated) [-].
MAX_FREQUENCY_RATIO = 1.5
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
        variance: ``(Re fixed, Re per unit drive, Im fixed, Im per unit drive)`` [1/s², per
            signal units² s⁻¹]: the σ² at any drive q (:mod:`.noise`; empty: not recomputable).
        drive: This segment's estimate q̂ of the rider's drive (:mod:`.noise`; NaN: none).
        drive_sigma: Its σ.
        drive_used: The drive the σ are computed with (its own, or shared at its speed).
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
    variance: tuple[float, ...] = ()
    drive: float = math.nan
    drive_sigma: float = math.nan
    drive_used: float = math.nan

    @property
    def clean(self) -> bool:
        """Valid, with finite σ and no flags."""
        return self.valid and not self.flags and self.real_sigma > 0 and self.imag_sigma > 0

    def with_drive(self, q: float) -> MeasuredEigenvalue:
        """The same eigenvalue with its σ at the drive ``q`` (itself where they cannot be recomputed)."""
        if len(self.variance) != 4 or not self.valid or not math.isfinite(q):
            return self
        v = self.variance
        return replace(
            self,
            real_sigma=math.sqrt(max(0.0, v[0] + q * v[1])),
            imag_sigma=math.sqrt(max(0.0, v[2] + q * v[3])),
            drive_used=q,
        )


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
    y = np.asarray(signal, dtype=float)
    fit = fit_period(
        y,
        times=t,
        window=WindowPolicy.lead_in(0.0, whole_cycles=False),
        min_cycles=FLAG_SEGMENT_CYCLES,
        min_valid_cycles=TRIAL_MIN_CYCLES,
    )
    real, real_sigma, imag, imag_sigma = eigenvalue_of_fit(fit)
    flags = [str(f) for f in fit.flags]
    valid, chosen, n_cycles, notes = fit.valid, None, fit.n_cycles, list[str]()
    independent = imag  # the frequency that counts the cycles, whatever model is reported
    white = noise_sigma(y) if np.all(np.isfinite(y)) else math.nan
    if fit.valid:
        explained = (FlagCode.POOR_FIT, FlagCode.DRIFT)  # what the trend or real mode may account for
        flags = [str(f) for f in fit.flags if f.code not in explained]
        try:
            chosen = choose_model(t, y, -real, imag, model, white)
        except RealModeFitFailed as exc:
            valid, real, real_sigma, imag, imag_sigma = False, math.nan, math.nan, math.nan, math.nan
            flags.append(f"{FlagCode.FIT_FAILED.value}: {exc}")
    elif {f.code for f in fit.flags} <= SHORT_CODES:
        short = _short_segment(t, y, model, fit, white)
        if short is not None:
            chosen, n_cycles, flags, notes, independent = short
            valid = True
    variance: tuple[float, ...] = ()
    drive = drive_sigma = drive_used = math.nan
    if chosen is not None:
        real, real_sigma, imag, imag_sigma = chosen.real, chosen.real_sigma, chosen.imag, chosen.imag_sigma
        variance, drive, drive_sigma = chosen.variance, chosen.drive, chosen.drive_sigma
        drive_used = pooled_drive([(drive, drive_sigma)])
        model, notes = chosen.fit.model, notes + list(chosen.notes)
        if not chosen.fit.r2 >= MIN_R2:
            flags.append(f"{FlagCode.POOR_FIT.value}: r² = {chosen.fit.r2:.3f} < {MIN_R2:g} ({model})")
        problem = envelope_problem(t, y - chosen.fit.baseline(t), imag, real, real_sigma, white)
        if problem is not None:
            flags.append(problem)
        stray = _frequency_problem(imag, independent, n_cycles)
        if stray is not None:
            flags.append(stray)
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
        flags=tuple(flags),
        n_cycles=n_cycles,
        fit=fit,
        model=model,
        notes=tuple(notes),
        variance=variance,
        drive=drive,
        drive_sigma=drive_sigma,
        drive_used=drive_used,
    )


def _frequency_problem(imag: float, independent: float, n_cycles: float) -> str | None:
    """Why the fitted ω_d [rad/s] is not the record's oscillation (at ``independent`` rad/s, ``n_cycles``), or None."""
    if not (imag > 0 and independent > 0 and n_cycles > 0):
        return None
    own = n_cycles * imag / independent
    ratio = imag / independent
    if own < MIN_SEGMENT_CYCLES or not 1.0 / MAX_FREQUENCY_RATIO <= ratio <= MAX_FREQUENCY_RATIO:
        return (
            f"not_free_decay: the fitted ω_d {imag:.3g} rad/s ({own:.2f} cycles) is not the "
            f"record's oscillation ({independent:.3g} rad/s, {n_cycles:.2f} cycles): no weave decays freely here"
        )
    return None


def _short_segment(
    t: NDArray[np.float64], y: NDArray[np.float64], model: str, fit: PeriodFit, white: float
) -> tuple[ModelChoice, float, list[str], list[str], float] | None:
    """A segment of about one cycle that the trial fitter's spectrum cannot resolve: the frequency search.

    The cycles are counted with the search's frequency, not the fitted model's (a refinement
    that inflates ω_d must not lift a segment over :data:`FLAG_SEGMENT_CYCLES`).

    Returns:
        (the fit, cycles, flags, notes, the search's ω_d [rad/s]), or None when no oscillation stands out of the trend
        (:func:`~.realmode.search_frequency`), the segment is longer than
        :data:`SEARCH_MAX_S`, it spans fewer than :data:`MIN_SEGMENT_CYCLES` cycles or its
        frequency is not determined (σ above :data:`MAX_RELATIVE_SIGMA` of it).
    """
    if t.size < 8 or not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))) or t[-1] - t[0] > SEARCH_MAX_S:
        return None
    try:
        search = search_frequency(t, y)
        if not search.found:
            return None
        chosen = choose_model(t, y, search.alpha, search.omega_d, model, white)
    except RealModeFitFailed:
        return None
    duration = float(t[-1] - t[0]) * t.size / max(1, t.size - 1)
    cycles = search.omega_d * duration / TWO_PI
    if cycles < MIN_SEGMENT_CYCLES or not chosen.imag_sigma < MAX_RELATIVE_SIGMA * chosen.imag:
        return None
    flags = []
    if cycles < FLAG_SEGMENT_CYCLES:
        flags.append(f"{FlagCode.TOO_FEW_CYCLES.value}: {cycles:.2f} cycles, at least {FLAG_SEGMENT_CYCLES:g} wanted")
    why = "; ".join(str(f) for f in fit.flags)
    note = f"the trial fitter found no period ({why}); frequency search: false alarm {search.false_alarm:.1e}"
    return chosen, cycles, flags, [note], search.omega_d


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


def speed_groups(segments: Sequence[MeasuredEigenvalue]) -> list[list[int]]:
    """The segments' indices grouped by speed (within :data:`SPEED_TOLERANCE` of a group's slowest), by speed."""
    groups: list[list[int]] = []
    order = sorted((i for i, s in enumerate(segments) if math.isfinite(s.speed)), key=lambda i: segments[i].speed)
    for i in order:
        if groups and segments[i].speed - segments[groups[-1][0]].speed <= SPEED_TOLERANCE:
            groups[-1].append(i)
        else:
            groups.append([i])
    return groups


def pool_drive(segments: Sequence[MeasuredEigenvalue]) -> list[MeasuredEigenvalue]:
    """The segments with the rider's drive shared at each speed (:func:`~.noise.pooled_drive`), in input order.

    One segment's estimate of the drive is noisy; the valid segments at one speed share theirs
    (:mod:`.noise`). Where the unflagged ones of the record, over all its speeds, scatter beyond
    their σ at those drives more than chance allows (:func:`~.noise.scatter_significant`), each
    speed's drive is raised until its segments do not (:func:`~.noise.scatter_drive`); so is a
    speed's whose own scatter is beyond chance among the record's speeds (one bad speed is not
    diluted by many good ones). Every segment gets its σ at its speed's drive. Segments without
    a speed keep their own.
    """
    out = list(segments)
    shared: list[tuple[list[int], float, NDArray[np.float64], NDArray[np.float64]]] = []
    for group in speed_groups(segments):
        valid = [i for i in group if segments[i].valid and len(segments[i].variance) == 4]
        if len(valid) < 2:
            continue
        q = pooled_drive([(segments[i].drive, segments[i].drive_sigma) for i in valid])
        clean = [i for i in valid if not segments[i].flags]
        x = np.array([(segments[i].real, segments[i].imag) for i in clean], dtype=float).reshape(-1, 2)
        v = np.array([segments[i].variance for i in clean], dtype=float).reshape(-1, 4)
        shared.append((valid, q, x, v))
    scatter = [scatter_chi2(x, v, q) for _, q, x, v in shared]
    raise_drive = scatter_significant(sum(c for c, _ in scatter), sum(d for _, d in scatter))
    for (valid, q, x, v), (chi2, dof) in zip(shared, scatter, strict=True):
        alone = scatter_significant(chi2, dof, tests=len(shared))  # one speed's scatter among the record's
        q_used = scatter_drive(x, v, q) if raise_drive or alone else q
        for i in valid:
            out[i] = segments[i].with_drive(q_used)
    return out


def combine_eigenvalues(segments: Sequence[MeasuredEigenvalue]) -> list[CombinedEigenvalue]:
    """The clean segments grouped by speed (within :data:`SPEED_TOLERANCE`) and combined, by speed."""
    groups = [[segments[i] for i in g] for g in speed_groups(segments)]
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
