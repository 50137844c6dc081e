"""σ of A and B at one speed (open and closed loop), from the parameters' covariance.

The values equal :func:`state_space` on the canonical matrices; the σ agree with a Monte Carlo
over the raw readings of every bicycle under ``../shared/data/bicycleparameters`` that has them;
the closed loop adds the gains' σ exactly as ``∂(A − B K)/∂k`` says.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bike_rig.core.benchmark import compute_parameters, monte_carlo_parameters
from bike_rig.core.feedback import Feedback, GainSchedule
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from bike_rig.core.uncertainty.state_space_sigma import state_space_sigma
from bike_rig.core.whipple import canonical_matrices, state_space
from bike_rig.core.whipple.closed_loop import closed_loop_state_space
from test.support.paper import shared_dir

BP_DATA = shared_dir() / "data" / "bicycleparameters"
RAW = sorted(p for p in BP_DATA.glob("*/RawData/*Measured.txt") if p.name == f"{p.parents[1].name}Measured.txt")

UNCERTAIN = Feedback(
    "uncertain assist",
    k_phi=GainSchedule((5.0, 15.0), (0.0, -5.0)),
    k_delta=GainSchedule((), (0.3,), (0.05,)),
    k_phidot=GainSchedule((0.0, 5.0), (-50.0, 0.0), (4.0, 0.0)),
)


def test_every_raw_bicycle_is_checked() -> None:
    assert len(RAW) >= 8, RAW  # the paper's eight bicycles and the Rigid one, at least


@pytest.mark.parametrize("path", RAW, ids=lambda p: p.parents[1].name)
def test_sigma_agrees_with_monte_carlo_from_the_raw_readings(path: Path) -> None:
    """The σ of every entry against 3,000 draws of the raw readings.

    The sample σ is within 6 % of the true σ with probability 1 − 2e-7 (σ_s/σ ≈ 1.3 %); 10 % in
    all leaves room for the second-order terms.
    """
    m = read_bp_measured(path)
    ps = compute_parameters(m)
    speed = 4.0
    got = state_space_sigma(ps, speed)
    ms = canonical_with_sigma(ps)
    a, b = state_space(ms.matrices, speed, ms.g)
    np.testing.assert_allclose(got.a, a, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got.b, b, rtol=1e-13, atol=1e-13)
    draws = monte_carlo_parameters(m, 3000, seed=20261126)
    a_mc, b_mc = state_space(canonical_matrices(draws), speed, np.asarray(draws["g"])[:, None, None])
    for name, ours, mc in (("A", got.a_sigma, a_mc.std(axis=0)), ("B", got.b_sigma, b_mc.std(axis=0))):
        constant = mc < 1e-12 * max(1.0, float(np.abs(a).max()))
        assert np.all(ours[constant] == 0.0), name  # the 0 and 1 entries
        np.testing.assert_allclose(ours[~constant], mc[~constant], rtol=0.10, err_msg=name)


def test_paper_convention_drops_the_correlations() -> None:
    ps = compute_parameters(read_bp_measured(RAW[0]))
    independent = state_space_sigma(ps, 3.0, SigmaConvention.PAPER)
    correlated = state_space_sigma(ps, 3.0)
    assert np.array_equal(independent.a, correlated.a)
    assert not np.allclose(independent.a_sigma, correlated.a_sigma, rtol=1e-3)


def test_closed_loop_adds_the_gains_sigma() -> None:
    """A − B K with the parameters' σ and, independent of them, (B_δ ∂K/∂k σ_k)² of each gain value."""
    ps = compute_parameters(read_bp_measured(RAW[0]))
    speed = 2.0
    got = state_space_sigma(ps, speed, feedback=UNCERTAIN)
    ms = canonical_with_sigma(ps)
    a_cl, _ = closed_loop_state_space(ms.matrices, speed, ms.g, UNCERTAIN.gains(speed))
    np.testing.assert_allclose(got.a, a_cl, rtol=1e-13, atol=1e-13)
    exact = Feedback("exact", *(GainSchedule(s.speeds, s.values) for s in UNCERTAIN.schedules))
    params_only = state_space_sigma(ps, speed, feedback=exact)
    # by differences: each uncertain gain value moved by h
    extra = np.zeros((4, 4))
    h = 1e-6
    for i, j, sigma, _ in UNCERTAIN.uncertain_knots():
        moved = []
        for step in (h, -h):
            schedules = list(UNCERTAIN.schedules)
            values = list(schedules[i].values)
            values[j] += step
            schedules[i] = GainSchedule(schedules[i].speeds, tuple(values), schedules[i].sigmas)
            moved.append(closed_loop_state_space(ms.matrices, speed, ms.g, Feedback("m", *schedules).gains(speed))[0])
        extra += ((moved[0] - moved[1]) / (2 * h) * sigma) ** 2
    assert extra.max() > 0.0
    np.testing.assert_allclose(got.a_sigma, np.sqrt(params_only.a_sigma**2 + extra), rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(got.b_sigma, params_only.b_sigma)
