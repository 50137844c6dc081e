"""σ of the closed loop's critical speeds and eigenvalues (steer-torque feedback, gains exact).

The implicit-function gradients (complex step in the parameters) are checked against central
differences of the closed-loop critical speeds and eigenvalues themselves.
"""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.feedback import Feedback, GainSchedule, load_feedback
from bike_rig.core.loader import load_measurements
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.eigen_sigma import eigenvalue_gain_gradient, eigenvalues_with_sigma
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.core.whipple import canonical_matrices, eigenvalues
from bike_rig.core.whipple.closed_loop import closed_loop_critical_speeds

ASSIST = load_feedback(config_file("feedback/balance_assist.yaml"))


def _speeds(values: dict[str, float], fb: Feedback) -> tuple[float | None, float | None]:
    cs = closed_loop_critical_speeds(canonical_matrices(values), values["g"], fb)
    return cs.weave, cs.capsize


def _steps(values: dict[str, float]) -> list[tuple[int, str, float]]:
    return [(k, name, 1e-6 * max(abs(values[name]), 1e-3)) for k, name in enumerate(PARAMETER_NAMES)]


def _shifted(values: dict[str, float], name: str, h: float) -> dict[str, float]:
    out = dict(values)
    out[name] += h
    return out


@pytest.mark.parametrize("bike", ["browser", "stratos"])
def test_closed_loop_speed_gradient_equals_central_differences(bike: str) -> None:
    """∂v/∂p of the closed loop's weave and capsize speeds (on a sloped gain piece) by differences."""
    ps = compute_parameters(load_measurements(config_file(f"bicycles/{bike}.yaml")))
    values = ps.parameters.as_dict()
    result = critical_speeds_with_sigma(ps, feedback=ASSIST)
    assert (result.weave, result.capsize) != (None, None)
    direct = _speeds(values, ASSIST)
    for got, expected in zip((result.weave, result.capsize), direct, strict=True):
        assert (got is None) == (expected is None)
        assert got is None or got.speed == pytest.approx(expected, rel=1e-12)
    for index, got in ((0, result.weave), (1, result.capsize)):
        if got is None:
            continue
        assert got.gradient is not None and got.sigma > 0.0
        fd = np.empty(len(PARAMETER_NAMES))
        for k, name, h in _steps(values):
            hi, lo = (
                _speeds(_shifted(values, name, h), ASSIST)[index],
                _speeds(_shifted(values, name, -h), ASSIST)[index],
            )
            assert hi is not None and lo is not None
            fd[k] = (hi - lo) / (2 * h)
        assert np.max(np.abs(fd - got.gradient)) < 1e-6 * np.max(np.abs(got.gradient))


def test_closed_loop_eigenvalue_gradient_equals_central_differences() -> None:
    """∂λ/∂p of the closed-loop eigenvalues by differences of the closed-loop sweep."""
    ps = compute_parameters(load_measurements(config_file("bicycles/browser.yaml")))
    values = ps.parameters.as_dict()
    v = np.array([1.5, 3.0, 7.0])
    es = eigenvalues_with_sigma(ps, v, feedback=ASSIST)
    gains = ASSIST.gains(v)
    open_loop = eigenvalues(canonical_matrices(values), values["g"], v).eigenvalues
    assert np.abs(es.sweep.eigenvalues - open_loop).max() > 0.1  # the feedback changes them
    for k, name, h in _steps(values):
        up, down = _shifted(values, name, h), _shifted(values, name, -h)
        hi = eigenvalues(canonical_matrices(up), up["g"], v, gains=gains).eigenvalues
        lo = eigenvalues(canonical_matrices(down), down["g"], v, gains=gains).eigenvalues
        fd = (hi - lo) / (2 * h)
        scale = np.abs(es.gradient[..., k]).max() + 1e-12
        assert np.abs(fd - es.gradient[..., k]).max() < 1e-5 * max(scale, np.abs(es.gradient).max() * 1e-3), name
    assert np.all(np.isfinite(es.sigma_real) | np.isnan(es.sigma_real))
    assert np.nanmax(es.sigma_real) > 0.0


#: The assist with σ on two gain values (a constant and a table value).
UNCERTAIN = Feedback(
    "uncertain assist",
    k_phi=GainSchedule((5.0, 15.0), (0.0, -5.0)),
    k_delta=GainSchedule((), (0.3,), (0.05,)),
    k_phidot=GainSchedule((0.0, 5.0), (-50.0, 0.0), (4.0, 0.0)),
)


def _moved(fb: Feedback, i: int, j: int, h: float) -> Feedback:
    """``fb`` with value ``j`` of gain ``i`` moved by ``h``."""
    s = fb.schedules[i]
    values = list(s.values)
    values[j] += h
    schedules = list(fb.schedules)
    schedules[i] = GainSchedule(s.speeds, tuple(values), s.sigmas)
    return Feedback(fb.name, *schedules)


def test_gain_sigma_of_the_closed_loop_speeds() -> None:
    """∂v/∂k by differences; σ² = the parameters' part + Σ (∂v/∂k σ_k)²; σ_k = 0 is the exact case."""
    ps = compute_parameters(load_measurements(config_file("bicycles/browser.yaml")))
    values = ps.parameters.as_dict()
    result = critical_speeds_with_sigma(ps, feedback=UNCERTAIN)
    knots = UNCERTAIN.uncertain_knots()
    assert [k[3] for k in knots] == ["k_delta", "k_phidot.values[0]"]
    for index, got in ((0, result.weave), (1, result.capsize)):
        assert got is not None and got.gain_gradient is not None and got.gradient is not None
        h = 1e-6
        for n, (i, j, _, label) in enumerate(knots):
            hi = _speeds(values, _moved(UNCERTAIN, i, j, h))[index]
            lo = _speeds(values, _moved(UNCERTAIN, i, j, -h))[index]
            assert hi is not None and lo is not None
            assert got.gain_gradient[n] == pytest.approx((hi - lo) / (2 * h), rel=1e-5, abs=1e-9), label
        params = float(got.gradient @ ps.parameters.covariance @ got.gradient)
        gains = sum((g * k[2]) ** 2 for g, k in zip(got.gain_gradient, knots, strict=True))
        assert got.sigma == pytest.approx(np.sqrt(params + gains), rel=1e-12)
        assert gains > 0.0
    exact = Feedback("exact", *(GainSchedule(s.speeds, s.values) for s in UNCERTAIN.schedules))
    plain = critical_speeds_with_sigma(ps, feedback=exact)
    assert plain.weave is not None and result.weave is not None
    assert plain.weave.speed == result.weave.speed and plain.weave.sigma < result.weave.sigma


def test_gain_sigma_of_the_closed_loop_eigenvalues() -> None:
    """∂λ/∂k by differences of the closed-loop sweep; the gains' σ widens the eigenvalues' σ."""
    ps = compute_parameters(load_measurements(config_file("bicycles/browser.yaml")))
    values = ps.parameters.as_dict()
    v = np.array([1.5, 3.0, 7.0])
    grad = eigenvalue_gain_gradient(
        values, v, eigenvalues_with_sigma(ps, v, feedback=UNCERTAIN).sweep.eigenvalues, UNCERTAIN
    )
    m = canonical_matrices(values)
    h = 1e-6
    for n, (i, j, _, label) in enumerate(UNCERTAIN.uncertain_knots()):
        up, down = _moved(UNCERTAIN, i, j, h), _moved(UNCERTAIN, i, j, -h)
        fd = (
            eigenvalues(m, values["g"], v, gains=up.gains(v)).eigenvalues
            - eigenvalues(m, values["g"], v, gains=down.gains(v)).eigenvalues
        ) / (2 * h)
        assert np.abs(fd - grad[..., n]).max() < 1e-5 * max(1.0, np.abs(grad[..., n]).max()), label
    exact = Feedback("exact", *(GainSchedule(s.speeds, s.values) for s in UNCERTAIN.schedules))
    wide = eigenvalues_with_sigma(ps, v, feedback=UNCERTAIN).sigma_real
    narrow = eigenvalues_with_sigma(ps, v, feedback=exact).sigma_real
    ok = np.isfinite(wide) & np.isfinite(narrow)
    assert ok.any() and np.all(wide[ok] >= narrow[ok]) and np.any(wide[ok] > narrow[ok])
