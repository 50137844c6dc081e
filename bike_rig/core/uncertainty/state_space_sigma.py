"""Standard uncertainty of the first-order model ``ẋ = A x + B u`` at one speed.

``A = [[0, I], [−M⁻¹(g K0 + v² K2), −M⁻¹ v C1]]``, ``B = [[0], [M⁻¹]]`` are analytic in the 26
parameters, so one complex-step evaluation gives the Jacobian of every entry and
``σ² = diag(J Σ_p Jᵀ)`` (paper Eq 3). Under feedback, gains given with σ are further
independent inputs: ``∂(A − B K)/∂k_n = −B[:, 1] ∂K/∂k_n``. A in 1/s and 1/s², B in 1/(kg m²),
σ alike; speed in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..benchmark import ParameterSet
from ..errors import ModelError
from ..feedback import Feedback
from ..whipple import state_space
from ..whipple.closed_loop import closed_loop_state_space
from .matrix_sigma import SigmaConvention
from .speed_sigma import perturbed_matrices
from .uncertain import COMPLEX_STEP

__all__ = ["StateSpaceSigma", "state_space_sigma"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StateSpaceSigma:
    """A and B at one speed with the σ of every entry.

    Attributes:
        speed: m/s.
        a: A (or the closed loop's A − B K), shape (4, 4), 1/s and 1/s².
        b: B, shape (4, 2), 1/(kg m²).
        a_sigma: σ of every entry of ``a``, same layout and units.
        b_sigma: σ of every entry of ``b``, same layout and units.
    """

    speed: float
    a: FloatArray
    b: FloatArray
    a_sigma: FloatArray
    b_sigma: FloatArray


def _sigma(jacobian: FloatArray, covariance: FloatArray) -> FloatArray:
    """``sqrt(diag(J Σ Jᵀ))`` for ``J`` of shape (outputs, inputs)."""
    var = np.einsum("ip,pq,iq->i", jacobian, covariance, jacobian)
    return np.asarray(np.sqrt(np.clip(var, 0.0, None)))


def state_space_sigma(
    ps: ParameterSet,
    speed: float,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    feedback: Feedback | None = None,
) -> StateSpaceSigma:
    """A, B of ``ps`` at ``speed`` (m/s) with first-order σ from the parameter covariance.

    Args:
        ps: The parameter set (add a rider first with :func:`bike_rig.core.rider.add_rider`).
        speed: Forward speed, m/s.
        convention: ``correlated``: the full covariance; ``paper``: parameters independent.
        feedback: Steer-torque state feedback: A is the closed loop's ``A − B K`` and its σ
            include the gain values given with σ. None: the open loop.

    Returns:
        The values (equal to :func:`bike_rig.core.whipple.state_space` on the canonical
        matrices) and their σ.

    Raises:
        ModelError: The speed is not finite or the mass matrix is singular.
    """
    v = float(speed)
    if not np.isfinite(v):
        raise ModelError(f"speed must be a finite number, got {speed}")
    convention = SigmaConvention(convention)
    mats, g = perturbed_matrices(ps.parameters.as_dict())
    g3 = g[:, None, None]
    if feedback is None:
        a, b = state_space(mats, v, g3)
    else:
        a, b = closed_loop_state_space(mats, v, g3, feedback.gains(v))
    n = a.shape[0]
    jac_a = (a.imag / COMPLEX_STEP).reshape(n, 16).T  # (16, 26)
    jac_b = (b.imag / COMPLEX_STEP).reshape(n, 8).T  # (8, 26)
    params = ps.parameters if convention is SigmaConvention.CORRELATED else ps.parameters.independent()
    a_var = _sigma(jac_a, params.covariance) ** 2
    a0, b0 = a[0].real.copy(), b[0].real.copy()
    if feedback is not None and feedback.uncertain_knots():
        sigmas = np.array([k[2] for k in feedback.uncertain_knots()])
        dk = feedback.knot_jacobian(v)  # (n_knots, 4): ∂[kφ, kδ, kφ̇, kδ̇]/∂ each value
        da = -b0[:, 1][None, :, None] * dk[:, None, :]  # (n_knots, 4, 4)
        a_var = a_var + np.einsum("n,nij->ij", sigmas**2, da**2).ravel()
    return StateSpaceSigma(v, a0, b0, np.sqrt(a_var).reshape(4, 4), _sigma(jac_b, params.covariance).reshape(4, 2))
