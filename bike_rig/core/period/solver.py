"""The least-squares solvers of the period fit: Eq 23 fitted by variable projection and Gauss–Newton.

* :func:`varpro` fits the block means (stage 4 of :mod:`~bike_rig.core.period.fit`). For fixed
  (ζω, ω sqrt(1 − ζ²)) Eq 23 is linear in A, B, C, which are solved for; Levenberg–Marquardt
  (:mod:`~bike_rig.core.period.lm`) fits the two nonlinear parameters with the analytic
  (Kaufman) Jacobian of the projected residual, until neither moves by 1e-3 of its σ.
* :func:`gauss_newton` finishes the fit on every sample when the timestamps are uneven (stage 5),
  with the analytic Jacobian of all five parameters.

Both work in the fit's scaled units (samples about ±1) with t from the window centre [s], and
raise :class:`FitFailed` when the fit does not converge to an oscillation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .lm import Stop, minimise
from .oscillation import block_phasors

__all__ = ["FitFailed", "Solution", "gauss_newton", "inverse3", "varpro"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: The variable-projection fit stops when Σ r² falls by less than this fraction of itself, or
#: when neither nonlinear parameter moves by more than ``_STEP_SIGMA`` of its σ (:mod:`.lm`).
_REL_TOL = 1e-4
_STEP_SIGMA = 1e-3


class FitFailed(Exception):
    """The solver did not converge to an oscillation; the message says why (for a flag)."""


@dataclass
class Solution:
    """The fit in the scaled units, t from the window centre.

    Attributes:
        alpha: ζω [1/s].
        omega_d: ω sqrt(1 − ζ²) [rad/s].
        A: Offset, scaled units.
        K: C − iB at the centre time, scaled units.
    """

    alpha: float  # ζω [1/s]
    omega_d: float  # ω sqrt(1 − ζ²) [rad/s]
    A: float
    K: complex  # C − iB at the centre time


def inverse3(a: float, b: float, c: float, d: float, e: float, f: float) -> tuple[tuple[float, float, float], ...]:
    """Inverse of the symmetric 3 × 3 matrix [[a, b, c], [b, d, e], [c, e, f]].

    By cofactors, in plain floats: far cheaper than LAPACK for one tiny matrix (any units).

    Raises:
        numpy.linalg.LinAlgError: The matrix is singular.
    """
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    det = a * c00 + b * c01 + c * c02
    if not abs(det) > 1e-300:
        raise np.linalg.LinAlgError("singular normal equations")
    c11, c12, c22 = (a * f - c * c) / det, (b * c - a * e) / det, (a * d - b * b) / det
    c00, c01, c02 = c00 / det, c01 / det, c02 / det
    return (c00, c01, c02), (c01, c11, c12), (c02, c12, c22)


_Solved = tuple[ComplexArray, FloatArray, tuple[float, float, float], FloatArray]


class _Projection:
    """The block means' residual with A, B, C projected out, and its Jacobian, per (ζω, omega_d)."""

    def __init__(self, tau: FloatArray, yb: FloatArray, counts: FloatArray, step: float, even: bool):
        self.tau, self.counts, self.step, self.even = tau, counts, step, even
        self.weight = np.sqrt(counts)
        self.target = yb * self.weight
        self.tau_w = tau * self.weight
        self.weighted_y = counts * yb
        self.total, self.moment = float(np.sum(counts)), float(np.sum(self.weighted_y))  # Σc, Σc·y
        self.k, self.k_last = int(counts[0]), int(counts[-1])
        self.cache: dict[bytes, _Solved] = {}  # per x
        self.jacobians: dict[bytes, FloatArray] = {}

    def solve(self, x: FloatArray) -> _Solved:
        """Block-mean phasors, inverse normal matrix, (A, B, C) and the weighted residual."""
        key = x.tobytes()
        if key not in self.cache:
            self.cache.clear()
            counts = self.counts
            s = complex(-x[0], x[1])
            z = block_phasors(s, self.tau, self.step, self.k, self.k_last, self.even)
            # normal equations of the basis (1, Im z, Re z) weighted by the counts c, from
            # Σ c z, Σ c z², Σ c |z|² and Σ c y z
            cz = counts * z
            s1, s2 = complex(np.dot(counts, z)), complex(np.dot(cz, z))
            p, y1 = float(np.vdot(z, cz).real), complex(np.dot(self.weighted_y, z))
            inverse = inverse3(self.total, s1.imag, s1.real, 0.5 * (p - s2.real), 0.5 * s2.imag, 0.5 * (p + s2.real))
            (i00, i01, i02), (_, i11, i12), (_, _, i22) = inverse
            moment = self.moment
            coef = (
                i00 * moment + i01 * y1.imag + i02 * y1.real,
                i01 * moment + i11 * y1.imag + i12 * y1.real,
                i02 * moment + i12 * y1.imag + i22 * y1.real,
            )
            fitted = (complex(coef[2], -coef[1]) * z).real
            fitted += coef[0]
            fitted *= self.weight
            self.cache[key] = (z, np.array(inverse), coef, np.subtract(self.target, fitted, out=fitted))
        return self.cache[key]

    def residual(self, x: FloatArray) -> FloatArray:
        """The weighted residual of the block means at ``x = (ζω, omega_d)``."""
        return self.solve(x)[3]

    def jacobian(self, x: FloatArray) -> FloatArray:
        """Kaufman's Jacobian of the projected residual, −P⊥ ∂f/∂(ζω, omega_d), by rows."""
        key = x.tobytes()
        if key not in self.jacobians:
            self.jacobians.clear()
            self.jacobians[key] = self._kaufman(*self.solve(x)[:3])
        return self.jacobians[key]

    def _kaufman(self, z: ComplexArray, inverse: FloatArray, coef: tuple[float, float, float]) -> FloatArray:
        tau, weight = self.tau, self.weight
        kz = complex(coef[2], -coef[1]) * z
        d = np.empty((2, tau.size))  # −∂f/∂(ζω), −∂f/∂omega_d
        np.multiply(self.tau_w, kz.real, out=d[0])
        np.multiply(self.tau_w, kz.imag, out=d[1])
        basis = np.empty((3, tau.size))  # the weighted basis (1, Im z, Re z)
        basis[0] = weight
        np.multiply(z.imag, weight, out=basis[1])
        np.multiply(z.real, weight, out=basis[2])
        return d - ((d @ basis.T) @ inverse) @ basis


def varpro(
    tau: FloatArray,
    yb: FloatArray,
    counts: FloatArray,
    step: float,
    omega0: float,
    duration: float,
    even: bool = True,
) -> Solution:
    """Levenberg–Marquardt on the block means for (ζω, omega_d); A, B, C by projection.

    Args:
        tau: Block centres from the window centre [s].
        yb: Block means, scaled to about ±1.
        counts: Samples per block.
        step: Sample interval [s].
        omega0: Initial damped angular frequency [rad/s] (the spectrum's peak).
        duration: The window's length [s].
        even: Whether the samples are evenly spaced (the block-mean model is then exact).

    Returns:
        The solution, with ``omega_d > 0``.

    Raises:
        FitFailed: The fit failed or did not converge to an oscillation.
    """
    problem = _Projection(tau, yb, counts, step, even)

    def model(x: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
        return problem.residual(x), lambda: problem.jacobian(x)

    try:
        with np.errstate(all="ignore"):  # a fit that runs away is reported below
            found = minimise(model, np.array([0.0, omega0]), rel_tol=_REL_TOL, step_sigma=_STEP_SIGMA)
        x = found.x
        coef = np.array(problem.solve(x)[2])
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        raise FitFailed(f"the least-squares fit failed ({exc})") from None
    alpha, omega_d = float(x[0]), float(x[1])
    K = complex(coef[2], -coef[1])
    if omega_d < 0:  # the same curve, with the sine's sign flipped
        omega_d, K = -omega_d, K.conjugate()
    if not (
        found.stop is not Stop.ITERATIONS
        and math.isfinite(alpha)
        and omega_d > 0
        and abs(alpha) * duration < 30.0
        and np.all(np.isfinite(coef))
    ):
        why = f"ζω = {alpha:.3g} 1/s, ω_d = {omega_d:.3g} rad/s"
        why = "too many iterations" if found.stop is Stop.ITERATIONS else why
        raise FitFailed(f"the fit did not converge to an oscillation ({why})")
    return Solution(alpha, omega_d, float(coef[0]), K)


def gauss_newton(
    tau: FloatArray, y: FloatArray, sol: Solution, duration: float, units: tuple[float, float]
) -> Solution:
    """Gauss–Newton on every sample with the analytic Jacobian of (A, B, C, ζω, omega_d).

    Args:
        tau: Sample times from the window centre [s].
        y: The samples, in ``units``.
        sol: The starting solution (scaled samples).
        duration: The window's length [s].
        units: ``(scale, offset)`` of ``y``: ``y = offset + scale · (scaled sample)``.

    Returns:
        The refined solution, for the scaled samples.

    Raises:
        FitFailed: The normal equations are singular or the refinement diverged.
    """
    units_scale, units_offset = units
    alpha, omega_d = sol.alpha, sol.omega_d
    A, K = units_offset + units_scale * sol.A, units_scale * sol.K
    J = np.empty((5, tau.size))
    J[0] = 1.0
    for _ in range(8):
        z = np.exp(complex(-alpha, omega_d) * tau)
        kz = K * z
        J[1] = z.imag
        J[2] = z.real
        np.multiply(tau, kz.real, out=J[3])
        np.multiply(tau, kz.imag, out=J[4])
        J[3:] *= -1.0
        r = y - A - kz.real
        M = np.einsum("in,jn->ij", J, J)
        d = np.sqrt(np.diag(M))
        try:
            delta = (np.linalg.solve(M / np.outer(d, d), np.einsum("in,n->i", J, r) / d)) / d
        except np.linalg.LinAlgError:
            raise FitFailed("the Gauss–Newton refinement is singular") from None
        A += float(delta[0])
        K += complex(delta[2], -delta[1])
        alpha += float(delta[3])
        omega_d += float(delta[4])
        # converged when the step changes the phase by ≪ 0.01 rad over the window
        if not max(abs(delta[3]), abs(delta[4])) * duration > 1e-3:
            break
    if not (math.isfinite(omega_d) and omega_d > 0 and math.isfinite(alpha) and abs(alpha) * duration < 30.0):
        raise FitFailed("the Gauss–Newton refinement diverged")
    return Solution(alpha, omega_d, (A - units_offset) / units_scale, K / units_scale)
