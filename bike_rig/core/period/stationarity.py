"""Does the period stay put along the record? Windowed periods from the per-cycle phases.

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
divided by the cycle's squared amplitude. This is a
windowed fit's information at no extra cost.

The windows' periods are tested against one period (χ² with ``windows − 1`` degrees of
freedom, probability 1e-3): a movement beyond their σ is noted (the trial is still good).
A spread (largest − smallest) above ``MAX_PERIOD_SPREAD`` of the period makes the period
meaningless: flagged ``period_drift``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .oscillation import TWO_PI
from .result import Flag, FlagCode, PeriodFit

__all__ = ["MAX_PERIOD_SPREAD", "Stationarity", "windowed_periods", "with_stationarity"]

#: Windows at most.
MAX_WINDOWS = 4
#: Whole cycles per window at least.
MIN_WINDOW_CYCLES = 4
#: A spread of the windowed periods above this fraction of the period is flagged.
MAX_PERIOD_SPREAD = 0.02
#: χ² at probability 1e-3 of one period, by degrees of freedom (1, 2, 3).
_CHI2_LIMIT = {1: 10.83, 2: 13.82, 3: 16.27}


@dataclass(frozen=True)
class Stationarity:
    """The windowed periods of a fit.

    Attributes:
        periods: The period of each window, in record order [s].
        sigmas: Their standard uncertainties [s].
        chi2: Σ ((T_w − T̄) / σ_w)² about their weighted mean T̄.
    """

    periods: tuple[float, ...]
    sigmas: tuple[float, ...]
    chi2: float

    @property
    def moves(self) -> bool:
        """Whether the period moves beyond the windows' σ (χ² beyond its 1e-3 quantile)."""
        return self.chi2 > _CHI2_LIMIT.get(len(self.periods) - 1, math.inf)

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

    def flag(self, period: float) -> Flag | None:
        """``period_drift`` when the windows spread by more than ``MAX_PERIOD_SPREAD`` of ``period``."""
        if not (self.moves and self.spread > MAX_PERIOD_SPREAD * period):
            return None
        return Flag(
            FlagCode.PERIOD_DRIFT,
            f"the period moves by {100 * self.spread / period:.1f} % along the record "
            f"({self.periods[0]:.5g} s to {self.periods[-1]:.5g} s; limit {100 * MAX_PERIOD_SPREAD:g} %)",
        )


def windowed_periods(
    deviation: NDArray[np.complex128], amplitude: NDArray[np.float64], omega: float
) -> Stationarity | None:
    """The periods of consecutive windows of whole cycles (module docstring).

    Args:
        deviation: Per whole cycle, the residual's complex amplitude at ω relative to the
            fitted oscillation (the fit's units).
        amplitude: Per whole cycle, the fitted oscillation's amplitude (same units).
        omega: The fitted angular frequency [rad/s].

    Returns:
        The windows' periods, or None with fewer than two windows of ``MIN_WINDOW_CYCLES``.
    """
    n = deviation.size
    windows = min(MAX_WINDOWS, n // MIN_WINDOW_CYCLES)
    if windows < 2 or not np.all(amplitude > 0):
        return None
    curve = deviation[2:] - 2.0 * deviation[1:-1] + deviation[:-2]  # (blind to a smooth departure)
    noise2 = float(np.vdot(curve, curve).real) / (6.0 * (n - 2))  # E|noise|² of one deviation
    phase = deviation.imag / amplitude  # rad
    var = np.maximum(0.5 * noise2 / amplitude**2, np.finfo(float).tiny)  # rad²
    t = (np.arange(n) + 0.5) * (TWO_PI / omega)  # cycle centres [s]
    # each window's weighted least-squares slope of the phase against time (all windows at once)
    size, extra = divmod(n, windows)
    starts = np.arange(windows) * size + np.minimum(np.arange(windows), extra)  # (np.array_split's)
    w = 1.0 / var
    sw = np.add.reduceat(w, starts)
    tm = np.add.reduceat(w * t, starts) / sw  # weighted mean time per window
    tc = t - np.repeat(tm, np.diff(np.append(starts, n)))
    sxx = np.add.reduceat(w * tc * tc, starts)
    omega_w = omega + np.add.reduceat(w * tc * phase, starts) / sxx
    p = TWO_PI / omega_w
    s = TWO_PI / omega_w**2 / np.sqrt(sxx)
    mean = float(np.sum(p / s**2) / np.sum(1.0 / s**2))
    chi2 = float(np.sum(((p - mean) / s) ** 2))
    return Stationarity(tuple(p.tolist()), tuple(s.tolist()), chi2)


def with_stationarity(
    fit: PeriodFit, deviation: NDArray[np.complex128], amplitude: NDArray[np.float64], omega: float
) -> PeriodFit:
    """``fit`` with its windowed periods, a note when they move, and ``period_drift`` when they spread.

    Args:
        fit: The fit (Eq 23's: its phase is linear, so the windows see every movement).
        deviation: Its per-cycle deviations (:func:`windowed_periods`).
        amplitude: Its per-cycle amplitudes.
        omega: Its angular frequency [rad/s].
    """
    found = windowed_periods(deviation, amplitude, omega)
    if found is None:
        return fit
    notes = (*fit.notes, found.describe()) if found.moves else fit.notes
    flag = found.flag(fit.period)
    flags = fit.flags if flag is None else (*fit.flags, flag)
    return replace(fit, window_periods=found.periods, window_period_sigmas=found.sigmas, notes=notes, flags=flags)
