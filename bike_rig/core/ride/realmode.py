"""Eq 23 plus a trend or one real mode: the free decay of a bicycle's roll rate over one to two cycles.

After a kick the roll rate holds all four modes of the Whipple model: the weave pair, which
Eq 23 describes, and two real ones (capsize and caster). The caster mode dies within a few
tenths of a second; the capsize mode decays (or grows) slowly, at a rate comparable with the
segment's length, and over one or two cycles Eq 23's constant offset cannot absorb it: the
weave's fitted eigenvalue is then biased by several of its σ (measured on simulated rides,
``test/core/ride``). So the ride's segments are fitted with

    y(τ) = A + D (e^{μτ} − 1)/μ + e^{−ατ}(B sin ω_d τ + C cos ω_d τ),   τ = t − t_mid   [eq23_real]

(the real mode written so that it becomes a linear trend D τ as μ → 0, with no degeneracy
with A), with μ = 0, a linear trend [eq23_trend], or with neither, Eq 23 alone [eq23]. For
fixed (α, ω_d, μ) the model is linear in A, B, C, D, which are solved by least squares
(variable projection); :func:`scipy.optimize.least_squares` fits the nonlinear parameters from
a starting (α, ω_d). σ: the sandwich of :mod:`.noise` (white sensor noise plus the weave driven
by the rider) with the Jacobian of all parameters, times the Student-t factor for n_eff − p
degrees of freedom; its white part never below the residuals' own, ``SSE/(n − p) (JᵀJ)⁻¹``
(what the residual supports, whatever the sensor's noise). A design that does not determine
its parameters (condition number above :data:`.noise.MAX_CONDITION`) is no fit. Which model a
segment gets is :mod:`.choice`'s.
Units: t s, α and μ 1/s, ω_d rad/s; A, B, C in the signal's units, D in its units per second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..period.sigma import student_factor
from .noise import ResidualNoise, driven_covariance, inverse_normal_matrix, pooled_drive, residual_noise

__all__ = ["RealModeFit", "RealModeFitFailed", "fit_with_real_mode", "real_mode_basis"]

FloatArray = NDArray[np.float64]

#: Starting decay rates of the real mode tried [1/s] (the best fit is kept).
MU_STARTS = (-2.0, -0.5, 0.5)


class RealModeFitFailed(ArithmeticError):
    """The model could not be fitted (singular design)."""


@dataclass(frozen=True)
class RealModeFit:
    """The fit of the ``eq23``, ``eq23_trend`` or ``eq23_real`` model.

    Attributes:
        alpha: Decay rate of the oscillation ζω [1/s] (Re λ = −alpha).
        alpha_sigma: Its σ [1/s].
        omega_d: Damped angular frequency [rad/s] (Im λ).
        omega_d_sigma: Its σ [rad/s].
        mu: The real mode's rate [1/s] (0: the trend, or none).
        r2: Coefficient of determination [-].
        residual_rms: RMS of the residuals [signal units].
        model: ``eq23`` (no trend), ``eq23_trend`` or ``eq23_real``.
        n_params: Parameters fitted (5, 6 or 7).
        sse: Sum of squared residuals [signal units²].
        noise: The residuals' white-plus-AR(1) model (:mod:`.noise`): their worth in samples.
        variance: Var(α) and Var(ω_d) as ``(α white, α per unit drive, ω white, ω per unit drive)``
            (:class:`~.noise.DrivenCovariance`, times the Student factor²); the σ above use the
            segment's own drive.
        drive: This segment's estimate of the drive q̂ (may be negative; NaN: none) [units² / s].
        drive_sigma: Its σ [units² / s].
        coefficients: A, B, C, D of the linear basis (:func:`real_mode_basis`; D = 0 for ``eq23``).
        t_mid: The time τ is counted from [s].
    """

    alpha: float
    alpha_sigma: float
    omega_d: float
    omega_d_sigma: float
    mu: float
    r2: float
    residual_rms: float
    model: str = "eq23_trend"
    n_params: int = 6
    sse: float = math.nan
    noise: ResidualNoise = ResidualNoise(math.nan, 0.0, 0.0)
    variance: tuple[float, float, float, float] = (math.nan, math.nan, math.nan, math.nan)
    drive: float = math.nan
    drive_sigma: float = math.nan
    coefficients: tuple[float, float, float, float] = (math.nan, math.nan, math.nan, math.nan)
    t_mid: float = 0.0

    def baseline(self, times: ArrayLike) -> FloatArray:
        """The model without its oscillation, A + D (e^{μτ} − 1)/μ, at ``times`` [s] [signal units]."""
        tau = np.asarray(times, dtype=float) - self.t_mid
        phi, _ = real_mode_basis(tau, 0.0, 1.0, self.mu)
        return np.asarray(self.coefficients[0] + self.coefficients[3] * phi[:, 3], dtype=float)


def real_mode_basis(tau: FloatArray, alpha: float, omega_d: float, mu: float) -> tuple[FloatArray, FloatArray]:
    """The model's linear basis [1, e^{−ατ} sin ω_dτ, e^{−ατ} cos ω_dτ, (e^{μτ} − 1)/μ] and ∂/∂μ of the last.

    Args:
        tau: Times from the segment's middle [s].
        alpha: ζω [1/s].
        omega_d: ω_d [rad/s].
        mu: The real mode's rate [1/s].
    """
    e = np.exp(-alpha * tau)
    if abs(mu) * float(np.max(np.abs(tau))) > 1e-6:
        g = np.expm1(mu * tau) / mu
        dg = (tau * np.exp(mu * tau) - g) / mu
    else:  # the series: (e^{μτ} − 1)/μ = τ + μτ²/2 + μ²τ³/6
        g = tau + 0.5 * mu * tau**2 + mu**2 * tau**3 / 6.0
        dg = 0.5 * tau**2 + mu * tau**3 / 3.0
    phi = np.column_stack([np.ones_like(tau), e * np.sin(omega_d * tau), e * np.cos(omega_d * tau), g])
    return phi, dg


def _solve(phi: FloatArray, y: FloatArray) -> FloatArray:
    coef, *_ = np.linalg.lstsq(phi, y, rcond=None)
    return np.asarray(coef, dtype=float)


def _centred(times: ArrayLike, samples: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The times [s], the samples and the times from the record's centre [s].

    Raises:
        RealModeFitFailed: Fewer than 8 samples (a fit has up to seven parameters).
    """
    t = np.asarray(times, dtype=float)
    y = np.asarray(samples, dtype=float)
    if y.size < 8:
        raise RealModeFitFailed(f"{y.size} samples for up to seven parameters")
    return t, y, t - 0.5 * (t[0] + t[-1])


def fit_with_real_mode(
    times: ArrayLike,
    samples: ArrayLike,
    alpha0: float,
    omega_d0: float,
    free_mu: bool = False,
    trend: bool = True,
    white: float = math.nan,
) -> RealModeFit:
    """Fit ``eq23_trend`` (``free_mu``: ``eq23_real``; ``trend=False``: ``eq23``) from a starting (α, ω_d).

    Args:
        times: Sample times [s].
        samples: The samples.
        alpha0: Starting ζω [1/s].
        omega_d0: Starting ω_d [rad/s].
        free_mu: Fit the real mode's rate μ (else μ = 0: a linear trend).
        trend: Fit the trend or real mode at all (False: Eq 23, an offset and the oscillation).
        white: The sensor's white-noise σ [signal units] for the noise model (:mod:`.noise`;
            NaN: the residuals are taken as white).

    Raises:
        RealModeFitFailed: Fewer than 8 samples, or a singular design.
    """
    from scipy.optimize import least_squares

    t, y, tau = _centred(times, samples)
    n = y.size
    free_mu = free_mu and trend
    cols = 4 if trend else 3

    def residual(p: FloatArray) -> FloatArray:
        phi, _ = real_mode_basis(tau, float(p[0]), float(p[1]), float(p[2]) if free_mu else 0.0)
        return np.asarray(phi[:, :cols] @ _solve(phi[:, :cols], y) - y, dtype=float)

    best = None
    for mu0 in MU_STARTS if free_mu else (0.0,):
        start = np.array([alpha0, omega_d0, mu0] if free_mu else [alpha0, omega_d0])
        sol = least_squares(residual, start, method="lm")
        if sol.x[1] > 0 and (best is None or sol.cost < best.cost):
            best = sol
    if best is None:
        raise RealModeFitFailed("no fit with a positive frequency")
    alpha, omega_d = float(best.x[0]), float(best.x[1])
    mu = float(best.x[2]) if free_mu else 0.0
    phi, dg = real_mode_basis(tau, alpha, omega_d, mu)
    phi = phi[:, :cols]
    coef = _solve(phi, y)
    b, c = float(coef[1]), float(coef[2])
    r = phi @ coef - y
    e = np.exp(-alpha * tau)
    osc = b * np.sin(omega_d * tau) + c * np.cos(omega_d * tau)
    quad = b * np.cos(omega_d * tau) - c * np.sin(omega_d * tau)
    columns = [phi, -tau * e * osc, tau * e * quad] + ([float(coef[3]) * dg] if free_mu else [])
    jac = np.column_stack(columns)
    p = jac.shape[1]
    noise = residual_noise(r, white, p)
    try:
        driven = driven_covariance(t, jac, r, alpha, omega_d, white)
    except np.linalg.LinAlgError:
        raise RealModeFitFailed("singular design: the segment does not determine the model") from None
    sse = float(r @ r)
    f2 = student_factor(max(1.0, noise.n_eff(n) - p)) ** 2
    ia, iw = cols, cols + 1
    floor = sse / max(1, n - p) * inverse_normal_matrix(jac)  # the residuals' own covariance, taken as white
    variance = (
        f2 * max(float(driven.white[ia, ia]), float(floor[ia, ia])),
        f2 * float(driven.per_drive[ia, ia]),
        f2 * max(float(driven.white[iw, iw]), float(floor[iw, iw])),
        f2 * float(driven.per_drive[iw, iw]),
    )
    q = pooled_drive([(driven.drive, driven.drive_sigma)])
    centred = y - float(np.mean(y))
    sst = float(centred @ centred)
    d = float(coef[3]) if trend else 0.0
    return RealModeFit(
        alpha=alpha,
        alpha_sigma=math.sqrt(max(0.0, variance[0] + q * variance[1])),
        omega_d=omega_d,
        omega_d_sigma=math.sqrt(max(0.0, variance[2] + q * variance[3])),
        mu=mu,
        r2=1.0 - sse / sst if sst > 0 else math.nan,
        residual_rms=math.sqrt(sse / n),
        model="eq23_real" if free_mu else "eq23_trend" if trend else "eq23",
        n_params=p,
        sse=sse,
        noise=noise,
        variance=variance,
        drive=driven.drive,
        drive_sigma=driven.drive_sigma,
        coefficients=(float(coef[0]), b, c, d),
        t_mid=float(0.5 * (t[0] + t[-1])),
    )


#: The frequency search's highest frequency [Hz] (a bicycle's weave is far below).
SEARCH_MAX_HZ = 5.0
#: Its lowest frequency, in cycles over the segment.
SEARCH_MIN_CYCLES = 0.7
#: Its grid step, in cycles over the segment.
SEARCH_STEP_CYCLES = 0.02
#: Its decays tried: the oscillation's envelope falls by e^(−x) over the segment for each x [-]
#: (0: undamped; a free decay cut at its end by the noise falls by 2–4).
SEARCH_DECAYS = (0.0, 1.0, 2.0, 3.0, 4.0)
#: The false-alarm probability an oscillation found by the search must beat (as the trial fitter's).
SEARCH_FALSE_ALARM = 1e-4


@dataclass(frozen=True)
class FrequencySearch:
    """A short segment's best frequency and whether an oscillation stands out of the trend.

    Attributes:
        omega_d: The best angular frequency of the grid [rad/s].
        false_alarm: Probability that noise alone gives as large an F anywhere on the grid [-].
        alpha: The best decay rate of the grid [1/s] (a start for the fit).
    """

    omega_d: float
    false_alarm: float
    alpha: float = 0.0

    @property
    def found(self) -> bool:
        """An oscillation stands out (false alarm below :data:`SEARCH_FALSE_ALARM`)."""
        return self.false_alarm < SEARCH_FALSE_ALARM


def search_frequency(times: ArrayLike, samples: ArrayLike) -> FrequencySearch:
    """The frequency and decay of a decaying sinusoid plus a trend that fit best, on a grid, and its significance.

    For a segment too short for the trial fitter's spectrum (about one cycle, or a few that
    decay into the noise): at each ω of a grid from :data:`SEARCH_MIN_CYCLES` cycles over the
    segment to :data:`SEARCH_MAX_HZ` and each decay α of :data:`SEARCH_DECAYS` (over the
    segment's length), the least-squares fit of A + Dτ + e^{−ατ}(B sin ωτ + C cos ωτ); the best
    (ω, α), and the F test of B, C against the trend alone, F = ((SSE₀ − SSE)/2) / (SSE/(n − 5)),
    its p-value multiplied by the number of independent candidates searched (Bonferroni; the
    grid's width in cycles times the decays tried). An undamped search alone misses a fast
    free decay (its best sinusoid fits it poorly and at a wrong frequency), which would leave
    out the segments that decay fastest and bias the speed's mean towards slow decay.

    Args:
        times: Sample times [s].
        samples: The samples.

    Raises:
        RealModeFitFailed: Fewer than 8 samples.
    """
    from scipy.stats import f as f_distribution

    t, y, tau = _centred(times, samples)
    n = y.size
    duration = float(t[-1] - t[0])
    trend = np.column_stack([np.ones_like(tau), tau])
    r0 = trend @ _solve(trend, y) - y
    sse0 = float(r0 @ r0)
    cycles = np.arange(SEARCH_MIN_CYCLES, max(SEARCH_MIN_CYCLES, SEARCH_MAX_HZ * duration), SEARCH_STEP_CYCLES)
    best_sse, best_omega, best_alpha = math.inf, math.nan, 0.0
    for x in SEARCH_DECAYS:
        alpha = x / duration if duration > 0 else 0.0
        e = np.exp(-alpha * tau)
        for c in cycles:
            w = 2.0 * math.pi * c / duration
            phi = np.column_stack([trend, e * np.sin(w * tau), e * np.cos(w * tau)])
            r = phi @ _solve(phi, y) - y
            sse = float(r @ r)
            if sse < best_sse:
                best_sse, best_omega, best_alpha = sse, w, alpha
    if not (best_sse > 0 and sse0 > best_sse):
        return FrequencySearch(best_omega, 1.0 if sse0 <= best_sse else 0.0, best_alpha)
    f_value = ((sse0 - best_sse) / 2.0) / (best_sse / (n - 5))
    independent = max(1.0, float(cycles[-1] - cycles[0]) if cycles.size > 1 else 1.0) * len(SEARCH_DECAYS)
    p = float(f_distribution.sf(f_value, 2, n - 5))
    return FrequencySearch(best_omega, min(1.0, independent * p), best_alpha)
