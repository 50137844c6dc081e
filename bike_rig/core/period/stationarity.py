"""Does the period stay put along the record, or move as the fit's model says? Windowed periods.

A fit gives one period; a real pendulum's may move along the record (a finite swing shortens it
as the swing decays, a clamp settles, the temperature changes). Every fit therefore reports the
period of each of up to ``MAX_WINDOWS`` consecutive windows of at least ``MIN_WINDOW_CYCLES``
whole cycles, with σ.

They come from what the fit already has: per whole cycle, the residual's complex amplitude at
the fitted frequency relative to the fitted oscillation (``deviation``; its imaginary part over
the cycle's amplitude is the cycle's phase departure from the fit, rad). In each window the
phase's weighted least-squares slope against time is the window's frequency departure, so its
period is ``2π / (ω + slope)``. The phase's noise per cycle is measured, as for the beating test,
by the second differences of the deviations from cycle to cycle (blind to a smooth departure
from the fit, such as a dry-friction envelope): its variance is half of E|d|² = E|Δ²d|²/6,
divided by the cycle's squared amplitude.

**What the model does not explain.** The same windowed slopes of the *chosen* model's residual
phase are what its period law (constant, or following the swing) leaves over. Fitted by what the
model can still absorb (its ω; with the swing term also that term's windowed slopes), they leave
χ² with ν = windows − 1 (− 2 with the swing term) degrees of freedom; since their σ come from
the cycles' own noise (cycles − 2 degrees of freedom), χ²/ν is tested against Fisher's F. With
B = sqrt(χ²/ν) the Birge ratio and ΔT the model's mean period minus the windows' (the model's
moved by the windows' mean departure, weighted by their cycles):

* below the ``WIDEN_FROM`` quantile: nothing changes;
* beyond it: σ² = (B σ)² + ΔT² (the small-swing period's σ: × B);
* beyond ``REJECT_FROM`` (the model's law is rejected): the mean period is the windows', with
  σ² = σ² + σ_ΔT²;
* flagged ``period_drift`` only when the movement is both certain and large: beyond the
  ``FLAG_FROM`` quantile and B ≥ ``MAX_BIRGE``.

A flag sends the trial to be redone, and a session holds tens of trials: at ``REJECT_FROM`` a
clean session would lose a trial now and then (on the rig simulator's clean trials the test's
probabilities are uniform: 1 trial in 1000 falls below 1e-3, two windows of a short record then
lying some 7 σ apart by chance). Below ``FLAG_FROM`` a session of a hundred clean trials is
flagged once in a thousand sessions; in between, the σ carries the movement (widened, or the
windows' own mean period) and a note says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .oscillation import TWO_PI
from .result import Flag, FlagCode, PeriodFit

__all__ = [
    "MAX_BIRGE",
    "Movement",
    "PhaseResidual",
    "Stationarity",
    "unexplained_movement",
    "windowed_periods",
    "windows_mean_period",
    "with_stationarity",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Windows at most.
MAX_WINDOWS = 4
#: Whole cycles per window at least.
MIN_WINDOW_CYCLES = 4
#: The probability of one period (χ² about the weighted mean) below which the windows "move".
MOVES_BELOW = 1e-3
#: The probability under the model below which its unexplained movement widens the σ.
WIDEN_FROM = 0.05
#: The probability under the model below which its period law is rejected (the windows' mean is taken).
REJECT_FROM = 1e-3
#: The probability below which a movement of ``MAX_BIRGE`` × its σ or more is flagged: one clean
#: trial in 1e5 (a session of 100 trials: one in 1000 sessions).
FLAG_FROM = 1e-5
#: The Birge ratio from which the unexplained movement is flagged ``period_drift``.
MAX_BIRGE = 3.0


def _probability(chi2: float, dof: int, noise_dof: int) -> float:
    """The chance of a χ² of ``dof`` degrees of freedom this large, its scale from ``noise_dof`` of noise.

    The windows' σ come from a noise estimate of its own few degrees of freedom (the cycles
    less 2): χ²/ν then follows Fisher's F(ν, noise_dof), whose tail is longer than χ²_ν/ν's.
    """
    from scipy.special import fdtrc  # (scipy.special: loaded already for the σ's Student factor)

    return float(fdtrc(dof, max(1, noise_dof), chi2 / dof))


@dataclass(frozen=True)
class Stationarity:
    """The windowed periods of a fit.

    Attributes:
        periods: The period of each window, in record order [s].
        sigmas: Their standard uncertainties [s].
        chi2: Σ ((T_w − T̄) / σ_w)² about their weighted mean T̄.
        noise_dof: Degrees of freedom of the per-cycle noise their σ come from.
    """

    periods: tuple[float, ...]
    sigmas: tuple[float, ...]
    chi2: float
    noise_dof: int

    @property
    def moves(self) -> bool:
        """Whether the period moves beyond the windows' σ (χ² beyond its ``MOVES_BELOW`` quantile)."""
        dof = len(self.periods) - 1
        return dof >= 1 and _probability(self.chi2, dof, self.noise_dof) < MOVES_BELOW

    @property
    def spread(self) -> float:
        """Largest minus smallest windowed period [s]."""
        return max(self.periods) - min(self.periods)

    def describe(self) -> str:
        """One line: the windows' periods and whether they move."""
        values = ", ".join(f"{p:.6g}" for p in self.periods)
        sigma = max(self.sigmas)
        verdict = "moves beyond its σ" if self.moves else "steady within its σ"
        return f"the period along the record: {values} s (σ ≤ {sigma:.2g} s, χ² = {self.chi2:.1f}): {verdict}"


@dataclass(frozen=True)
class PhaseResidual:
    """A fit's per-cycle departures from its own model, for :func:`unexplained_movement`.

    Attributes:
        deviation: Per whole cycle, the residual's complex amplitude at the fitted frequency
            relative to the fitted oscillation (the fit's units).
        amplitude: Per whole cycle, the fitted oscillation's amplitude (same units).
        omega: The fitted angular frequency [rad/s].
        model: What the model's period does, for the messages ("a constant period", "the swing").
        shape: Per whole cycle, the phase the model's swing term adds per unit of κ [rad]
            (None: the model's period is constant).
    """

    deviation: ComplexArray
    amplitude: FloatArray
    omega: float
    model: str = "a constant period"
    shape: FloatArray | None = None


@dataclass(frozen=True)
class Movement:
    """How far the period moves along the record beyond what the fit's model explains.

    Attributes:
        chi2: χ² of the windowed frequency departures about what the model can absorb [-].
        dof: Its degrees of freedom.
        model: What the model's period does (:class:`PhaseResidual`).
        shift: The windows' frequency departures from the model, averaged over the window
            (weighted by their cycles): the model's mean frequency is this far from the
            record's [rad/s].
        shift_sigma: Its σ [rad/s].
        probability: The chance of so large a χ² when the model holds (:func:`_probability`).
    """

    chi2: float
    dof: int
    model: str
    shift: float
    shift_sigma: float
    probability: float

    @property
    def rejects(self) -> bool:
        """Whether the model's period law is rejected (χ² beyond its ``REJECT_FROM`` quantile)."""
        return self.probability < REJECT_FROM

    @property
    def birge(self) -> float:
        """The Birge ratio sqrt(χ²/ν) [-]."""
        return math.sqrt(self.chi2 / self.dof)

    @property
    def widening(self) -> float:
        """The factor on a σ the model's law carries: the Birge ratio beyond χ²'s ``WIDEN_FROM`` quantile, else 1."""
        if self.probability < WIDEN_FROM:
            return max(1.0, self.birge)
        return 1.0

    def flag(self, windows: Stationarity | None) -> Flag | None:
        """``period_drift`` beyond χ²'s ``FLAG_FROM`` quantile with a movement of ``MAX_BIRGE`` × its σ or more.

        Args:
            windows: Eq 23's windowed periods, to say how far the period moves.
        """
        if not (self.probability < FLAG_FROM and self.birge >= MAX_BIRGE):
            return None
        moves = ""
        if windows is not None:
            first, last = windows.periods[0], windows.periods[-1]
            moves = f" ({first:.5g} s to {last:.5g} s, {100 * windows.spread / first:.2g} % at most)"
        return Flag(
            FlagCode.PERIOD_DRIFT,
            f"the period moves along the record{moves} beyond {self.model}: {self.birge:.1f} × its σ "
            f"(χ² = {self.chi2:.1f} for {self.dof} degrees of freedom, p = {self.probability:.1g}; "
            f"flagged from {MAX_BIRGE:g} × at p < {FLAG_FROM:g})",
        )

    def describe(self, reported: tuple[float, float], model: tuple[float, float]) -> str:
        """One line: whether the model explains the movement, and what became of the period and its σ.

        Args:
            reported: The period reported and its σ [s].
            model: The model's own period and its σ [s].
        """
        what = f"χ² = {self.chi2:.1f} for {self.dof} degrees of freedom about {self.model}"
        if self.rejects:
            return (
                f"the period moves beyond {self.model} ({what}): the mean period is the windows', "
                f"{reported[0]:.6g} ± {reported[1]:.2g} s (by {self.model}: {model[0]:.6g} ± {model[1]:.2g} s)"
            )
        if self.widening > 1.0:
            return f"the period moves beyond {self.model} ({what}): its σ widened by the Birge ratio {self.birge:.2f}"
        return f"the period follows {self.model} within its σ ({what})"


def _windows(n: int) -> NDArray[np.intp] | None:
    """The first cycle of each window (np.array_split's), or None for fewer than two windows."""
    windows = min(MAX_WINDOWS, n // MIN_WINDOW_CYCLES)
    if windows < 2:
        return None
    size, extra = divmod(n, windows)
    return np.asarray(np.arange(windows) * size + np.minimum(np.arange(windows), extra), dtype=np.intp)


@dataclass(frozen=True)
class _Slopes:
    """Each window's weighted least-squares slope against time of a fit's per-cycle phase departures.

    Attributes:
        starts: The first cycle of each window.
        phase: Each window's frequency departure from the fit [rad/s].
        shape: Each window's slope of the swing term's phase per unit κ [rad/s] (None: no term).
        sxx: Σ w (t − t̄)² per window [s²/rad²]: 1/σ² of ``phase``.
        cycles: Cycles in all.
    """

    starts: NDArray[np.intp]
    phase: FloatArray
    shape: FloatArray | None
    sxx: FloatArray
    cycles: int


def _slopes(residual: PhaseResidual) -> _Slopes | None:
    """The windows' slopes of ``residual`` (module docstring), or None for fewer than two windows."""
    deviation, amplitude = residual.deviation, residual.amplitude
    n = deviation.size
    starts = _windows(n)
    if starts is None or not np.all(amplitude > 0):
        return None
    curve = deviation[2:] - 2.0 * deviation[1:-1] + deviation[:-2]  # (blind to a smooth departure)
    noise2 = float(np.vdot(curve, curve).real) / (6.0 * (n - 2))  # E|noise|² of one deviation
    w = 1.0 / np.maximum(0.5 * noise2 / amplitude**2, np.finfo(float).tiny)  # 1 / each cycle's phase variance
    t = (np.arange(n) + 0.5) * (TWO_PI / residual.omega)  # cycle centres [s]
    tm = np.add.reduceat(w * t, starts) / np.add.reduceat(w, starts)  # weighted mean time per window
    wtc = t - np.repeat(tm, np.diff(np.append(starts, n)))
    sxx = np.add.reduceat(w * wtc * wtc, starts)
    wtc *= w
    phase = np.add.reduceat(wtc * (deviation.imag / amplitude), starts) / sxx
    shape = None if residual.shape is None else np.add.reduceat(wtc * residual.shape, starts) / sxx
    return _Slopes(starts, phase, shape, sxx, n)


def _stationarity(slopes: _Slopes, omega: float) -> Stationarity:
    """The windows' periods 2π / (ω + slope), σ and χ² about their weighted mean."""
    omega_w = omega + slopes.phase
    p = TWO_PI / omega_w
    s = TWO_PI / omega_w**2 / np.sqrt(slopes.sxx)
    mean = float(np.sum(p / s**2) / np.sum(1.0 / s**2))
    chi2 = float(np.sum(((p - mean) / s) ** 2))
    return Stationarity(tuple(p.tolist()), tuple(s.tolist()), chi2, slopes.cycles - 2)


def _movement(slopes: _Slopes, model: str) -> Movement | None:
    """χ² of the windows' departures about their weighted fit by a constant (and the swing term's slopes)."""
    w, y, x = slopes.sxx, slopes.phase, slopes.shape
    dof = y.size - (1 if x is None else 2)
    if dof < 1:
        return None
    yc = y - float(w @ y) / float(np.sum(w))
    chi2 = float(w @ (yc * yc))
    if x is not None:
        xc = x - float(w @ x) / float(np.sum(w))
        sxx = float(w @ (xc * xc))
        chi2 -= float(w @ (xc * yc)) ** 2 / sxx if sxx > 0 else 0.0
    share = np.diff(np.append(slopes.starts, slopes.cycles)) / slopes.cycles  # each window's share of the cycles
    shift, shift_sigma = float(share @ y), math.sqrt(float(share**2 @ (1.0 / w)))
    chi2 = max(0.0, chi2)
    return Movement(chi2, dof, model, shift, shift_sigma, _probability(chi2, dof, slopes.cycles - 2))


def windowed_periods(deviation: ComplexArray, amplitude: FloatArray, omega: float) -> Stationarity | None:
    """The periods of consecutive windows of whole cycles (module docstring).

    Args:
        deviation: Per whole cycle, the residual's complex amplitude at ω relative to the
            fitted oscillation (the fit's units).
        amplitude: Per whole cycle, the fitted oscillation's amplitude (same units).
        omega: The fitted angular frequency [rad/s].

    Returns:
        The windows' periods, or None with fewer than two windows of ``MIN_WINDOW_CYCLES``.
    """
    slopes = _slopes(PhaseResidual(deviation, amplitude, omega))
    return None if slopes is None else _stationarity(slopes, omega)


def unexplained_movement(residual: PhaseResidual) -> Movement | None:
    """χ² of the windows' frequency departures from the model, about what the model absorbs (module docstring).

    Returns:
        The movement, or None without a degree of freedom (too few windows).
    """
    slopes = _slopes(residual)
    return None if slopes is None else _movement(slopes, residual.model)


def windows_mean_period(period: float, sigma: float, shift: float, shift_sigma: float) -> tuple[float, float]:
    """Eq 25 over the window from the windows: ``T̄ = 2π / (2π/T + Δω)``, σ² = σ_T² + (T̄² σ_Δω / 2π)², s.

    The model's mean period T (± σ_T) moved by the windows' mean frequency departure from the
    model Δω (± σ_Δω) [rad/s]: the record's own mean period when the model's law is rejected.
    """
    mean = TWO_PI / (TWO_PI / period + shift)
    return mean, math.hypot(sigma, mean**2 * shift_sigma / TWO_PI)


def with_stationarity(fit: PeriodFit, eq23: PhaseResidual, residual: PhaseResidual) -> PeriodFit:
    """``fit`` with its windowed periods, its σ made to cover what its model leaves unexplained, and flags.

    Args:
        fit: The fit under its chosen damping model (``period``: the mean period).
        eq23: Eq 23's per-cycle departures, for the windowed periods (its phase is linear, so
            the windows see every movement).
        residual: The chosen model's per-cycle departures (:func:`unexplained_movement`; may
            be ``eq23`` itself).

    Returns:
        ``fit`` with ``window_periods`` and a note when they move. When the model leaves a
        movement beyond χ²'s ``WIDEN_FROM`` quantile, ``period_sigma`` and
        ``small_swing_period_sigma`` are multiplied by the Birge ratio; beyond ``REJECT_FROM``
        (the model's law rejected) the mean period is the windows' (the model's, moved by
        their mean departure ``shift``), σ² = σ_model² + σ_shift²; ``period_drift`` is
        flagged beyond ``FLAG_FROM`` when the Birge ratio reaches ``MAX_BIRGE``.
    """
    notes, flags = list(fit.notes), list(fit.flags)
    slopes = _slopes(eq23)
    windows = None if slopes is None else _stationarity(slopes, eq23.omega)
    if windows is not None:
        fit = replace(fit, window_periods=windows.periods, window_period_sigmas=windows.sigmas)
        if windows.moves:
            notes.append(windows.describe())
    if residual is not eq23:
        slopes = _slopes(residual)
    movement = None if slopes is None else _movement(slopes, residual.model)
    if movement is None:
        return replace(fit, notes=tuple(notes))
    widening = movement.widening
    period, sigma = fit.period, fit.period_sigma
    windows_period, windows_sigma = windows_mean_period(period, sigma, movement.shift, movement.shift_sigma)
    if movement.rejects:
        period, sigma = windows_period, windows_sigma
    elif widening > 1.0:  # (and the model's departure from the windows' mean period)
        sigma = math.hypot(widening * sigma, windows_period - period)
    if widening > 1.0 or (windows is not None and windows.moves):
        notes.append(movement.describe((period, sigma), (fit.period, fit.period_sigma)))
    if (flag := movement.flag(windows)) is not None:
        flags.append(flag)
    return replace(
        fit,
        period=period,
        period_sigma=sigma,
        mean_period=period,
        small_swing_period_sigma=fit.small_swing_period_sigma * widening,
        sigma_widening=sigma / fit.period_sigma if fit.period_sigma > 0 else widening,
        notes=tuple(notes),
        flags=tuple(flags),
    )
