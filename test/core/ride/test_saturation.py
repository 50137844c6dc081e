"""A saturating assist: segments of a bicycle falling over give no absurd σ, and no clean eigenvalue.

With the gains acting at 0.7 of their scale and the motor's torque clipped, the Browser at
1.5–2.5 m/s falls over within a second of the push: the roll rate is a ramp or an exponential
growth, with at most a trace of the weave. Fitted as a free decay it once gave σ ≈ 1e-36
(``JᵀJ`` inverted to rounding noise) and, elsewhere, +3.04 ± 0.0006 + 1.08i reported clean (a
fast growth with a slow "oscillation"). The σ must never fall below what the residuals support,
a design that does not determine its parameters is no fit, and a fitted frequency that is not
the record's oscillation is flagged.
"""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.noise import inverse_normal_matrix
from bike_rig.core.ride.realmode import fit_with_real_mode
from bike_rig.core.ride.ridesim import RideConditions, simulate_segment
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma


@pytest.fixture(scope="module")
def browser() -> tuple[object, object]:
    ms = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None
    return ms, fb


def test_falling_over_with_the_motor_saturated_gives_no_clean_eigenvalue(browser: tuple[object, object]) -> None:
    ms, fb = browser
    rng = np.random.default_rng(7)
    saturated = 0
    for saturation in (2.0, 5.0):
        for v in (1.5, 1.9, 2.4):
            for _ in range(6):
                sim = simulate_segment(
                    ms.matrices,  # type: ignore[attr-defined]
                    ms.g,  # type: ignore[attr-defined]
                    v,
                    0.7 * fb.gains(v),  # type: ignore[attr-defined]
                    float(rng.uniform(1.2, 2.5)),
                    RideConditions(saturation=saturation),
                    rng,
                )
                saturated += sim.saturated > 0.9
                m = fit_segment(sim.times, sim.roll_rate, speed=v)
                if m.valid:  # a σ the record's noise (0.01 rad/s) and length (≤ 1 s) can support
                    assert m.real_sigma > 1e-4 and m.imag_sigma > 1e-4, m
                assert not (m.clean and sim.saturated > 0.9), m
    assert saturated >= 18  # the case is exercised: the motor saturates over most of these records


def test_an_ill_conditioned_design_is_refused() -> None:
    t = np.linspace(-0.5, 0.5, 80)
    jac = np.column_stack([np.ones_like(t), t, t + 1e-12 * t**2])
    with pytest.raises(np.linalg.LinAlgError, match="condition number"):
        inverse_normal_matrix(jac)
    good = np.column_stack([np.ones_like(t), t, t**2])
    inv = inverse_normal_matrix(good)
    assert np.allclose(inv, np.linalg.inv(good.T @ good))
    assert np.all(np.linalg.eigvalsh(inv) > 0)


def test_the_sigma_is_never_below_what_the_residuals_support() -> None:
    """A sensor noise claimed 50 times below the residuals' does not shrink the σ."""
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 1.6, 0.01)
    y = 0.3 * np.exp(-0.8 * t) * np.sin(8.0 * t + 0.4) + rng.normal(0.0, 0.02, t.size)
    claimed = fit_with_real_mode(t, y, 0.8, 8.0, trend=False, white=4e-4)
    residual = fit_with_real_mode(t, y, 0.8, 8.0, trend=False)  # the residuals taken as white
    for i in (0, 2):  # the white parts of Var(α) and Var(ω_d): the drive's come on top
        assert claimed.variance[i] >= 0.95 * residual.variance[i], (claimed.variance, residual.variance)
