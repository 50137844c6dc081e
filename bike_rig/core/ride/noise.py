"""The noise model of a ride segment: white sensor noise plus the weave driven by the rider.

A ride's roll rate carries the gyro's white noise (σ_w, measured robustly from the signal's
second differences, :func:`bike_rig.core.ride.segment.noise_sigma`) and the rider's small
steering inputs, which keep driving the weave during the "free" decay. Modelled as the weave's
two states driven by isotropic white noise of intensity q from the segment's start t₀, the
driven part's covariance is

    K_ij = ∫_{t₀}^{min(t_i, t_j)} e^{−α(t_i − s) − α(t_j − s)} cos ω_d(t_i − t_j) ds,

and the least-squares estimates' covariance is the sandwich

    C(q) = (JᵀJ)⁻¹ Jᵀ(σ_w² I + q K)J (JᵀJ)⁻¹ = C_w + q C_q

(``JᵀKJ`` by one backward complex first-order filter, O(n p)). Most of a driven weave is
absorbed by the fit (amplitude, phase, α, ω_d), so the drive shows in the residuals only
faintly, yet moves the estimates much: q is estimated from the residuals' block means (blocks
of :data:`BLOCK_PERIODS` weave periods, where the white noise is averaged down and the driven
part is not) by moments, ``q̂ = (Σ r̄_b² − white part) / tr(A(I − P)K(I − P)ᵀAᵀ)``, unbiased and
possibly negative. One segment's q̂ is noisy (where it comes out ≤ 0 the σ of a driven record
would be the white one, several times too small), so segments at one speed share q: the mean
of their q̂ plus :data:`UPPER_SIGMAS` of its σ, clipped at 0
(:func:`bike_rig.core.ride.eigen.pool_drive`); where they scatter about their weighted mean
beyond their σ at that drive, it is raised until they do not (:func:`scatter_drive`: the
moment estimate misses part of a coloured drive, a rider's steering torque, measured up to a
factor 2–5 low on simulated rides). Three segments scatter beyond their σ by chance often, so
the raise needs evidence: the record's scatter over all its speeds, or that speed's own among
the record's speeds, must exceed chance at :data:`SCATTER_P` (:func:`scatter_significant`).
q̂ comes from the Eq 23 + trend fit whatever the model chosen (:mod:`.choice`): Eq 23 leaves
the capsize mode in its residuals, which is no drive, and a free real mode absorbs part of the
drive's trace. The residuals' lag-one correlation gives the samples' worth for the model choice
(:class:`ResidualNoise`). Units: the signal's (rad/s), q in its units² per second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BLOCK_PERIODS",
    "MAX_CONDITION",
    "MAX_RHO",
    "SCATTER_P",
    "UPPER_SIGMAS",
    "DrivenCovariance",
    "ResidualNoise",
    "driven_covariance",
    "inverse_normal_matrix",
    "pooled_drive",
    "residual_noise",
    "scatter_chi2",
    "scatter_drive",
    "scatter_significant",
]

FloatArray = NDArray[np.float64]

#: The largest lag-one correlation used (a random walk has no finite n_eff) [-].
MAX_RHO = 0.995
#: The residuals are averaged over blocks of this many weave periods to see the drive above the white noise [-].
BLOCK_PERIODS = 1.0 / 16.0
#: The drive used is the estimate plus this many of its chance σ (calibrated, test_calibration) [-].
UPPER_SIGMAS = 0.5
#: The shared drive is raised only where the record's segments scatter beyond their σ with a
#: chance below this (simulated rides, two speeds a record: at 0.05 chance scatter still raised
#: a low-drive record's σ, its errors falling to 0.73 σ RMS; at 0.01 they stay at 0.77–0.83 σ
#: while a drive the residuals miss is still raised, errors 0.96–1.45 σ RMS) [-].
SCATTER_P = 0.01
#: A design whose column-scaled Jacobian has a larger condition number does not determine its
#: parameters (``JᵀJ`` would be inverted to rounding noise: σ of 1e-36 or negative variances) [-].
MAX_CONDITION = 1e7


@dataclass(frozen=True)
class ResidualNoise:
    """White noise plus a first-order autoregressive part, for the samples' worth.

    Attributes:
        white: σ_w of the white part [signal units].
        process: σ_p of the correlated part [signal units].
        rho: Its lag-one correlation per sample [-].
    """

    white: float
    process: float
    rho: float

    @property
    def inflation(self) -> float:
        """The variance of a mean over many samples relative to white noise of the same variance [-] (≥ 1)."""
        total = self.white**2 + self.process**2
        if not total > 0:
            return 1.0
        return (self.white**2 + self.process**2 * (1.0 + self.rho) / (1.0 - self.rho)) / total

    def n_eff(self, n: int) -> float:
        """The samples' worth in independent ones [-]."""
        return n / self.inflation


def residual_noise(residuals: FloatArray, white: float, n_params: int) -> ResidualNoise:
    """The residuals as white noise (σ_w given) plus an AR(1) part: its σ from the excess variance, ρ from lag one.

    Args:
        residuals: The fit's residuals.
        white: The sensor's white-noise σ (NaN: taken as all of the residual variance).
        n_params: Parameters fitted (the variance's degrees of freedom are n − n_params).
    """
    n = residuals.size
    dof = max(1, n - n_params)
    var = float(residuals @ residuals) / dof
    w2 = min(white**2, var) if math.isfinite(white) else var
    p2 = var - w2
    if not p2 > 0 or n < 3:
        return ResidualNoise(math.sqrt(var), 0.0, 0.0)
    c1 = float(residuals[:-1] @ residuals[1:]) / dof
    rho = min(MAX_RHO, max(0.0, c1 / p2))
    return ResidualNoise(math.sqrt(w2), math.sqrt(p2), rho)


@dataclass(frozen=True)
class DrivenCovariance:
    """The estimates' covariance as ``C_w + q C_q`` and one segment's estimate of q (module docstring).

    Attributes:
        white: C_w, from the white noise (p × p).
        per_drive: C_q, per unit drive (p × p) [per signal units² s⁻¹].
        drive: The moment estimate q̂ (may be negative; NaN: none) [signal units² / s].
        drive_sigma: Its σ from the white noise alone [signal units² / s].
    """

    white: FloatArray
    per_drive: FloatArray
    drive: float
    drive_sigma: float

    def at(self, q: float) -> FloatArray:
        """The covariance with drive ``q`` (p × p)."""
        return self.white + q * self.per_drive


def inverse_normal_matrix(jac: FloatArray) -> FloatArray:
    """``(JᵀJ)⁻¹`` from the SVD of the column-scaled Jacobian: positive semi-definite by construction.

    Raises:
        numpy.linalg.LinAlgError: A zero column, or a condition number above :data:`MAX_CONDITION`
            (the segment does not determine the parameters).
    """
    scale = np.sqrt(np.sum(jac**2, axis=0))
    if not np.all(np.isfinite(scale)) or not np.all(scale > 0):
        raise np.linalg.LinAlgError("a parameter the record does not change")
    _, s, vt = np.linalg.svd(jac / scale, full_matrices=False)
    if not s[-1] * MAX_CONDITION > s[0]:
        raise np.linalg.LinAlgError(f"condition number {s[0] / s[-1]:.1e}")
    return np.asarray((vt.T / s**2) @ vt / np.outer(scale, scale), dtype=float)


def _block_drive(t: FloatArray, jac: FloatArray, bread: FloatArray, u: FloatArray, z: complex, m: int) -> float:
    """``tr(A(I − P) K (I − P)ᵀAᵀ)``: the drive's variance per unit q in the residuals' block means."""
    n = t.size
    nb = n // m
    lag = (np.arange(nb) * m)[:, None] - np.arange(n)[None, :]  # block start − k
    whole = np.where(lag >= 0, z ** np.maximum(lag, 0) * (1 - z**m) / (1 - z), 0.0)
    part = np.where((lag < 0) & (lag > -m), (1 - z ** np.clip(m + lag, 0, m)) / (1 - z), 0.0)
    a_phi = (whole + part) / m  # (nb, n): the block means of the drive's response φ_k
    a_j = jac[: nb * m].reshape(nb, m, -1).mean(axis=1)  # (nb, p)
    outside = a_phi - a_j @ (bread @ u.T)  # (nb, n): what the fit cannot absorb
    return float(np.sum(np.abs(outside) ** 2)) * float(np.median(np.diff(t)))


def driven_covariance(
    t: FloatArray, jac: FloatArray, residuals: FloatArray, alpha: float, omega_d: float, white: float
) -> DrivenCovariance:
    """``C_w``, ``C_q`` and q̂ of a fit (module docstring).

    Args:
        t: Sample times [s] (about evenly spaced).
        jac: The residuals' Jacobian (n × p).
        residuals: The fit's residuals.
        alpha: The fitted decay rate ζω [1/s].
        omega_d: The fitted ω_d [rad/s].
        white: The sensor's white-noise σ (NaN: all of the residuals are white, no drive).

    Raises:
        numpy.linalg.LinAlgError: A singular or ill-conditioned ``JᵀJ`` (:func:`inverse_normal_matrix`).
    """
    from scipy.signal import lfilter

    n, p = jac.shape
    bread = inverse_normal_matrix(jac)
    sse = float(residuals @ residuals)
    w2 = min(white**2, sse / max(1, n - p)) if math.isfinite(white) else sse / max(1, n - p)
    dt = float(np.median(np.diff(t)))
    z = complex(np.exp(complex(-alpha, omega_d) * dt))
    u = lfilter([1.0], [1.0, -z], jac[::-1].astype(complex), axis=0)[::-1]  # u_k = Σ_{i≥k} J_i z^(i−k)
    jkj = np.real(u.T @ np.conj(u)) * dt
    m = max(1, int(round(BLOCK_PERIODS * 2.0 * math.pi / max(omega_d, 1e-9) / dt)))
    nb = n // m
    q, q_sigma = math.nan, math.nan
    if nb > p and math.isfinite(white):
        a_j = jac[: nb * m].reshape(nb, m, -1).mean(axis=1)
        r_b = residuals[: nb * m].reshape(nb, m).mean(axis=1)
        white_part = w2 * (nb / m - float(np.trace(bread @ (a_j.T @ a_j))))
        drive = _block_drive(t, jac, bread, u, z, m)
        if drive > 0:
            q = (float(r_b @ r_b) - white_part) / drive
            q_sigma = white_part * math.sqrt(2.0 / nb) / drive  # the white part's chance σ in the block sum
    per_drive = np.asarray(bread @ jkj @ bread, dtype=float)
    return DrivenCovariance(np.asarray(w2 * bread, dtype=float), per_drive, q, q_sigma)


def pooled_drive(drives: list[tuple[float, float]]) -> float:
    """The drive shared by segments: the mean of their q̂ plus :data:`UPPER_SIGMAS` of its σ, ≥ 0.

    The mean's σ holds the white noise's chance and the estimates' own scatter (the drive's
    chance, which dominates where the rider steers much).

    Args:
        drives: Each segment's (q̂, σ) [signal units² / s]; non-finite ones are left out.
    """
    ok = [(q, s) for q, s in drives if math.isfinite(q) and math.isfinite(s)]
    if not ok:
        return 0.0
    n = len(ok)
    mean = sum(q for q, _ in ok) / n
    spread = sum((q - mean) ** 2 for q, _ in ok) / (n - 1) if n > 1 else 0.0  # the drive's own scatter
    sigma = math.sqrt(sum(s**2 for _, s in ok) / n**2 + spread / n)
    return max(0.0, mean + UPPER_SIGMAS * sigma)


def scatter_chi2(x: FloatArray, variance: FloatArray, q: float) -> tuple[float, int]:
    """(χ², degrees of freedom) of segments of one eigenvalue about their weighted mean at the drive ``q``.

    Args:
        x: The segments' (Re λ, Im λ) (n × 2) [1/s].
        variance: Their ``(Re fixed, Re per unit drive, Im fixed, Im per unit drive)`` (n × 4).
        q: The drive [signal units² / s].

    Returns:
        Σ over the parts of Σ_i (x_i − x̄)² / σ_i² [-] and its 2 (n − 1) degrees of freedom.
    """
    n = x.shape[0]
    if n < 2:
        return 0.0, 0
    return _scatter_chi2(x, variance[:, [0, 2]], variance[:, [1, 3]], q), 2 * (n - 1)


def scatter_significant(chi2: float, dof: int, tests: int = 1) -> bool:
    """Whether a scatter of ``chi2`` over ``dof`` degrees of freedom exceeds chance at :data:`SCATTER_P`.

    Args:
        chi2: The scatter's χ² [-].
        dof: Its degrees of freedom.
        tests: Scatters tested alike (one of them beyond chance at SCATTER_P / tests, Bonferroni).
    """
    from scipy.stats import chi2 as chi2_dist

    return dof > 0 and bool(chi2_dist.sf(chi2, dof) < SCATTER_P / max(1, tests))


def _scatter_chi2(x: FloatArray, fixed: FloatArray, per_drive: FloatArray, q: float) -> float:
    """Σ over the parts of min_m Σ_i (x_i − m)² / (fixed_i + q per_drive_i) [-]."""
    w = 1.0 / np.maximum(fixed + q * per_drive, 1e-300)
    mean = np.sum(w * x, axis=0) / np.sum(w, axis=0)
    return float(np.sum(w * (x - mean) ** 2))


def scatter_drive(x: FloatArray, variance: FloatArray, q: float) -> float:
    """The drive at least ``q`` at which segments of one eigenvalue scatter as their σ say.

    The segments at one speed measure one eigenvalue; if they scatter about their weighted
    mean by more than their σ at the drive ``q`` allow (χ² above its n − 1 degrees of freedom
    per part), the drive is raised until it does not (Paule and Mandel's estimate of an
    excess variance, here the drive's, whose σ² per unit drive each segment knows). χ² falls as
    q rises, so the root is unique.

    Args:
        x: The segments' (Re λ, Im λ) (n × 2) [1/s].
        variance: Their ``(Re fixed, Re per unit drive, Im fixed, Im per unit drive)`` (n × 4).
        q: The drive from the residuals (:func:`pooled_drive`) [signal units² / s].

    Returns:
        The drive [signal units² / s]: ``q`` where the segments do not scatter beyond it.
    """
    from scipy.optimize import brentq

    n = x.shape[0]
    fixed, per_drive = variance[:, [0, 2]], variance[:, [1, 3]]
    target = 2.0 * (n - 1)
    if n < 2 or not np.all(per_drive > 0) or _scatter_chi2(x, fixed, per_drive, q) <= target:
        return q
    hi = max(q, float(np.max(fixed / per_drive)), 1e-30)
    for _ in range(200):
        if _scatter_chi2(x, fixed, per_drive, hi) <= target:
            return float(brentq(lambda d: _scatter_chi2(x, fixed, per_drive, d) - target, q, hi, xtol=1e-12 * hi))
        hi *= 4.0
    return hi
