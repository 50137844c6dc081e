"""The model's Monte Carlo σ: equal to the first-order σ where that is defined, finite where it is not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.weave_mc import eigenvalue_monte_carlo
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.pipeline.ride import MONTE_CARLO, predicted_weave


@pytest.fixture(scope="module")
def browser():  # type: ignore[no-untyped-def]
    return add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "assist"])
def test_monte_carlo_sigma_equals_the_linear_sigma_away_from_branch_points(browser, closed: bool) -> None:  # type: ignore[no-untyped-def]
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml"))) if closed else None
    v = np.array([2.0, 3.0, 4.5])
    p = predicted_weave(browser, v, fb)
    mc = eigenvalue_monte_carlo(browser, v, p.real + 1j * p.imag, fb, draws=3000, seed=1)
    # measured: within 4 % (the robust σ of 3000 draws has a relative standard error of ~2 %)
    assert mc.real_sigma == pytest.approx(p.real_sigma, rel=0.08)
    assert mc.imag_sigma == pytest.approx(p.imag_sigma, rel=0.08)
    assert np.all(mc.real_fraction == 0)


def test_near_a_branch_point_the_prediction_has_a_monte_carlo_sigma(browser) -> None:  # type: ignore[no-untyped-def]
    v = np.array([0.783, 3.0])  # the open loop's weave pair is born at about 0.78 m/s
    p = predicted_weave(browser, v)
    assert p.sigma_method == (MONTE_CARLO, "linear")
    assert all(math.isfinite(x) and x > 0 for x in (*p.real_sigma, *p.imag_sigma))
    assert any("branch point" in n for n in p.notes)


def test_a_measured_oscillation_where_the_model_has_none_is_compared_with_its_nearest_root(browser) -> None:  # type: ignore[no-untyped-def]
    p = predicted_weave(browser, [0.4], near=[complex(-1.0, 2.0)])
    assert p.imag[0] == 0 and math.isfinite(p.real[0]) and p.sigma_method == (MONTE_CARLO,)
    assert math.isfinite(p.real_sigma[0]) and math.isfinite(p.imag_sigma[0])
