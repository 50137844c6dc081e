"""Tests of core/speed_sigma: σ of the weave and capsize speeds.

σ of the weave and capsize speeds (implicit function theorem), checked against central
differences of critical_speeds and a Monte Carlo over the parameter covariance.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet, compute_parameters
from bike_rig.core.loader import load_input, load_measurements
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention
from bike_rig.core.uncertainty.speed_sigma import critical_speed_gradient, critical_speeds_with_sigma
from bike_rig.core.whipple import WhippleMatrices, canonical_matrices, critical_speeds

MC_SAMPLES = 4000
MC_TOLERANCE = 0.15


def parameter_set(name: str, rider: bool = False) -> ParameterSet:
    ps = compute_parameters(load_measurements(config_file(f"bicycles/{name}.yaml")))
    return add_rider(ps, PAPER_RIDER) if rider else ps


def speeds_of(values: dict[str, float]) -> tuple[float | None, float | None]:
    cs = critical_speeds(canonical_matrices(values), values["g"])
    return cs.weave, cs.capsize


@pytest.mark.parametrize("rider", [False, True])
def test_gradient_equals_central_differences(rider: bool) -> None:
    ps = parameter_set("browser", rider)
    values = ps.parameters.as_dict()
    result = critical_speeds_with_sigma(ps)
    assert result.weave is not None and result.capsize is not None
    for index, got in ((0, result.weave), (1, result.capsize)):
        assert got.gradient is not None
        fd = np.empty(len(PARAMETER_NAMES))
        for k, name in enumerate(PARAMETER_NAMES):
            h = 1e-6 * max(abs(values[name]), 1e-3)
            up, down = dict(values), dict(values)
            up[name] += h
            down[name] -= h
            hi, lo = speeds_of(up)[index], speeds_of(down)[index]
            assert hi is not None and lo is not None
            fd[k] = (hi - lo) / (2 * h)
        scale = np.max(np.abs(got.gradient))
        assert np.max(np.abs(fd - got.gradient)) < 1e-6 * scale


def monte_carlo_sigmas(ps: ParameterSet, covariance: np.ndarray, seed: int) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    samples = rng.multivariate_normal(ps.parameters.values, covariance, size=MC_SAMPLES, method="eigh")
    cm = canonical_matrices({name: samples[:, k] for k, name in enumerate(PARAMETER_NAMES)})
    g = samples[:, PARAMETER_NAMES.index("g")]
    weave, capsize = [], []
    for i in range(MC_SAMPLES):
        cs = critical_speeds(WhippleMatrices(cm.M[i], cm.C1[i], cm.K0[i], cm.K2[i]), float(g[i]))
        assert cs.weave is not None and cs.capsize is not None
        weave.append(cs.weave)
        capsize.append(cs.capsize)
    return float(np.std(weave, ddof=1)), float(np.std(capsize, ddof=1))


@pytest.mark.parametrize(
    ("name", "rider", "convention"),
    [("browser", False, "correlated"), ("browser", True, "correlated"), ("crescendo", False, "paper")],
)
def test_sigma_agrees_with_monte_carlo(name: str, rider: bool, convention: str) -> None:
    ps = parameter_set(name, rider)
    result = critical_speeds_with_sigma(ps, convention)
    params = ps.parameters if convention == "correlated" else ps.parameters.independent()
    mc_weave, mc_capsize = monte_carlo_sigmas(ps, params.covariance, seed=11)
    assert result.weave is not None and result.capsize is not None
    assert result.weave.sigma == pytest.approx(mc_weave, rel=MC_TOLERANCE)
    assert result.capsize.sigma == pytest.approx(mc_capsize, rel=MC_TOLERANCE)


def test_conventions_differ_and_speeds_match_the_core() -> None:
    ps = parameter_set("browser")
    correlated = critical_speeds_with_sigma(ps, SigmaConvention.CORRELATED)
    paper = critical_speeds_with_sigma(ps, SigmaConvention.PAPER)
    assert correlated.weave is not None and paper.weave is not None
    assert correlated.weave.speed == paper.weave.speed
    assert correlated.weave.sigma != paper.weave.sigma


def test_exact_parameters_have_zero_sigma() -> None:
    ps = load_input(config_file("bicycles/benchmark.yaml"))
    assert isinstance(ps, ParameterSet)
    result = critical_speeds_with_sigma(ps)
    assert result.weave is not None and result.capsize is not None
    assert result.weave.speed == pytest.approx(4.29238253634111, abs=1e-12)
    assert result.capsize.speed == pytest.approx(6.02426201538837, abs=1e-12)
    assert (result.weave.sigma, result.capsize.sigma) == (0.0, 0.0)


def test_double_root_has_no_gradient() -> None:
    # a0(v) = e00 + e02 v² + e04 v⁴ is even in v: its v-derivative is exactly zero at v = 0
    values = parameter_set("browser").parameters.as_dict()
    grad = critical_speed_gradient(values, 0.0, "real")
    assert all(math.isnan(x) for x in grad)
