"""Standard uncertainty of the weave and capsize speeds, from the parameters' covariance.

The critical speeds are roots of ``F(v, p) = 0`` in the coefficients ``a_k(v; p)`` of
``det(M s² + v C1 s + g K0 + v² K2)``: capsize ``F = a0`` (a real root through 0), weave the
Hurwitz determinant ``F = a3 a2 a1 − a4 a1² − a0 a3²`` (a pair through ±iω). At a simple root
``∂v/∂p = −(∂F/∂p) / (∂F/∂v)`` (implicit function theorem; ∂F/∂p by one complex step), and
``σ_v² = ∇v Σ_p ∇vᵀ`` (paper Eq 3, correlations kept). Checked against central differences and a
Monte Carlo in ``test/core/test_speed_sigma.py``. Speeds and their σ in m/s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..benchmark import ParameterSet
from ..feedback import Feedback
from ..symbols import PARAMETER_NAMES
from ..whipple import (
    CriticalSpeeds,
    WhippleMatrices,
    canonical_matrices,
    characteristic_polynomial,
    critical_speeds,
    hurwitz_determinant,
)
from ..whipple.closed_loop import closed_loop_critical_speeds, closed_loop_rows
from .matrix_sigma import MatrixSet, SigmaConvention, canonical_with_sigma
from .uncertain import COMPLEX_STEP

__all__ = [
    "CrossingKind",
    "CriticalSpeedsWithSigma",
    "SpeedWithSigma",
    "closed_loop_speed_gradients",
    "critical_speed_gradient",
    "critical_speeds_with_sigma",
    "perturbed_coefficients",
    "perturbed_matrices",
]

FloatArray = NDArray[np.float64]


class CrossingKind(str, Enum):
    """Which condition defines a critical speed (the ``kind`` of a whipple ``Crossing``)."""

    #: A real eigenvalue through ``s = 0``: ``a0(v) = 0`` (capsize).
    REAL = "real"
    #: A complex pair through ``±iω``: Hurwitz determinant ``H(v) = 0`` (weave).
    OSCILLATORY = "oscillatory"


@dataclass(frozen=True)
class SpeedWithSigma:
    """A critical speed with its standard uncertainty.

    Attributes:
        speed: The speed, m/s.
        sigma: Its standard uncertainty, m/s (NaN if the root is not simple).
        gradient: ∂speed/∂p for the 26 parameters in PARAMETER_NAMES order (m/s per SI unit
            of each parameter); None when not known (e.g. read back from a message).
        gain_gradient: For a closed loop, ∂speed/∂ each feedback gain value given with σ
            (:meth:`bike_rig.core.feedback.Feedback.uncertain_knots` order; m/s per N m/rad or
            N m s/rad); their variance is in ``sigma``. None for the open loop.
    """

    speed: float
    sigma: float
    gradient: FloatArray | None = None
    gain_gradient: FloatArray | None = None


@dataclass(frozen=True)
class CriticalSpeedsWithSigma:
    """Weave and capsize speeds with σ.

    Attributes:
        weave: The weave speed, or None when the bicycle has none.
        capsize: The capsize speed, or None.
        speeds: The underlying crossings (:func:`critical_speeds`).
        convention: Which parameter covariance gave the σ.
    """

    weave: SpeedWithSigma | None
    capsize: SpeedWithSigma | None
    speeds: CriticalSpeeds
    convention: SigmaConvention


def perturbed_matrices(values: Mapping[str, float]) -> tuple[WhippleMatrices, NDArray[np.complex128]]:
    """Canonical matrices (batch (26,)) and ``g`` with parameter ``k`` perturbed by ``i h`` in row ``k``.

    Args:
        values: The 26 benchmark parameters (SI, ``lam`` in rad).

    Returns:
        The complex matrices and gravity (m/s², shape (26,)); ``Im / h`` of anything computed
        from them analytically is its derivative by each parameter (complex step).
    """
    n = len(PARAMETER_NAMES)
    step = np.eye(n) * COMPLEX_STEP
    args = {name: float(values[name]) + 1j * step[k] for k, name in enumerate(PARAMETER_NAMES)}
    return canonical_matrices(args), np.asarray(args["g"])


def perturbed_coefficients(values: Mapping[str, float]) -> NDArray[np.complex128]:
    """Characteristic-polynomial coefficients with each parameter perturbed by ``i h`` in turn.

    Row ``k`` is :func:`characteristic_polynomial` of the parameters with ``p_k + i h``
    (``h`` = :data:`COMPLEX_STEP`): its real part is the coefficients, its imaginary part / h
    their exact derivative by ``p_k`` (complex step), for any function of them evaluated on the
    whole complex array.

    Args:
        values: The 26 benchmark parameters (SI, ``lam`` in rad).

    Returns:
        Shape (26, 5, 5): parameter (PARAMETER_NAMES order), power of ``s``, power of ``v``.
    """
    matrices, g = perturbed_matrices(values)
    return np.asarray(characteristic_polynomial(matrices, g).coefficients)


def _criterion(coef: NDArray[Any], v: float, kind: CrossingKind) -> tuple[NDArray[Any], NDArray[Any]]:
    """``F(v)`` and ``∂F/∂v`` from characteristic-polynomial coefficients ``coef[..., k, j]``."""
    powers = np.array([1.0, v, v**2, v**3, v**4])
    dpowers = np.array([0.0, 1.0, 2.0 * v, 3.0 * v**2, 4.0 * v**3])
    a = coef @ powers  # a_k(v), shape (..., 5), index k = power of s
    da = coef @ dpowers
    if kind is CrossingKind.REAL:
        return a[..., 0], da[..., 0]
    h, dh = hurwitz_determinant([a[..., k] for k in range(5)], [da[..., k] for k in range(5)])
    return h, dh


def critical_speed_gradient(values: Mapping[str, float], speed: float, kind: CrossingKind | str) -> FloatArray:
    """``∂v/∂p`` of a critical speed by the implicit function theorem.

    Args:
        values: The 26 benchmark parameters (SI, ``lam`` in rad).
        speed: A simple root ``v`` (m/s) of the condition of ``kind``.
        kind: ``"real"`` (capsize: ``a0 = 0``) or ``"oscillatory"`` (weave: ``H = 0``).

    Returns:
        The gradient, shape (26,), PARAMETER_NAMES order; NaN where ``∂F/∂v = 0`` (a double
        root, whose speed is not differentiable).
    """
    kind = CrossingKind(kind)
    n = len(PARAMETER_NAMES)
    coef = perturbed_coefficients(values)
    f, _ = _criterion(coef, float(speed), kind)
    df_dp = np.asarray(f).imag / COMPLEX_STEP
    _, df_dv = _criterion(coef[0].real, float(speed), kind)
    dv = float(df_dv)
    if dv == 0.0 or not math.isfinite(dv):
        return np.full(n, math.nan)
    return np.asarray(-df_dp / dv, dtype=float)


def closed_loop_speed_gradients(
    values: Mapping[str, float], speed: float, kind: CrossingKind | str, feedback: Feedback
) -> tuple[FloatArray, FloatArray]:
    """``∂v/∂p`` and ``∂v/∂k`` of a closed-loop critical speed (implicit function theorem).

    As :func:`critical_speed_gradient` with ``F`` the closed loop's ``a0`` or Hurwitz
    determinant (:func:`bike_rig.core.whipple.closed_loop.closed_loop_rows`): the complex step
    in the 26 parameters, then in each gain value given with σ
    (:meth:`bike_rig.core.feedback.Feedback.knot_jacobian`); ``∂F/∂v`` includes the gains'
    slope ``dK/dv`` (of the schedule piece above ``speed``).

    Returns:
        ``∂v/∂p``, shape (26,), PARAMETER_NAMES order, and ``∂v/∂k``, shape ``(n,)``,
        :meth:`~bike_rig.core.feedback.Feedback.uncertain_knots` order; NaN where
        ``∂F/∂v = 0``.
    """
    kind = CrossingKind(kind)
    v = float(speed)
    gains, slopes = feedback.gains(v), feedback.slopes(v)

    def criterion(matrices: WhippleMatrices, g: Any, k: Any) -> tuple[Any, Any]:
        a, da = closed_loop_rows(matrices, g, v, k, slopes)
        return (a[0], da[0]) if kind is CrossingKind.REAL else hurwitz_determinant(a, da)

    f_p, df = criterion(*perturbed_matrices(values), gains)
    n = len(feedback.uncertain_knots())
    f_k = np.zeros(0)
    if n:
        moved = gains + 1j * COMPLEX_STEP * feedback.knot_jacobian(v)
        f_k, _ = criterion(canonical_matrices(values), values["g"], moved)
    dv = float(np.asarray(df).real.reshape(-1)[0])
    if dv == 0.0 or not math.isfinite(dv):
        return np.full(len(PARAMETER_NAMES), math.nan), np.full(n, math.nan)
    df_dp = np.asarray(f_p).imag / COMPLEX_STEP
    df_dk = np.asarray(f_k).imag / COMPLEX_STEP
    return np.asarray(-df_dp / dv, dtype=float), np.asarray(-df_dk / dv, dtype=float)


def _with_sigma(
    values: Mapping[str, float],
    speed: float | None,
    kind: CrossingKind,
    covariance: FloatArray,
    feedback: Feedback | None = None,
) -> SpeedWithSigma | None:
    if speed is None:
        return None
    gain_grad, gain_var = None, 0.0
    if feedback is None:
        grad = critical_speed_gradient(values, speed, kind)
    else:
        grad, gain_grad = closed_loop_speed_gradients(values, speed, kind, feedback)
        sigmas = np.array([k[2] for k in feedback.uncertain_knots()])
        gain_var = float(np.sum((gain_grad * sigmas) ** 2))  # the gains' σ: independent inputs
    var = float(grad @ covariance @ grad) + gain_var
    return SpeedWithSigma(float(speed), math.sqrt(var) if var >= 0.0 else math.nan, grad, gain_grad)


def critical_speeds_with_sigma(
    ps: ParameterSet,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    matrices: MatrixSet | None = None,
    v_max: float = math.inf,
    feedback: Feedback | None = None,
) -> CriticalSpeedsWithSigma:
    """Weave and capsize speeds (m/s) of a parameter set with their σ (m/s).

    Args:
        ps: The parameter set (values and covariance).
        convention: ``correlated``: the full parameter covariance; ``paper``: the parameters
            taken as independent (the convention of the paper's Table 3).
        matrices: The set's canonical matrices if already computed
            (:func:`canonical_with_sigma`); the speeds are found from exactly these, so they
            equal ``critical_speeds(matrices.matrices, matrices.g)``.
        v_max: Only crossings in ``(0, v_max]`` count (m/s).
        feedback: Steer-torque state feedback: the speeds are the closed loop's
            (:func:`bike_rig.core.whipple.closed_loop.closed_loop_critical_speeds`), σ from the
            parameters and from the gain values given with σ (independent). None: the open loop.

    Returns:
        The speeds with σ; ``weave``/``capsize`` are None when absent.
    """
    convention = SigmaConvention(convention)
    ms = matrices if matrices is not None else canonical_with_sigma(ps, convention)
    if feedback is None:
        cs = critical_speeds(ms.matrices, ms.g, v_max)
    else:
        cs = closed_loop_critical_speeds(ms.matrices, ms.g, feedback, v_max)
    params = ps.parameters if convention is SigmaConvention.CORRELATED else ps.parameters.independent()
    values = ps.parameters.as_dict()
    return CriticalSpeedsWithSigma(
        weave=_with_sigma(values, cs.weave, CrossingKind.OSCILLATORY, params.covariance, feedback),
        capsize=_with_sigma(values, cs.capsize, CrossingKind.REAL, params.covariance, feedback),
        speeds=cs,
        convention=convention,
    )
