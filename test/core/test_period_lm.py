"""The period fit's Levenberg–Marquardt (bike_rig.core.period.lm) against scipy's solvers."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.optimize import least_squares

from bike_rig.core.period.lm import SingularError, Stop, minimise

FloatArray = np.ndarray


def _rosenbrock(x: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
    r = np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])
    return r, lambda: np.array([[-20.0 * x[0], -1.0], [10.0, 0.0]])  # parameters × residuals


def test_rosenbrock_reaches_its_minimum() -> None:
    found = minimise(_rosenbrock, np.array([-1.2, 1.0]), rel_tol=0.0, step_sigma=1e-12, max_iter=200)
    assert found.stop in (Stop.CONVERGED, Stop.STALLED)
    np.testing.assert_allclose(found.x, [1.0, 1.0], atol=1e-8)
    assert found.sse < 1e-16


def _decay_problem(seed: int) -> tuple[FloatArray, FloatArray]:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, 400)
    y = 2.0 * np.exp(-0.3 * t) * np.cos(1.7 * t + 0.4) + 0.05 * rng.standard_normal(t.size)
    return t, y


@pytest.mark.parametrize("seed", range(5))
def test_a_damped_cosine_fit_equals_scipys(seed: int) -> None:
    """Four parameters, analytic Jacobian: the minimum scipy's trust-region solver finds."""
    t, y = _decay_problem(seed)

    def residual(p: FloatArray) -> FloatArray:
        a, alpha, omega, phase = p
        return np.asarray(y - a * np.exp(-alpha * t) * np.cos(omega * t + phase))

    def jacobian(p: FloatArray) -> FloatArray:
        a, alpha, omega, phase = p
        e, c, s = np.exp(-alpha * t), np.cos(omega * t + phase), np.sin(omega * t + phase)
        return np.stack([-e * c, a * t * e * c, a * t * e * s, a * e * s])  # ∂r/∂p, rows

    x0 = np.array([1.5, 0.2, 1.65, 0.0])
    found = minimise(lambda p: (residual(p), lambda: jacobian(p)), x0, rel_tol=1e-14, step_sigma=1e-6)
    reference = least_squares(residual, x0, jac=lambda p: jacobian(p).T, xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert found.stop is Stop.CONVERGED
    np.testing.assert_allclose(found.x, reference.x, rtol=1e-7)
    assert found.sse == pytest.approx(2.0 * reference.cost, rel=1e-10)


def test_the_sigma_rule_stops_within_its_fraction_of_sigma() -> None:
    """Stopped by ``step_sigma`` = 1e-3: every parameter within about 1e-3 σ of the optimum."""
    t, y = _decay_problem(7)

    def model(p: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
        a, alpha, omega, phase = p
        e, c, s = np.exp(-alpha * t), np.cos(omega * t + phase), np.sin(omega * t + phase)
        return y - a * e * c, lambda: np.stack([-e * c, a * t * e * c, a * t * e * s, a * e * s])

    x0 = np.array([1.5, 0.2, 1.65, 0.0])
    loose = minimise(model, x0, rel_tol=0.0, step_sigma=1e-3)
    tight = minimise(model, x0, rel_tol=0.0, step_sigma=1e-9, max_iter=100)
    _, jac = model(tight.x)
    j = jac()
    sigma = np.sqrt(np.diag(np.linalg.inv(j @ j.T)) * tight.sse / (t.size - 4))
    assert loose.evaluations < tight.evaluations
    assert np.all(np.abs(loose.x - tight.x) <= 1e-2 * sigma)


def test_refused_steps_and_failures() -> None:
    # a model that raises beyond x = 1.7 (before the optimum, 1.88) is stepped around, not propagated
    def model(x: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
        if x[0] > 1.7:
            raise np.linalg.LinAlgError("degenerate")
        return np.array([x[0] - 1.9, 0.1 * x[0]]), lambda: np.array([[1.0, 0.1]])

    found = minimise(model, np.array([0.0]), rel_tol=1e-12, step_sigma=1e-9, feasible=lambda v: bool(v[0] < 1.0))
    assert found.x[0] < 1.0  # the optimum (1.88) is beyond what is feasible
    found = minimise(model, np.array([0.0]), rel_tol=1e-12, step_sigma=1e-9)
    assert 1.6 < found.x[0] <= 1.7

    # a parameter the residuals do not depend on: singular
    def flat(x: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
        return np.array([x[0] - 1.0, x[0] + 1.0]), lambda: np.array([[1.0, 1.0], [0.0, 0.0]])

    with pytest.raises(SingularError):
        minimise(flat, np.array([0.0, 0.0]), rel_tol=1e-12, step_sigma=1e-9)
