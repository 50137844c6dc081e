"""Levenberg–Marquardt for the period fit's small nonlinear least-squares problems.

Both of the fit's nonlinear problems are small and come with analytic Jacobians: Eq 23's two
nonlinear parameters (ζω, ω_d) on the block means (:func:`~bike_rig.core.period.solver.varpro`)
and the damping models' 10–25 parameters (:mod:`~bike_rig.core.period.damping`). They share
this one solver:

* Marquardt's scaling: the damping term is λ·diag(JᵀJ), so the steps do not depend on the
  parameters' units;
* Nielsen's update of λ (H. B. Nielsen, *Damping parameter in Marquardt's method*, IMM-REP
  1999-05): after an accepted step λ ← λ·max(1/3, 1 − (2ρ − 1)³), ρ the actual over the
  predicted fall of the sum of squares; after a refused one λ ← λ·ν, ν doubling. It refuses
  far fewer steps than multiplying λ by 10 either way;
* it stops when the sum of squares falls by less than ``rel_tol`` of itself, or when no
  parameter moves by more than ``step_sigma`` of its σ (white residuals, from JᵀJ): further
  steps would not change a printed digit of any result.

(``scipy.optimize.leastsq``, MINPACK, fitted Eq 23 before; importing ``scipy.optimize`` takes
about 0.3 s, half of a fresh ``bike-rig replay``'s budget, for a loop of a few dozen lines
over the Jacobians we already have.)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import NDArray

__all__ = ["Minimum", "Stop", "minimise"]

FloatArray = NDArray[np.float64]

#: The model: parameters → (weighted residuals r, what gives their Jacobian ∂r/∂x, parameters ×
#: residuals; asked for only where the iteration goes on from).
Model = Callable[[FloatArray], tuple[FloatArray, Callable[[], FloatArray]]]

#: λ above which no step can lower the sum of squares any more.
_LAMBDA_MAX = 1e12


class Stop(str, Enum):
    """Why the iteration stopped."""

    CONVERGED = "converged"  # a stopping rule was met
    STALLED = "stalled"  # no step lowers the sum of squares (at the optimum, to rounding)
    ITERATIONS = "iterations"  # the iteration limit was reached


class SingularError(ArithmeticError):
    """JᵀJ is singular: the parameters are not determined by the data."""


@dataclass(frozen=True)
class Minimum:
    """The result of :func:`minimise`.

    Attributes:
        x: The parameters.
        r: The weighted residuals there.
        sse: Σ r².
        stop: Why it stopped.
        evaluations: Model evaluations made.
    """

    x: FloatArray
    r: FloatArray
    sse: float
    stop: Stop
    evaluations: int


def _inverse_diagonal(h: FloatArray) -> FloatArray:
    """The diagonal of h⁻¹, h symmetric positive semi-definite.

    Raises:
        SingularError: ``h`` is singular.
    """
    if h.shape == (2, 2):  # (Eq 23's problem, on every trial: closed form, no LAPACK call)
        (a, b), (_, d) = h.tolist()
        det = a * d - b * b
        if not abs(det) > 1e-300 * max(1.0, a * d):
            raise SingularError("singular normal equations")
        return np.array([d / det, a / det])
    try:
        return np.asarray(np.diag(np.linalg.inv(h)), dtype=np.float64)
    except np.linalg.LinAlgError:
        raise SingularError("singular normal equations") from None


def _damped_step(h: FloatArray, g: FloatArray, diag: FloatArray, lam: float) -> FloatArray:
    """The step (h + λ diag(h))⁻¹ g.

    Raises:
        SingularError: The damped matrix is singular.
    """
    if h.shape == (2, 2):
        (a, b), (_, d) = h.tolist()
        g0, g1 = g.tolist()
        a, d = a + lam * float(diag[0]), d + lam * float(diag[1])
        det = a * d - b * b
        if not abs(det) > 1e-300 * max(1.0, a * d):
            raise SingularError("singular normal equations")
        return np.array([(d * g0 - b * g1) / det, (a * g1 - b * g0) / det])
    damped = h.copy()
    damped.flat[:: diag.size + 1] += lam * diag
    try:
        return np.asarray(np.linalg.solve(damped, g), dtype=np.float64)
    except np.linalg.LinAlgError:
        raise SingularError("singular normal equations") from None


def minimise(
    model: Model,
    x0: FloatArray,
    *,
    rel_tol: float,
    step_sigma: float,
    max_iter: int = 40,
    feasible: Callable[[FloatArray], bool] | None = None,
) -> Minimum:
    """Minimise Σ r(x)² from ``x0`` (module docstring).

    Args:
        model: x → (r, a callable giving ∂r/∂x).
        x0: Starting parameters.
        rel_tol: Stop when an accepted step lowers Σ r² by less than this fraction of it.
        step_sigma: Stop when no parameter moves by more than this multiple of its σ.
        max_iter: Accepted steps at most.
        feasible: Parameters a step may reach (a refused one counts as a failed step, as does
            one where the model raises ``ArithmeticError`` or ``LinAlgError``).

    Raises:
        SingularError: JᵀJ is singular.
    """
    x = np.array(x0, dtype=np.float64)
    r, jacobian = model(x)
    jac = jacobian()
    evaluations = 1
    sse = float(np.dot(r, r))
    dof = max(1.0, r.size - x.size)
    lam, nu = 1e-3, 2.0
    stop = Stop.ITERATIONS
    for _ in range(max_iter):
        h = jac @ jac.T
        g = -(jac @ r)
        diag = h.diagonal().copy()
        limit = (step_sigma * step_sigma * sse / dof) * _inverse_diagonal(h)  # (step_sigma · σ)²
        accepted = False
        while lam < _LAMBDA_MAX:
            step = _damped_step(h, g, diag, lam)
            trial = x + step
            if feasible is not None and not feasible(trial):
                lam, nu = lam * nu, 2.0 * nu
                continue
            try:
                r2, jacobian = model(trial)
            except (ArithmeticError, np.linalg.LinAlgError):  # (a degenerate model there: a failed step)
                lam, nu = lam * nu, 2.0 * nu
                continue
            evaluations += 1
            sse2 = float(np.dot(r2, r2))
            if not (math.isfinite(sse2) and sse2 <= sse):
                lam, nu = lam * nu, 2.0 * nu
                continue
            predicted = float(step @ (g + lam * diag * step))
            rho = (sse - sse2) / predicted if predicted > 0 else 0.0
            small = sse - sse2 <= rel_tol * sse or bool((step * step <= limit).all())
            x, r, sse = trial, r2, sse2
            lam, nu = max(1e-9, lam * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)), 2.0
            accepted = True
            break
        if not accepted:
            stop = Stop.STALLED
            break
        if small:
            stop = Stop.CONVERGED
            break
        jac = jacobian()
    return Minimum(x, r, sse, stop, evaluations)
