"""An autoregressive model of a record's noise, and the whitening it gives a least-squares fit.

The riding before a push (the weave driven by the rider's steering, plus the gyro's white
noise) is coloured at the weave's own frequency; a decay fitted to the push's response by
ordinary least squares treats it as white. An AR(p) model ``x_t = Σ_k φ_k x_{t−k} + e_t`` of
that riding (forward–backward least squares on the mean-removed stretch: Yule–Walker's biased
autocovariance underestimates a lightly damped resonance) turns the fit into generalised least
squares: the residual ``r`` is whitened exactly (the model's Gaussian likelihood, no sample
dropped): its first p samples by the Cholesky factor of their stationary covariance
``toeplitz(γ₀…γ_{p−1})`` (from φ and σ_e² by the Yule–Walker equations), the rest by the
prediction error ``(r_t − Σ φ_k r_{t−k}) / σ_e``. The order is the one of least BIC
``N ln σ_e²(p) + p ln N`` over 0…``max_order`` (all orders predict the same N samples), among
stable models (roots inside :data:`MAX_ROOT`). An order of 0 (white noise), or a stretch too
short to identify a model (:data:`MIN_SAMPLES_PER_ORDER`), gives no model: the fit stays
ordinary. The gain is bounded by how well a few seconds of riding fix the colour: where the
noise's poles are the decay's own, an error in them moves the whitened model much. Units:
those of the record (the model is scale-free).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

__all__ = ["MIN_SAMPLES_PER_ORDER", "NoiseAR", "fit_noise_ar"]

FloatArray = NDArray[np.float64]

#: A stretch needs this many samples per AR order tried (and at least twice that overall).
MIN_SAMPLES_PER_ORDER = 10
#: The AR polynomial's roots must lie inside this radius (a stable, not nearly periodic model).
MAX_ROOT = 0.999


@dataclass(frozen=True)
class NoiseAR:
    """An AR(p) noise model (module docstring).

    Attributes:
        coef: φ₁…φ_p [-].
        sigma: The innovation σ_e [units of the record].
        acov: The stationary autocovariance γ₀…γ_{p−1} [units²].
    """

    coef: FloatArray
    sigma: float
    acov: FloatArray

    @property
    def order(self) -> int:
        """The order p."""
        return int(self.coef.size)

    @cached_property
    def _head_factor(self) -> FloatArray:
        """The lower Cholesky factor of the first p samples' covariance ``toeplitz(γ₀…γ_{p−1})``."""
        from scipy.linalg import cholesky, toeplitz

        return np.asarray(cholesky(toeplitz(self.acov), lower=True), dtype=float)

    def whiten(self, r: FloatArray) -> FloatArray:
        """The residual ``r`` whitened along its first axis (module docstring).

        Unit-variance white noise where ``r`` is this noise; ``r`` of shape (n,) or (n, k).
        """
        from scipy.linalg import solve_triangular
        from scipy.signal import lfilter

        p = min(self.order, r.shape[0])
        head = r[:p]
        if p:  # (a leading block of the factor is the factor of the leading block)
            head = solve_triangular(self._head_factor[:p, :p], head, lower=True)
        tail = np.asarray(lfilter(np.r_[1.0, -self.coef], [1.0], r, axis=0), dtype=float)[p:] / self.sigma
        return np.asarray(np.concatenate([head, tail]), dtype=float)


def _stationary_acov(phi: FloatArray, var: float) -> FloatArray:
    """γ₀…γ_p of the AR with coefficients ``phi`` and innovation variance ``var`` (its Yule–Walker equations)."""
    p = phi.size
    m = np.eye(p + 1)
    for k in range(p + 1):
        for j in range(1, p + 1):
            m[k, abs(k - j)] -= phi[j - 1]
    return np.asarray(np.linalg.solve(m, np.r_[var, np.zeros(p)]), dtype=float)


def _fit(x: FloatArray, p: int, skip: int) -> tuple[FloatArray, float]:
    """φ and σ_e² of the forward–backward least-squares AR(p) fit, predicting the samples ``skip`` from each end."""
    n = x.size
    forward = np.column_stack([x[skip - j : n - j] for j in range(1, p + 1)])
    backward = np.column_stack([x[j : n - skip + j] for j in range(1, p + 1)])
    target = np.r_[x[skip:], x[: n - skip]]
    design = np.vstack([forward, backward])
    phi = np.linalg.lstsq(design, target, rcond=None)[0]
    return np.asarray(phi, dtype=float), float(np.mean((target - design @ phi) ** 2))


def fit_noise_ar(x: FloatArray, max_order: int) -> NoiseAR | None:
    """The AR model of evenly sampled noise ``x`` (module docstring), or None (white or not identifiable)."""
    n = x.size
    if max_order < 1 or not np.all(np.isfinite(x)):
        return None
    orders = min(max_order, n // MIN_SAMPLES_PER_ORDER - 1)
    if orders < 1:
        return None
    x = x - np.mean(x)
    white = float(np.mean(np.r_[x[orders:], x[: n - orders]] ** 2))
    if not white > 0:
        return None
    count = 2 * (n - orders)
    best: tuple[float, FloatArray, float] = (count * math.log(white), np.empty(0), white)
    for p in range(1, orders + 1):
        phi, var = _fit(x, p, orders)
        if not var > 0 or np.max(np.abs(np.roots(np.r_[1.0, -phi]))) >= MAX_ROOT:
            continue
        bic = count * math.log(var) + p * math.log(count)
        if bic < best[0]:
            best = (bic, phi, var)
    _, phi, var = best
    if not phi.size:
        return None
    gamma = _stationary_acov(phi, var)
    if not np.all(np.isfinite(gamma)) or not gamma[0] > 0:
        return None
    return NoiseAR(phi, math.sqrt(var), gamma[: phi.size].copy())
