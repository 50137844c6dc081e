"""Standard uncertainty of every eigenvalue over a speed sweep, from the parameters' covariance.

An eigenvalue λ at speed v is a root of ``P(s; v, p) = Σ_k a_k(v; p) s^k = det(M s² + v C1 s +
g K0 + v² K2)``; at a simple root the implicit function theorem gives
``∂λ/∂p = −(Σ_k ∂a_k/∂p λ^k) / (Σ_k k a_k λ^(k−1))``, with ``∂a_k/∂p`` from one complex-step
evaluation (no step size tuned). The σ of Re λ and Im λ are ``∇ Σ_p ∇ᵀ`` (paper Eq 3,
correlations kept); near a branch point (two roots merging) σ is NaN. Checked against central
differences and a Monte Carlo in ``test/core/test_eigen_sigma.py``. Eigenvalues and σ in 1/s,
speeds in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..benchmark import ParameterSet
from ..feedback import Feedback
from ..whipple import EigenvalueSweep, WhippleMatrices, canonical_matrices, eigenvalues
from ..whipple.closed_loop import closed_loop_rows
from .matrix_sigma import SigmaConvention, canonical_with_sigma
from .speed_sigma import perturbed_coefficients, perturbed_matrices
from .uncertain import COMPLEX_STEP

__all__ = [
    "BRANCH_POINT_MARGIN",
    "EigenSigma",
    "eigenvalue_gain_gradient",
    "eigenvalue_gradient",
    "eigenvalues_with_sigma",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: σ is reported only where the distance to the nearest other eigenvalue exceeds
#: ``BRANCH_POINT_MARGIN · σ_|λ|`` (6 σ of a separation whose σ is at most 2 σ_|λ|; see
#: :func:`eigenvalues_with_sigma`).
BRANCH_POINT_MARGIN = 12.0


@dataclass(frozen=True)
class EigenSigma:
    """Eigenvalues over speeds with their first-order σ.

    Attributes:
        sweep: Speeds (m/s), tracked and labelled eigenvalues (1/s), as :func:`eigenvalues`.
        sigma_real: σ of ``Re λ``, shape (N, 4), 1/s; NaN near branch points.
        sigma_imag: σ of ``Im λ``, shape (N, 4), 1/s; NaN near branch points.
        gradient: ``∂λ/∂p``, shape (N, 4, 26), PARAMETER_NAMES order (1/s per SI unit).
        convention: Which parameter covariance gave the σ.
    """

    sweep: EigenvalueSweep
    sigma_real: FloatArray
    sigma_imag: FloatArray
    gradient: ComplexArray
    convention: SigmaConvention


def _coefficient_gradient(values: dict[str, float]) -> tuple[FloatArray, FloatArray]:
    """Characteristic-polynomial coefficients ``c[k, j]`` (s^k v^j) and ``∂c/∂p`` (26, 5, 5)."""
    coef = perturbed_coefficients(values)
    return coef[0].real.copy(), coef.imag / COMPLEX_STEP


def _closed_loop_gradient(values: dict[str, float], v: FloatArray, gains: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Closed-loop ``a_k(v)`` (N, 5) and ``∂a_k/∂p`` (N, 26, 5) at fixed gains, by the complex step."""
    mats, g = perturbed_matrices(values)
    column = WhippleMatrices(*(x[:, None] for x in (mats.M, mats.C1, mats.K0, mats.K2)))
    rows, _ = closed_loop_rows(column, g[:, None], v, np.asarray(gains, dtype=float))
    a = np.stack(np.broadcast_arrays(*rows), axis=-1)  # (26, N, 5)
    return a[0].real.copy(), np.transpose(a.imag / COMPLEX_STEP, (1, 0, 2))


def eigenvalue_gradient(
    values: dict[str, float], speeds: ArrayLike, roots: ArrayLike, gains: ArrayLike | None = None
) -> ComplexArray:
    """``∂λ/∂p`` of eigenvalues ``roots`` at ``speeds`` (implicit function theorem).

    Args:
        values: The 26 benchmark parameters (SI, ``lam`` in rad).
        speeds: Speeds, shape (N,), m/s.
        roots: Eigenvalues at those speeds, shape (N, m), 1/s.
        gains: Steer-torque feedback ``[kφ, kδ, kφ̇, kδ̇]`` at the speeds, shape (N, 4), for
            the closed loop's eigenvalues (gains held fixed); None: the open loop.

    Returns:
        Shape (N, m, 26) complex; inf or NaN where a root is double.
    """
    v = np.asarray(speeds, dtype=float)
    lam = np.asarray(roots, dtype=complex)
    if gains is None:
        coef, dcoef = _coefficient_gradient(values)
        vpow = v[:, None] ** np.arange(5)  # (N, 5): v^j
        a = vpow @ coef.T  # (N, 5): a_k(v)
        da = np.einsum("nj,pkj->npk", vpow, dcoef)  # (N, 26, 5): ∂a_k/∂p
    else:
        a, da = _closed_loop_gradient(values, v, gains)
    return _root_gradient(a, da, lam)


def _root_gradient(a: FloatArray, da: FloatArray, lam: ComplexArray) -> ComplexArray:
    """``∂λ/∂x = −(Σ_k ∂a_k/∂x λ^k) / P'(λ)`` from ``a`` (N, 5) and ``∂a/∂x`` (N, X, 5): (N, m, X)."""
    k = np.arange(5)
    spow = lam[..., None] ** k  # (N, m, 5)
    dspow = np.zeros_like(spow)
    dspow[..., 1:] = k[1:] * lam[..., None] ** (k[1:] - 1)
    dp_dlam = np.einsum("nk,nmk->nm", a, dspow)  # P'(λ)
    dp_dp = np.einsum("npk,nmk->nmp", da, spow)  # ∂P/∂p at λ
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(-dp_dp / dp_dlam[..., None])


def eigenvalue_gain_gradient(
    values: dict[str, float], speeds: ArrayLike, roots: ArrayLike, feedback: Feedback
) -> ComplexArray:
    """``∂λ/∂k`` of closed-loop eigenvalues for each feedback gain value given with σ.

    Complex step in the uncertain gain values
    (:meth:`bike_rig.core.feedback.Feedback.knot_jacobian`), then the implicit function theorem.

    Returns:
        Shape (N, m, n), :meth:`~bike_rig.core.feedback.Feedback.uncertain_knots` order.
    """
    v = np.asarray(speeds, dtype=float)
    lam = np.asarray(roots, dtype=complex)
    gains = feedback.gains(v)[:, None, :] + 1j * COMPLEX_STEP * feedback.knot_jacobian(v)  # (N, n, 4)
    rows, _ = closed_loop_rows(canonical_matrices(values), values["g"], v[:, None], gains)
    a_c = np.stack(np.broadcast_arrays(*rows), axis=-1)  # (N, n, 5)
    return _root_gradient(a_c[:, 0].real.copy(), a_c.imag / COMPLEX_STEP, lam)


def _quadratic_form(grad: FloatArray, cov: FloatArray) -> FloatArray:
    with np.errstate(invalid="ignore", over="ignore"):
        var = np.einsum("nmp,pq,nmq->nm", grad, cov, grad)
    return np.sqrt(np.where(var >= 0.0, var, np.nan))


def _nearest_other(lam: ComplexArray) -> FloatArray:
    """Distance from each eigenvalue to the nearest other one at the same speed, 1/s."""
    d = np.abs(lam[:, :, None] - lam[:, None, :])
    idx = np.arange(lam.shape[1])
    d[:, idx, idx] = np.inf
    return np.asarray(d.min(axis=2))


def eigenvalues_with_sigma(
    ps: ParameterSet,
    speeds: ArrayLike,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    feedback: Feedback | None = None,
) -> EigenSigma:
    """Tracked eigenvalues (1/s) at ``speeds`` (m/s) with the σ of their real and imaginary parts.

    Args:
        ps: The parameter set (values and covariance); add a rider first with
            :func:`bike_rig.core.rider.add_rider` for the bicycle with rider.
        speeds: Speeds, m/s (any order, as :func:`eigenvalues`).
        convention: ``correlated``: the full covariance; ``paper``: parameters independent.
        feedback: Steer-torque state feedback: the closed loop's eigenvalues, σ from the
            parameters and from the gain values given with σ (independent). None: the open
            loop.

    Returns:
        The sweep and σ. σ is NaN where the distance d to the nearest other eigenvalue is
        under 6σ of that distance (``d < 12 σ_|λ|``): a draw of the parameters can reach the
        branch point there, where λ is not differentiable (its true spread scales like the
        square root of the parameter error) and the linearisation cannot hold.

    Raises:
        ModelError: Bad speeds or a singular mass matrix.
    """
    convention = SigmaConvention(convention)
    ms = canonical_with_sigma(ps, convention)
    gains = None if feedback is None else feedback.gains(np.asarray(speeds, dtype=float).reshape(-1))
    sweep = eigenvalues(ms.matrices, ms.g, speeds, gains=gains)
    params = ps.parameters if convention is SigmaConvention.CORRELATED else ps.parameters.independent()
    grad = eigenvalue_gradient(ps.parameters.as_dict(), sweep.speeds, sweep.eigenvalues, gains)
    inputs, covariance = grad, params.covariance
    if feedback is not None and feedback.uncertain_knots():
        # the gains given with σ: further independent inputs after the 26 parameters
        gain_grad = eigenvalue_gain_gradient(ps.parameters.as_dict(), sweep.speeds, sweep.eigenvalues, feedback)
        inputs = np.concatenate([grad, gain_grad], axis=2)
        sigmas = np.array([k[2] for k in feedback.uncertain_knots()])
        covariance = np.block(
            [
                [covariance, np.zeros((covariance.shape[0], sigmas.size))],
                [np.zeros((sigmas.size, covariance.shape[0])), np.diag(sigmas**2)],
            ]
        )
    finite: NDArray[np.bool_] = np.asarray(np.isfinite(inputs).all(axis=2))
    g_re = np.where(finite[..., None], inputs.real, 0.0)
    g_im = np.where(finite[..., None], inputs.imag, 0.0)
    s_re = _quadratic_form(g_re, covariance)
    s_im = _quadratic_form(g_im, covariance)
    spread = np.hypot(s_re, s_im)
    valid = finite & (BRANCH_POINT_MARGIN * spread < _nearest_other(sweep.eigenvalues))
    s_re = np.where(valid, s_re, np.nan)
    s_im = np.where(valid, s_im, np.nan)
    return EigenSigma(sweep, s_re, s_im, grad, convention)
