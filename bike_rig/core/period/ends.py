"""The record's own mean period from its phase at the window's two ends: a check of the period law.

The mean period over the window (Eq 25 over the window: the paper's quantity) is the window's
length W over the phase the oscillation gains in it, ``T̄ = 2π W / Φ``; only the phase at the
window's two ends decides it. A fit's model (a constant period, or one following the swing)
gives Φ from its period law, fitted to every cycle with weights that favour the large early
swings: a period change late in the record that the law does not describe (a clamp settling,
a part touching) moves the true T̄ but hardly the fit's.

The check needs no period law. Per whole cycle the fit has the phase departure of the record
from its model (:class:`~bike_rig.core.period.stationarity.PhaseResidual`); a weighted quadratic
through the departures of the first and of the last ``END_CYCLES`` cycles (a line through
``SHORT_END_CYCLES`` on windows too short for it), extrapolated to the window's start and end,
is the record's own phase there relative to the model's. The quadratic follows a period that
changes at a steady rate near an end, where a line lags it; through five cycles its
extrapolation varies less than a line's through two. The two phases' difference D [rad] turns
the model's own Φ (before the windowed test moves it) into the record's,
``T_ends = 2π W / (Φ + D)``: a mean period from the two ends alone, unbiased whatever the
period does in between, with a larger σ.

Under the model D is noise only: its σ follows from the cycles' phase noise (as for the
windowed periods, from second differences of the departures, blind to smooth departures)
propagated through what the model's fit absorbs (a phase offset, its frequency and, with a
finite swing, the swing term's phase shape; weighted least squares on the cycles). Then

* when the ends depart from the model's period by more than that σ (|ΔT| > σ_ΔT, ΔT the
  distance of the reported period from ``T_ends``, σ_ΔT that of D under the model: the data
  then estimate the model's squared bias ΔT² − σ_ΔT² above zero), the model's period is kept
  and its σ becomes the half-width about it that holds 68.3 % of the truth when the model's
  bias is ΔT ± σ_ΔT (:func:`bias_aware_sigma`: |ΔT| + 0.47 S far out, S² = σ² + σ_ΔT²);
  otherwise nothing changes;
* ``period_drift`` is flagged when D is both certain and large: beyond the Student-t
  quantile ``FLAG_FROM`` and ``MAX_BIRGE`` × its σ (as the windowed test).

The model's period is kept rather than moved toward ``T_ends``: on the simulated fork moving it
all the way covers clean records in 53–63 % of records, and by an empirical-Bayes weight
1 − σ_ΔT²/ΔT² in 72–75 % but changes of 1–2 ms less often than keeping it (41–57 % against
47–60 %); the root mean square ``sqrt(σ² + ΔT² + σ_ΔT²)`` covers a large bias towards 50 %.

On the simulated fork (dry friction, a 13° to 5° finite swing, a noisy 12-bit gyro; 200
records each, ``bench/bench_period_late.py``) a change of −3 ms in the last 7 s of 30 s moves
the mean period by about 1.8 σ_ΔT: ±σ covers the truth in 63 % of records, +3 ms in 74 %,
−7 ms in 90 %; clean records in 78 %, Eq 23's own records in 85 %: σ grows on the 23–33 % of
clean records whose ends depart by more than σ_ΔT by chance (D / σ_ΔT scatters by 0.9–1.1
there). A change smaller than σ_ΔT goes unseen: −1 ms is covered in 47 % of records, −2 ms in 54 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .oscillation import TWO_PI
from .result import Flag, FlagCode, PeriodFit
from .stationarity import FLAG_FROM, MAX_BIRGE, WIDEN_FROM, PhaseResidual

__all__ = ["DEPARTS_BEYOND", "END_CYCLES", "EndCheck", "bias_aware_sigma", "end_check", "with_end_check"]

FloatArray = NDArray[np.float64]

#: Whole cycles at each end of the window through which the end's phase curve is fitted, and the
#: curve's degree: a quadratic follows a period that changes at a steady rate near the end.
END_CYCLES = 5
END_DEGREE = 2
#: The line through fewer cycles for windows too short for the quadratic.
SHORT_END_CYCLES = 2
#: Fewest whole cycles for the check (both ends' curves and a degree of freedom beyond the model).
MIN_CYCLES = 2 * SHORT_END_CYCLES + 2
#: The ends depart from the model when |ΔT| exceeds this many σ_ΔT: from 1 the data estimate the
#: model's squared bias ΔT² − σ_ΔT² above zero. (At 2 — p ≈ 0.05 — clean records keep their σ
#: but a late −3 ms change on the noisy fork is covered in about 25 % of records.)
DEPARTS_BEYOND = 1.0
#: The share of a normal distribution within ±1 σ.
ONE_SIGMA = math.erf(1.0 / math.sqrt(2.0))


@dataclass(frozen=True)
class EndCheck:
    """The record's phase gain over the window beyond its model's, from the window's ends.

    Attributes:
        shift: D, the record's phase gain beyond the model's over the window [rad].
        sigma: σ of D when the model holds [rad].
        noise_dof: Degrees of freedom of the cycles' noise estimate.
        span: The window's length W [s].
        model: What the model's period does (for the messages).
    """

    shift: float
    sigma: float
    noise_dof: int
    span: float
    model: str

    @property
    def z(self) -> float:
        """D / σ [-]."""
        return self.shift / self.sigma if self.sigma > 0 else math.nan

    @property
    def probability(self) -> float:
        """The chance of so large a |D| when the model holds (Student t, the noise's degrees of freedom)."""
        from scipy.special import stdtr  # (loaded already for the σ's Student factor)

        return float(2.0 * stdtr(max(1, self.noise_dof), -abs(self.z))) if math.isfinite(self.z) else 1.0

    def period(self, model_period: float) -> tuple[float, float]:
        """``T_ends = 2π W / (Φ + D)`` and σ of its distance from the model's period [s].

        Args:
            model_period: The model's mean period over the window [s] (Φ = 2π W / it).
        """
        phase = TWO_PI * self.span / model_period + self.shift
        ends = TWO_PI * self.span / phase
        return ends, ends * self.sigma / phase


def _end_curve(t: FloatArray, w: FloatArray, cycles: NDArray[np.intp], at: float, n: int, degree: int) -> FloatArray:
    """The weights that give a weighted polynomial of ``degree`` through ``cycles``, evaluated at ``at`` [s]."""
    x = np.vander(t[cycles] - at, degree + 1)  # (its last column: the value at ``at``)
    wc = w[cycles]
    value = np.zeros(degree + 1)
    value[-1] = 1.0
    row = np.zeros(n)
    row[cycles] = wc * (x @ np.linalg.solve(x.T @ (x * wc[:, None]), value))
    return row


def bias_aware_sigma(distance: float, sigma_distance: float, sigma: float) -> float:
    """The half-width about a model's value that holds ``ONE_SIGMA`` of the truth when its bias is ``distance``.

    The model's value has its own σ ``sigma``; its bias is estimated as ``distance`` ± ``sigma_distance``
    (a flat prior on the bias): the truth then lies about the model's value as N(distance, S²),
    S² = σ² + σ_distance², and the half-width h solves Φ((h − |distance|)/S) − Φ((−h − |distance|)/S)
    = ``ONE_SIGMA`` (h = S at no distance, ≈ |distance| + 0.47 S far from it). Any unit.
    """
    scale = math.hypot(sigma, sigma_distance)
    if not scale > 0:
        return abs(distance)
    t = abs(distance) / scale

    def cdf(x: float) -> float:
        return 0.5 * math.erfc(-x / math.sqrt(2.0))

    h = t + 1.0  # (the share is concave in h beyond t: Newton's steps fall monotonically to the root)
    for _ in range(50):
        miss = cdf(h - t) - cdf(-h - t) - ONE_SIGMA
        slope = (math.exp(-0.5 * (h - t) ** 2) + math.exp(-0.5 * (h + t) ** 2)) / math.sqrt(2.0 * math.pi)
        step = miss / slope
        h -= step
        if abs(step) < 1e-12 * h:
            break
    return h * scale


def end_check(residual: PhaseResidual) -> EndCheck | None:
    """The check of the module docstring on a fit's per-cycle departures from its model.

    Returns:
        The check, or None with fewer than ``MIN_CYCLES`` whole cycles or no measurable noise.
    """
    deviation, amplitude = residual.deviation, residual.amplitude
    n = deviation.size
    if n < MIN_CYCLES or not np.all(amplitude > 0):
        return None
    curve = deviation[2:] - 2.0 * deviation[1:-1] + deviation[:-2]  # (blind to a smooth departure)
    noise2 = float(np.vdot(curve, curve).real) / (6.0 * (n - 2))  # E|noise|² of one deviation
    if not noise2 > 0:
        return None
    var: FloatArray = np.asarray(0.5 * noise2 / amplitude**2, dtype=np.float64)  # each cycle's phase variance [rad²]
    w: FloatArray = 1.0 / var
    period = TWO_PI / residual.omega
    t: FloatArray = (np.arange(n, dtype=np.float64) + 0.5) * period  # cycle centres from the window's start [s]
    span = n * period
    cycles, degree = (END_CYCLES, END_DEGREE) if n >= 2 * END_CYCLES + 2 else (SHORT_END_CYCLES, 1)
    edge = np.arange(cycles, dtype=np.intp)
    ends = _end_curve(t, w, edge + (n - cycles), span, n, degree) - _end_curve(t, w, edge, 0.0, n, degree)
    phase = deviation.imag / amplitude
    shift = float(ends @ phase)
    # what the model's fit absorbs: a weighted least-squares projection on its phase terms
    terms = [np.ones(n), t] + ([] if residual.shape is None else [np.asarray(residual.shape, dtype=float)])
    basis = np.stack(terms, axis=1)
    try:
        through = np.linalg.solve(basis.T @ (basis * w[:, None]), basis.T @ ends)
    except np.linalg.LinAlgError:
        return None
    # D's dependence on each cycle's noise, after the model's fit has absorbed its share
    sigma = float(np.linalg.norm((ends - w * (basis @ through)) * np.sqrt(var)))
    if not sigma > 0:
        return None
    return EndCheck(shift, sigma, n - 2, span, residual.model)


def with_end_check(fit: PeriodFit, residual: PhaseResidual, model: PeriodFit | None = None) -> PeriodFit:
    """``fit`` with the ends' mean period, its σ widened by the ends' bias estimate (module docstring), and a flag.

    Args:
        fit: The fit after :func:`~bike_rig.core.period.stationarity.with_stationarity`
            (``period`` the mean period, ``mean_period`` equal to it).
        residual: The chosen model's per-cycle departures.
        model: The fit before it (the model's own mean period and σ, which the departures refer
            to; None: ``fit``'s).
    """
    check = end_check(residual)
    if check is None:
        return fit
    own = fit if model is None else model
    model_period = own.mean_period if math.isfinite(own.mean_period) else own.period
    ends, sigma_shift = check.period(model_period)
    sigma_ends = math.hypot(own.period_sigma, sigma_shift)
    fit = replace(fit, ends_period=ends, ends_period_sigma=sigma_ends)
    distance = ends - fit.period
    notes, flags = list(fit.notes), list(fit.flags)
    p = check.probability
    departs = abs(distance) > DEPARTS_BEYOND * sigma_shift
    sigma = max(fit.period_sigma, bias_aware_sigma(distance, sigma_shift, fit.period_sigma)) if departs else 0.0
    if p < WIDEN_FROM or departs:
        widened = (
            f"; the period's σ {fit.period_sigma:.2g} s is widened to {sigma:.2g} s to hold the truth if that "
            f"departure is the model's bias"
            if sigma > fit.period_sigma
            else ""
        )
        notes.append(
            f"the phase at the window's ends departs from {check.model} by {check.shift:.3g} rad "
            f"({abs(check.z):.1f} σ, p = {p:.1g}): the ends' mean period is {ends:.6g} ± {sigma_ends:.2g} s" + widened
        )
    if p < FLAG_FROM and abs(check.z) >= MAX_BIRGE and not fit.has_flag(FlagCode.PERIOD_DRIFT):
        flags.append(
            Flag(
                FlagCode.PERIOD_DRIFT,
                f"the period changes along the record beyond {check.model}: the phase at the window's ends "
                f"departs from it by {abs(check.z):.1f} × its σ (p = {p:.1g}; the ends' mean period "
                f"{ends:.6g} s, the model's {fit.period:.6g} s)",
            )
        )
    if not departs:
        return replace(fit, notes=tuple(notes), flags=tuple(flags))
    model_sigma = fit.period_sigma / fit.sigma_widening if fit.sigma_widening > 0 else fit.period_sigma
    return replace(
        fit,
        period_sigma=sigma,
        sigma_widening=sigma / model_sigma if model_sigma > 0 else fit.sigma_widening,
        notes=tuple(notes),
        flags=tuple(flags),
    )
