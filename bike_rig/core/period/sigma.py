"""σ of the fitted period: the paper's Eq 27 and a drift-robust sandwich estimate.

The paper's Eq 26–27 (``U = σ_y² H⁻¹``, H = JᵀJ) assume independent residuals. A rate gyro's
bias drifts (a random walk) and its samples are quantised, so the residuals are serially
correlated and Eq 27 is optimistic: for the simulated 12-bit gyro with drift, by a factor of 2
to 10 in σ. It is still reported (``period_sigma_white``), but ``period_sigma`` is a sandwich
(autocorrelation-consistent, batch-means) estimate:

``Var(omega_d) = Σ_c (Σ_{i in cycle c} h_i r_i)²``, ``h = gᵀJ`` the influence of each sample on
``omega_d = ω sqrt(1 − ζ²)`` (g the omega_d row of H⁻¹), r the residuals, c over whole cycles.

Within a whole cycle slow drift integrates to almost nothing against the oscillating influence,
so what the per-cycle sums measure is the residual power near the oscillation frequency — the
power that moves the period — whatever its spectrum. Two corrections make it honest:

* the residuals are smaller than the noise by the fit's leverage: the estimate is divided by
  its own expectation under white noise relative to the truth,
  ``1 − Σ_c v_cᵀ H⁻¹ v_c / |h|²`` (``v_c = Σ_{i in c} J_i h_i``);
* with few cycles the estimate is itself uncertain: σ is multiplied by the Student-t factor
  ``t_ν(0.8413)`` for its effective degrees of freedom ν (Satterthwaite, from the per-cycle
  weights), so that ±σ still covers the truth 68 % of the time (GUM Annex G);
* cycles may share a departure the model does not explain (a period that moves late in the
  record): the same sums over about sqrt(cycles) windows of at least two cycles (a linearised
  window jackknife, :func:`window_sandwich`) gather it, and σ is at least theirs;
* σ is never below Eq 27's: serially correlated residuals move the period more than white
  ones, so a smaller sandwich σ (a few cycles' chance) is its estimate's scatter, not the truth.

Whole cycles matter: with a partial last cycle slow drift leaks into the sums. The statistics
use the block means (the influence hardly varies inside a block). T = 2π / omega_d (Eq 25), so
``σ_T = 2π σ(omega_d) / omega_d²``; ζ and ω get their σ from the same sandwich for
(ζω, omega_d) and the exact Jacobian of the map. ``test/core/test_period_sigma.py`` checks the
coverage of ±σ on simulated trials with white noise, a random-walk drift and 12-bit
quantisation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .oscillation import TWO_PI, block_phasors, zeta_omega
from .solver import FitFailed, Solution

__all__ = [
    "BlockDesign",
    "PeriodSigma",
    "cycle_starts",
    "jackknife_windows",
    "period_sigma",
    "sandwich",
    "student_factor",
    "window_sandwich",
]

FloatArray = NDArray[np.float64]

#: Whole cycles per window of the window sandwich, at least.
MIN_JACKKNIFE_CYCLES = 2

#: One-sided normal quantile of a ±1σ interval: Φ(1).
_PHI1 = 0.8413447460685429


@dataclass(frozen=True)
class BlockDesign:
    """The block means the fit was made on, and where its window lies.

    Attributes:
        tb: Block centres [s] (the fit's time axis).
        yb: Block means, scaled to about ±1.
        counts: Samples per block.
        k: Samples per (full) block.
        first: Time of the window's first sample [s].
        center: Time of the window's centre [s].
        step: Sample interval [s].
        uniform: Whether the samples are evenly spaced (the block-mean model is then exact).
    """

    tb: FloatArray
    yb: FloatArray
    counts: FloatArray
    k: int
    first: float
    center: float
    step: float
    uniform: bool


@dataclass(frozen=True)
class PeriodSigma:
    """σ of the fit and the per-cycle sums the quality flags use.

    Attributes:
        sigma: σ of the period T [s]: the sandwich estimate widened by the Student-t factor
            (or Eq 27's when there are too few cycles, see ``white_fallback``).
        sigma_white: σ of T from Eq 27 (white residuals) [s].
        zeta_sigma: σ of ζ [-].
        omega_sigma: σ of ω [rad/s].
        alpha_sigma: σ of the decay rate ζω [1/s] (the measured eigenvalue's real part is −ζω).
        dof: Effective degrees of freedom of ``sigma``.
        white_fallback: Too few cycles for the sandwich: ``sigma`` is Eq 27's.
        score: Σ J_i r_i per whole cycle, 5 × cycles (scaled units).
        per_cycle: Samples per cycle.
        power: Σ |exp(s τ)|² per cycle [-].
    """

    sigma: float
    sigma_white: float
    zeta_sigma: float
    omega_sigma: float
    alpha_sigma: float
    dof: float
    white_fallback: bool
    score: FloatArray
    per_cycle: FloatArray
    power: FloatArray


def _block_residuals(
    sol: Solution, blocks: BlockDesign, e: NDArray[np.complex128], r: FloatArray, units_scale: float
) -> FloatArray:
    """Residual sum per block (scaled units), from the exact block-mean model when uniform."""
    ke = sol.K * e
    if blocks.uniform:  # residual sum per block (scaled): the block-mean model is exact
        rb = blocks.yb - sol.A
        rb -= ke.real
        rb *= blocks.counts
    else:
        rb = np.add.reduceat(r, np.arange(0, r.size, blocks.k))
        rb *= 1.0 / units_scale
    return np.asarray(rb)


def period_sigma(
    sol: Solution, blocks: BlockDesign, r: FloatArray, s2: float, n_cycles: float, units_scale: float
) -> PeriodSigma:
    """σ of the period by Eq 27 and by the per-cycle sandwich (module docstring).

    Args:
        sol: The fit (scaled units).
        blocks: The block means it was made on.
        r: The residual of every sample in the window, in the samples' units.
        s2: Eq 26's residual variance (scaled units).
        n_cycles: Cycles in the window.
        units_scale: Scale of ``r``'s units relative to the scaled units.

    Returns:
        The σ and the per-cycle sums.

    Raises:
        FitFailed: The fit's Hessian is singular.
    """
    n = r.size
    alpha, omega_d, K = sol.alpha, sol.omega_d, sol.K
    s = complex(-alpha, omega_d)
    tb, counts, first = blocks.tb, blocks.counts, blocks.first

    # the design on the block means: per-block Jacobian of the block-mean model
    tau_b = tb - blocks.center
    e = block_phasors(s, tau_b, blocks.step, int(counts[0]), int(counts[-1]), blocks.uniform)
    ke = K * e
    rb = _block_residuals(sol, blocks, e, r, units_scale)
    nb = tb.size
    Jb = np.empty((5, nb))
    Jb[0] = 1.0
    Jb[1] = e.imag
    Jb[2] = e.real
    np.multiply(tau_b, ke.real, out=Jb[3])
    np.multiply(tau_b, ke.imag, out=Jb[4])
    Jb[3:] *= -1.0
    Jc = Jb * counts
    M = Jc @ Jb.T  # H of Eq 27 (JᵀJ), from the blocks
    try:
        G = np.asarray(np.linalg.inv(M), dtype=float)
    except np.linalg.LinAlgError:
        raise FitFailed("the fit's Hessian is singular") from None
    dT = TWO_PI / omega_d**2
    sigma_white = dT * math.sqrt(max(0.0, s2 * float(G[4, 4])))  # Eq 27

    # per whole cycle (in blocks), in one pass: Σ J_i r_i (the score), Σ J_i h_i and Σ h_i²
    # (h: each sample's influence on omega_d), samples, Σ |exp(s τ)|²
    starts = cycle_starts(tb, first, omega_d, n_cycles)
    h = G[4] @ Jb
    rows = np.empty((13, nb))
    np.multiply(Jb, rb, out=rows[:5])
    np.multiply(Jc, h, out=rows[5:10])
    np.multiply(counts, h * h, out=rows[10])
    rows[11] = counts
    np.multiply(counts, e.real**2 + e.imag**2, out=rows[12])
    per_cycle_sums = np.add.reduceat(rows, starts, axis=1)
    score = per_cycle_sums[:5]
    cov2, dof = sandwich(G, score, per_cycle_sums[5:10], per_cycle_sums[10])
    fallback = cov2 is None
    if cov2 is None:
        cov2, dof = s2 * G[3:, 3:], float(n - 5)
    factor = student_factor(dof)
    sigma = dT * math.sqrt(max(0.0, float(cov2[1, 1]))) * factor
    windowed = window_sandwich(G, score, per_cycle_sums[5:10], per_cycle_sums[10])
    if windowed is not None:  # (what the windows scatter beyond the cycles' σ)
        sigma = max(sigma, dT * math.sqrt(max(0.0, float(windowed[1, 1]))))
    sigma = max(sigma, sigma_white)  # (correlated residuals move the period more than white ones, never less)
    _, omega = zeta_omega(alpha, omega_d)
    jac = np.array([[omega_d**2 / omega**3, -alpha * omega_d / omega**3], [alpha / omega, omega_d / omega]])
    zw_cov = jac @ cov2 @ jac.T * factor**2
    return PeriodSigma(
        sigma=sigma,
        sigma_white=sigma_white,
        zeta_sigma=math.sqrt(max(0.0, float(zw_cov[0, 0]))),
        omega_sigma=math.sqrt(max(0.0, float(zw_cov[1, 1]))),
        alpha_sigma=factor * math.sqrt(max(0.0, float(cov2[0, 0]))),
        dof=dof,
        white_fallback=fallback,
        score=score,
        per_cycle=per_cycle_sums[11],
        power=per_cycle_sums[12],
    )


def cycle_starts(tb: FloatArray, first: float, omega: float, n_cycles: float) -> NDArray[np.intp]:
    """The first block of each whole cycle (the last cycle takes a partial one's blocks).

    Args:
        tb: Block centres, s.
        first: Time of the window's first sample, s.
        omega: The oscillation's angular frequency, rad/s.
        n_cycles: Cycles in the window.
    """
    n_blocks = max(1, int(math.floor(n_cycles + 0.25)))
    cycle_of = ((tb - first) * (omega / TWO_PI)).astype(np.intp)
    np.minimum(cycle_of, n_blocks - 1, out=cycle_of)
    starts = np.searchsorted(cycle_of, np.arange(n_blocks))
    return np.asarray(starts[np.diff(np.append(starts, tb.size)) > 0], dtype=np.intp)


def student_factor(dof: float) -> float:
    """``t_ν(Φ(1))``: what widens a σ estimated with ν degrees of freedom to cover 68 %."""
    if not dof < 1e6:
        return 1.0
    from scipy.special import stdtrit  # here: importing scipy.special takes ~0.15 s

    return float(stdtrit(dof, _PHI1))


def sandwich(
    G: FloatArray, score: FloatArray, v: FloatArray, e: FloatArray, first: int = 3
) -> tuple[FloatArray | None, float]:
    """Covariance of the nonlinear parameters from the per-cycle score sums, and its degrees of freedom.

    Args:
        G: H⁻¹ (p × p); the parameters from ``first`` on are reported, the last is the one
            whose influence ``h`` is.
        score: Σ J_i r_i per cycle, p × cycles.
        v: Σ J_i h_i per cycle (h the influence of each sample on the last parameter,
            omega_d), p × cycles.
        e: Σ h_i² per cycle.
        first: The first parameter reported (Eq 23's fit: 3, i.e. (ζω, omega_d)).

    Returns:
        The covariance of the parameters from ``first`` on (Eq 23's fit: (ζω [1/s], omega_d
        [rad/s])) and ν, or (None, 0) with fewer than two cycles or too little independent
        information.
    """
    if score.shape[1] < 2:
        return None, 0.0
    rows = G[first:] @ score  # per-cycle contributions to the estimates
    cov = rows @ rows.T
    expected = e - np.einsum("ic,ic->c", v, G @ v)  # E[contribution_c²] / σ² under white noise
    total = float(np.sum(expected))
    e_total = float(np.sum(e))
    if not total > 0.05 * e_total:
        return None, 0.0
    dof = total**2 / float(np.dot(expected, expected))
    return cov * (e_total / total), max(1.0, dof)


def jackknife_windows(cycles: int) -> NDArray[np.intp] | None:
    """The first cycle of each window of the window sandwich, or None for fewer than two windows.

    About sqrt(cycles) windows of at least ``MIN_JACKKNIFE_CYCLES`` whole cycles each: long
    enough to gather a slow departure from the model, many enough to estimate its scatter.
    """
    windows = min(cycles // MIN_JACKKNIFE_CYCLES, round(math.sqrt(cycles)))
    if windows < 2:
        return None
    size, extra = divmod(cycles, windows)
    return np.asarray(np.arange(windows) * size + np.minimum(np.arange(windows), extra), dtype=np.intp)


def window_sandwich(
    G: FloatArray, score: FloatArray, v: FloatArray, e: FloatArray, first: int = 3
) -> FloatArray | None:
    """:func:`sandwich` over windows of whole cycles (:func:`jackknife_windows`): a window jackknife.

    Summing the per-cycle contributions over each window before squaring is the linearised
    leave-one-window-out jackknife of the estimates: cycles whose departures from the model
    share a sign within a window (a period change the model does not explain) add up, where
    the per-cycle sandwich counts them as independent. Under the model it has the per-cycle
    sandwich's expectation, with fewer degrees of freedom.

    Returns:
        The covariance of the parameters from ``first`` on, or None with fewer than two windows.
    """
    starts = jackknife_windows(score.shape[1])
    if starts is None:
        return None
    cov, _ = sandwich(
        G,
        np.add.reduceat(score, starts, axis=1),
        np.add.reduceat(v, starts, axis=1),
        np.add.reduceat(e, starts),
        first,
    )
    return cov
