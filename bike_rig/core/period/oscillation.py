"""The paper's decaying oscillation (Eq 23), its period (Eq 25) and fit variance (Eq 26–27).

The fitter works internally with the decay rate ``alpha = ζω`` [1/s] and the damped angular
frequency ``omega_d = ω sqrt(1 − ζ²)`` [rad/s]: Eq 23 is then
``A + Re(K exp((−alpha + i omega_d) t))`` with ``K = C − iB``, the period is simply
``T = 2π / omega_d`` and its variance needs only the variance of ``omega_d``. The map
``(alpha, omega_d) ↔ (ζ, ω)`` is one-to-one for ``|ζ| < 1``, so this is the same fit and, to
first order, the same propagated σ as the paper's.

The mean over a block of k evenly spaced samples of ``exp(s t)`` is exactly
``g_k(s) exp(s t̄)`` (:func:`block_gain`, :func:`block_phasors`), so block means of Eq 23 follow
Eq 23 with the same parameters.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "TWO_PI",
    "alpha_omega_d",
    "block_gain",
    "block_phasors",
    "damped_cosine",
    "damped_cosine_even",
    "damped_oscillation",
    "damped_period",
    "fit_variance",
    "zeta_omega",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

TWO_PI = 2.0 * math.pi


def damped_oscillation(t: ArrayLike, A: float, B: float, C: float, zeta: float, omega: float) -> FloatArray:
    """Eq 23: ``f(t) = A + exp(−ζωt) [B sin(sqrt(1 − ζ²) ω t) + C cos(sqrt(1 − ζ²) ω t)]``.

    Args:
        t: Time since the fit's reference time [s].
        A: Offset, in the units of the samples (rad/s or V).
        B: Sine amplitude at t = 0, same units.
        C: Cosine amplitude at t = 0, same units.
        zeta: Damping ratio ζ, |ζ| < 1 [-].
        omega: Undamped natural angular frequency ω [rad/s].

    Returns:
        f(t), same units as A.
    """
    tt = np.asarray(t, dtype=float)
    omega_d = omega * math.sqrt(1.0 - zeta * zeta)
    return A + np.exp(-zeta * omega * tt) * (B * np.sin(omega_d * tt) + C * np.cos(omega_d * tt))


def damped_period(zeta: float, omega: float) -> float:
    """Eq 25 (as the physics has it; the printed equation misplaces the square root).

    ``T = 2π / (ω sqrt(1 − ζ²))`` [s], for the damping ratio ζ [-] and natural angular
    frequency ω [rad/s].
    """
    return TWO_PI / (omega * math.sqrt(1.0 - zeta * zeta))


def fit_variance(measured: ArrayLike, predicted: ArrayLike, n_parameters: int = 5) -> float:
    """Eq 26: the variance of the fit, ``σ_y² = Σ (y_m − ȳ_m)² − (y_p − ȳ_m)² / (N − 5)``.

    At a least-squares optimum of a model with an offset this equals the residual sum of squares
    over ``N − 5``, which is what the fitter computes directly.
    """
    ym = np.asarray(measured, dtype=float)
    yp = np.asarray(predicted, dtype=float)
    mean = float(np.mean(ym))
    return float((np.sum((ym - mean) ** 2) - np.sum((yp - mean) ** 2)) / (ym.size - n_parameters))


def zeta_omega(alpha: float, omega_d: float) -> tuple[float, float]:
    """(ζ, ω) from the decay rate ``alpha = ζω`` [1/s] and damped frequency ``omega_d`` [rad/s]."""
    omega = math.hypot(alpha, omega_d)
    return (alpha / omega if omega > 0 else math.nan), omega


def alpha_omega_d(zeta: float, omega: float) -> tuple[float, float]:
    """The decay rate ``ζω`` [1/s] and damped frequency ``ω sqrt(1 − ζ²)`` [rad/s]."""
    return zeta * omega, omega * math.sqrt(1.0 - zeta * zeta)


def damped_cosine(tau: FloatArray, s: complex, K: complex) -> FloatArray:
    """``Re(K exp(s τ))`` for every τ [s]: Eq 23 without A (``s = −ζω + iω sqrt(1 − ζ²)``)."""
    return (K * np.exp(s * tau)).real


def damped_cosine_even(tau0: float, step: float, n: int, s: complex, K: complex, A: float = 0.0) -> FloatArray:
    """``A + Re(K exp(s τ))`` at the n evenly spaced times ``τ = τ0 + k·step`` [s].

    Built from two short exponential tables (``exp(s τ) = coarse[i] · fine[j]``) and one rank-3
    matrix product: ten times faster than ``np.exp`` on the whole array, accurate to a few ulp.
    """
    if n < 64:
        return A + damped_cosine(tau0 + step * np.arange(n, dtype=float), s, K)
    m = int(math.isqrt(n - 1)) + 1
    rows = -(-n // m)
    fine = np.exp((s * step) * np.arange(m))
    coarse = K * np.exp(s * (tau0 + (step * m) * np.arange(rows)))
    left = np.stack([coarse.real, -coarse.imag, np.full(rows, A)], axis=1)  # rows × 3
    right = np.stack([fine.real, fine.imag, np.ones(m)])  # 3 × m
    return (left @ right).ravel()[:n]


def block_phasors(s: complex, tau: FloatArray, step: float, k: int, k_last: int, even: bool) -> ComplexArray:
    """Means of ``exp(s t)`` over blocks of k samples (the last of k_last) centred at ``tau``.

    They are ``g_k(s) exp(s τ)`` (:func:`block_gain`), exact for evenly spaced samples
    (``even``; ``step`` the interval). Then the blocks of equal length are evenly spaced too,
    and the phasors come from short tables and one outer product when there are many.

    Args:
        s: ``−ζω + iω sqrt(1 − ζ²)`` [1/s].
        tau: Block centres [s].
        step: Sample interval [s].
        k: Samples per block.
        k_last: Samples in the last block.
        even: Whether the samples (and so the blocks) are evenly spaced.

    Returns:
        The block means of ``exp(s t)`` [-], one per block.
    """
    n = tau.size
    gain = block_gain(s, k, step)
    if even and n >= 64:
        m = int(math.isqrt(n - 1)) + 1
        spacing = k * step
        fine = np.exp((s * spacing) * np.arange(m))
        coarse = np.exp(s * (tau[0] + (spacing * m) * np.arange(-(-n // m))))
        coarse *= gain
        z = np.multiply.outer(coarse, fine).ravel()[:n]
        z[-1] = cmath.exp(s * tau[-1]) * block_gain(s, k_last, step)  # the last block: its own centre and length
        return z
    z = np.exp(s * tau)
    z *= gain
    if k_last != k:
        z[-1] *= block_gain(s, k_last, step) / gain
    return z


def block_gain(s: complex, k: int, step: float) -> complex:
    """``g_k(s) = sinh(k s Δt/2) / (k sinh(s Δt/2))`` [-], ``Δt = step`` [s].

    The mean of ``exp(s t)`` over a block of k samples ``Δt`` apart, relative to its value at
    the block's centre (``s`` in 1/s).
    """
    x = s * step
    if k <= 1 or abs(x) < 1e-12:
        return 1.0 + 0j
    return cmath.sinh(k * x / 2) / (k * cmath.sinh(x / 2))
