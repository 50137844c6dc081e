"""Linear σ with correlations.

Exact complex-step Jacobians vs the ``uncertainties`` package and vs a Monte Carlo propagation
of the raw measurements.
"""

from __future__ import annotations

import numpy as np
import pytest
import uncertainties

from bike_rig.core.benchmark import PARAMETER_NAMES, benchmark_formulas, compute_parameters, monte_carlo_parameters
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.uncertainty.uncertain import complex_step_jacobian
from test.support.paper import BICYCLE_NAMES, shared_dir


def _measured(bike: str):  # type: ignore[no-untyped-def]
    return read_bp_measured(shared_dir() / "data" / "bicycleparameters" / bike / "RawData" / f"{bike}Measured.txt")


def test_covariance_matches_uncertainties_package() -> None:
    """The full 26 × 26 covariance (correlations included) equals what ``uncertainties`` gives.

    That is, when it propagates the same readings through the same formulas (its own numerical
    derivatives via ``uncertainties.wrap``).
    """
    m = _measured("Browser")
    ours = compute_parameters(m).parameters
    keys = [k for k, r in m.readings.items() if r.sigma > 0]  # exact counts stay plain floats
    fixed = {k: r.value for k, r in m.readings.items()}

    def component(name: str):  # type: ignore[no-untyped-def]
        def f(*xs: float) -> float:
            return float(benchmark_formulas({**fixed, **dict(zip(keys, xs))})[name])

        return uncertainties.wrap(f)

    u_in = [uncertainties.ufloat(m.readings[k].value, m.readings[k].sigma) for k in keys]
    u_out = [component(name)(*u_in) for name in PARAMETER_NAMES]
    cov = np.array(uncertainties.covariance_matrix(u_out))
    scale = np.sqrt(np.outer(np.diag(cov), np.diag(cov))) + 1e-300
    assert np.max(np.abs(ours.covariance - cov) / scale) < 1e-4
    # the parameters really are correlated: e.g. x_B and I_Byy share r_R and the hanging lines
    r = ours.correlation()
    assert abs(r[ours.index("xB"), ours.index("IByy")]) > 0.1


def test_jacobian_is_exact_for_a_polynomial() -> None:
    prop = complex_step_jacobian(lambda x: {"y": x["a"] ** 3 * x["b"]}, {"a": 2.0, "b": 5.0}, ["a", "b"])
    assert prop.values[0] == 40.0
    np.testing.assert_allclose(prop.jacobian, [[60.0, 8.0]], rtol=1e-15)


@pytest.mark.parametrize("bike", sorted(BICYCLE_NAMES.values()))
def test_linear_sigma_agrees_with_monte_carlo(bike: str) -> None:
    """Linear σ within 10 % of the standard deviation of 20,000 Monte Carlo draws."""
    m = _measured(bike)
    linear = compute_parameters(m).parameters
    draws = monte_carlo_parameters(m, samples=20_000, seed=7)
    for name in PARAMETER_NAMES:
        s = linear.sigma(name)
        if s == 0:
            assert np.ptp(draws[name]) == 0, name
            continue
        assert np.std(draws[name], ddof=1) == pytest.approx(s, rel=0.10), name
        assert np.mean(draws[name]) == pytest.approx(linear.value(name), abs=0.5 * s), name
