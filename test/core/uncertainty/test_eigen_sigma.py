"""σ of the eigenvalues over speed (first order, from the parameter covariance).

The gradient against central differences, the σ against a Monte Carlo over the raw measurements,
the paper's independent convention, and the branch points where the linearisation cannot hold.
"""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet, compute_parameters, monte_carlo_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.eigen_sigma import eigenvalue_gradient, eigenvalues_with_sigma
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from bike_rig.core.whipple import canonical_matrices, characteristic_coefficients, eigenvalues, quartic_roots

BICYCLES = ("browser", "browserins", "crescendo", "fisher", "stratos", "yellow")


def _measured(name: str) -> ParameterSet:
    return compute_parameters(load_measurements(config_file(f"bicycles/{name}.yaml")))


def test_gradient_equals_central_differences() -> None:
    ps = _measured("crescendo")
    values = ps.parameters.as_dict()
    speeds = np.array([0.3, 3.5, 6.0, 9.0])  # simple roots at each (no branch point nearby)
    ms = canonical_with_sigma(ps)
    lam = eigenvalues(ms.matrices, ms.g, speeds).eigenvalues
    grad = eigenvalue_gradient(values, speeds, lam)
    for k, name in enumerate(PARAMETER_NAMES):
        h = 1e-6 * max(abs(values[name]), 1e-3)
        plus, minus = dict(values), dict(values)
        plus[name] += h
        minus[name] -= h
        lp = eigenvalues(canonical_matrices(plus), plus["g"], speeds).eigenvalues
        lm = eigenvalues(canonical_matrices(minus), minus["g"], speeds).eigenvalues
        fd = (lp - lm) / (2 * h)
        scale = np.abs(grad[:, :, k]).max() + 1e-12
        assert np.max(np.abs(fd - grad[:, :, k])) < 1e-5 * scale + 1e-7, name


def _mc_roots(ps_draws: dict[str, np.ndarray], speed: float, nominal: np.ndarray) -> np.ndarray:
    """Each draw's four roots at ``speed``, matched to the nominal ones by nearest distance."""
    coef = characteristic_coefficients(canonical_matrices(ps_draws), ps_draws["g"], speed)
    roots = quartic_roots(coef.reshape(-1, 5))  # (draws, 4)
    out = np.empty_like(roots)
    for j, target in enumerate(nominal):
        pick = np.argmin(np.abs(roots - target), axis=1)
        out[:, j] = roots[np.arange(roots.shape[0]), pick]
    return out


@pytest.mark.parametrize("name", BICYCLES)
@pytest.mark.parametrize("rider", [False, True])
def test_sigma_agrees_with_monte_carlo_from_the_raw_readings(name: str, rider: bool) -> None:
    """4,000 draws of the raw readings.

    The sample σ of a normal quantity is within 6 % of the true σ with probability 1 − 2e-7
    (σ_s/σ ≈ 1/√(2n) = 1.1 %, 6 % ≈ 5.4 of those); the remaining allowance (10 % in all) is for
    the second-order terms the linear σ leaves out.
    """
    m = load_measurements(config_file(f"bicycles/{name}.yaml"))
    ps = compute_parameters(m)
    draws = monte_carlo_parameters(m, 4000, seed=20261121)
    if rider:
        ps = add_rider(ps, PAPER_RIDER)
        from bike_rig.core.rider import combine_rear_frame

        draws = {k: np.asarray(v) for k, v in combine_rear_frame(draws, PAPER_RIDER).items()}
    speeds = np.array([1.0, 5.0, 8.0])
    es = eigenvalues_with_sigma(ps, speeds)
    checked = 0
    for i, v in enumerate(speeds):
        mc = _mc_roots(draws, float(v), es.sweep.eigenvalues[i])
        for j in range(4):
            for lin, sample in ((es.sigma_real[i, j], mc[:, j].real), (es.sigma_imag[i, j], mc[:, j].imag)):
                if not np.isfinite(lin):
                    continue  # near a branch point: marked, not compared
                spread = float(np.std(sample, ddof=1))
                if lin < 1e-9 and spread < 1e-9:
                    continue  # an exactly real root: both zero
                assert spread == pytest.approx(lin, rel=0.10), (name, rider, v, j)
                checked += 1
    assert checked >= 12


def test_paper_convention_drops_the_correlations() -> None:
    ps = _measured("browser")
    speeds = np.linspace(0.5, 9.5, 10)
    cor = eigenvalues_with_sigma(ps, speeds, SigmaConvention.CORRELATED)
    ind = eigenvalues_with_sigma(ps, speeds, "paper")
    cov = np.diag(np.diag(ps.parameters.covariance))
    g = cor.gradient.real
    manual = np.sqrt(np.einsum("nmp,pq,nmq->nm", g, cov, g))
    ok = np.isfinite(ind.sigma_real)
    assert np.allclose(ind.sigma_real[ok], manual[ok], rtol=1e-12)
    assert not np.allclose(ind.sigma_real[ok], cor.sigma_real[ok], rtol=1e-3)


def test_sigma_is_marked_unknown_at_the_weave_branch_point_only() -> None:
    """Below the weave speed two real roots merge into the weave pair.

    There ``P'(λ) = 0``, the first-order σ diverges, and the module reports NaN instead of a
    meaningless band.
    """
    ps = _measured("browser")
    speeds = np.linspace(0.0, 10.0, 2001)
    es = eigenvalues_with_sigma(ps, speeds)
    weave = es.sweep.eigenvalues[:, 0]
    complex_from = speeds[np.argmax(np.abs(weave.imag) > 0)]  # first speed with a weave pair
    near = np.abs(speeds - complex_from) < 0.01
    far = np.abs(speeds - complex_from) > 0.5
    assert np.isnan(es.sigma_real[near, 0]).any()
    assert np.isfinite(es.sigma_real[far & (speeds > 4.0), :]).all()  # no branch point above 4 m/s
    assert np.nanmax(es.sigma_real[far, 0]) < 0.2  # 1/s: bounded away from it
