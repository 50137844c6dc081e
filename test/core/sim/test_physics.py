"""The inverse physics: true readings put back through the core's forward chain give the truth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bike_rig.config.paths import config_dir
from bike_rig.core import com, geometry, inertia
from bike_rig.core.benchmark import benchmark_formulas
from bike_rig.core.sim import physics
from bike_rig.core.sim.errors import SimulationError
from bike_rig.core.sim.rig import RigConfig
from bike_rig.core.sim.session import load_true_parameters
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.units import radians

BICYCLE_FILES = sorted((config_dir() / "bicycles").glob("*.yaml"))


def _forward(truth: physics.TrueReadings) -> dict[str, float]:
    """The core's chain (Eq 6–37) applied to the exact readings."""
    readings = {**truth.static, **truth.periods}
    out = benchmark_formulas(readings)
    return {k: float(out[k]) for k in PARAMETER_NAMES}


def _assert_recovered(got: dict[str, float], want: dict[str, float]) -> None:
    for k in PARAMETER_NAMES:
        assert got[k] == pytest.approx(want[k], rel=1e-10, abs=1e-12), k


def test_table2_browser_round_trips_through_the_forward_chain(rig: RigConfig, browser_truth: dict[str, float]) -> None:
    truth = physics.true_readings(browser_truth, rig)
    _assert_recovered(_forward(truth), browser_truth)
    # the rod's inertia and period also give k back (Fig 9)
    k = inertia.torsional_stiffness(truth.rod_inertia, truth.periods["TtP1"])
    assert k == pytest.approx(rig.stiffness, rel=1e-12)


@pytest.mark.parametrize("path", BICYCLE_FILES, ids=lambda p: p.stem)
def test_every_shipped_bicycle_round_trips(rig: RigConfig, path: object) -> None:
    _, params = load_true_parameters(str(path))
    _assert_recovered(_forward(physics.true_readings(params, rig)), params)


def test_more_orientations_and_another_rod(rig: RigConfig, browser_truth: dict[str, float]) -> None:
    """Any number of orientations and any stiffness invert exactly (least squares of Eq 35 is exact)."""
    other = replace(
        rig,
        stiffness=3.1,
        frame_orientations_deg=(3.4, 60.0, 138.7, 229.8, 300.0),
        fork_orientations_deg=(346.7, 28.1, 287.0, 100.0),
    )
    truth = physics.true_readings(browser_truth, other)
    assert [m.key for m in truth.plan].count("TtB5") == 1 and "TtH4" in truth.periods
    _assert_recovered(_forward(truth), browser_truth)


def test_pendulum_axis_inertia_is_eq34_and_inverts_eq35() -> None:
    Ixx, Ixz, Izz = 0.53, -0.11, 0.29
    betas = radians(np.array([19.5, -115.8, -206.9]))
    J = physics.pendulum_axis_inertia(Ixx, Ixz, Izz, betas)
    c, s = np.cos(betas), np.sin(betas)
    assert J == pytest.approx(c * c * Ixx - 2 * s * c * Ixz + s * s * Izz, rel=1e-14)
    got = inertia.inertia_from_pendulum_axes(list(J), list(betas))
    assert [float(g) for g in got] == pytest.approx([Ixx, Ixz, Izz], rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-0.5, 1.5),
    z=st.floats(-1.2, -0.1),
    alpha=st.floats(-180.0, 360.0),
    lam=st.floats(0.05, 0.5),
)
def test_string_distances_invert_eq14_and_eq21(x: float, z: float, alpha: float, lam: float) -> None:
    rR, rF, w = 0.34, 0.345, 1.1
    beta = com.pendulum_rotation_angle(lam, radians(alpha))
    if abs(np.cos(beta)) < 0.05:
        return
    m = com.com_line_slope(beta)
    a = physics.frame_string_distance(x, z, beta, rR)
    assert m * x + com.frame_com_line_intercept(a, beta, rR) == pytest.approx(z, abs=1e-12)
    a = physics.fork_string_distance(x, z, beta, w, rF)
    assert m * x + com.fork_com_line_intercept(a, beta, w, rF) == pytest.approx(z, abs=1e-12)


def test_geometry_inverses() -> None:
    assert geometry.wheel_radius(physics.distance_rolled(0.3405, 13), 13) == pytest.approx(0.3405, rel=1e-15)
    lam = 0.3997
    assert geometry.steer_axis_tilt(physics.head_tube_angle(lam)) == pytest.approx(lam, rel=1e-15)
    assert geometry.trail(0.34, lam, physics.fork_offset(0.34, lam, 0.0686)) == pytest.approx(0.0686, rel=1e-13)


def test_pendulum_periods_invert_eq28_and_eq29() -> None:
    T = physics.compound_period(0.11, 3.1, 0.29, 9.81)
    assert inertia.compound_pendulum_inertia(3.1, 9.81, 0.29, T) == pytest.approx(0.11, rel=1e-13)
    T = physics.torsional_period(0.09, 5.62)
    assert inertia.torsional_pendulum_inertia(5.62, T) == pytest.approx(0.09, rel=1e-14)


def test_impossible_bicycles_are_refused(rig: RigConfig, browser_truth: dict[str, float]) -> None:
    small = dict(browser_truth, rR=0.25)
    with pytest.raises(SimulationError, match="rear wheel pendulum arm"):
        physics.true_readings(small, rig)
    floppy = dict(browser_truth, IBxz=1.0)
    with pytest.raises(SimulationError, match="not positive definite"):
        physics.true_readings(floppy, rig)
    with pytest.raises(SimulationError, match="lack IBxx"):
        physics.true_readings({k: v for k, v in browser_truth.items() if k != "IBxx"}, rig)
    with pytest.raises(SimulationError, match="mB must be positive"):
        physics.true_readings(dict(browser_truth, mB=0.0), rig)
    vertical = float(np.degrees(browser_truth["lam"])) - 90.0
    with pytest.raises(SimulationError, match="orientation 2"):
        physics.true_readings(browser_truth, replace(rig, frame_orientations_deg=(3.4, vertical, 229.8)))
