"""Each paper equation on cases whose answer follows from the physics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bike_rig.core import com, geometry, inertia
from bike_rig.core.units import radians


def test_wheel_radius_eq6() -> None:
    assert geometry.wheel_radius(2 * np.pi * 0.3 * 13, 13) == pytest.approx(0.3, rel=1e-15)


def test_steer_axis_tilt_eq7_and_trail_eq8_round_trip() -> None:
    lam = geometry.steer_axis_tilt(radians(72.0))
    assert lam == pytest.approx(np.pi / 10, rel=1e-15)
    # the Meijaard benchmark: rF = 0.35, λ = π/10, c = 0.08 ⇒ f_o = rF sin λ − c cos λ
    f_o = 0.35 * np.sin(lam) - 0.08 * np.cos(lam)
    assert geometry.trail(0.35, lam, f_o) == pytest.approx(0.08, rel=1e-14)


@settings(max_examples=50, deadline=None)
@given(x0=st.floats(0.1, 1.0), z0=st.floats(-1.0, -0.2), a=st.floats(-0.5, 0.5), alpha=st.floats(-170.0, 170.0))
def test_com_line_intercepts_are_at_the_measured_distance(x0: float, z0: float, a: float, alpha: float) -> None:
    """Eq 14 and Eq 21: the pendulum axis passes at perpendicular distance |a| from the axle."""
    lam, rR, rF, w = 0.35, 0.34, 0.345, 1.1
    beta = com.pendulum_rotation_angle(lam, radians(alpha))
    if abs(np.cos(beta)) < 0.05:
        return
    m = com.com_line_slope(beta)
    for b, (ax, az) in (
        (com.frame_com_line_intercept(a, beta, rR), (0.0, -rR)),
        (com.fork_com_line_intercept(a, beta, w, rF), (w, -rF)),
    ):
        distance = (az - m * ax - b) / np.sqrt(1 + m * m)
        assert abs(distance) == pytest.approx(abs(a), abs=1e-12)


def test_both_com_methods_recover_an_exact_centre() -> None:
    x0, z0 = 0.31, -0.52
    betas = radians(np.array([10.0, 75.0, 140.0, 200.0]))
    slopes = [com.com_line_slope(b) for b in betas]
    intercepts = [z0 - s * x0 for s in slopes]
    for n in (2, 3, 4):
        for method in (com.centroid_com, com.least_squares_com):
            x, z = method(slopes[:n], intercepts[:n])
            assert (x, z) == pytest.approx((x0, z0), abs=1e-13)


def test_centroid_and_least_squares_differ_for_inconsistent_lines() -> None:
    slopes = [0.0, 1.0, -1.0]
    intercepts = [0.0, -1.0, -3.0]  # triangle (1, 0), (3, 0), (-1, -2)... not concurrent
    xc, zc = com.centroid_com(slopes, intercepts)
    xl, zl = com.least_squares_com(slopes, intercepts)
    pairs = ((0, 1), (0, 2), (1, 2))
    pts = [com.line_intersection(slopes[i], intercepts[i], slopes[j], intercepts[j]) for i, j in pairs]
    assert (xc, zc) == pytest.approx(tuple(np.mean(pts, axis=0)))

    # least squares minimises the summed squared vertical residuals; the centroid does not
    def cost(x: float, z: float) -> float:
        return sum((z - s * x - b) ** 2 for s, b in zip(slopes, intercepts))

    assert cost(xl, zl) < cost(xc, zc)


def test_rod_and_pendulum_inertias() -> None:
    assert inertia.rod_inertia(6.0, 2.0, 0.0) == pytest.approx(2.0)  # m l² / 12
    k = inertia.torsional_stiffness(0.5, 2.0)
    assert inertia.torsional_pendulum_inertia(k, 2.0) == pytest.approx(0.5)
    # compound pendulum: T = 2π sqrt((I + m l²) / (m g l)) inverted by Eq 28
    i_c, m, g, length = 0.12, 3.0, 9.81, 0.3
    T = 2 * np.pi * np.sqrt((i_c + m * length**2) / (m * g * length))
    assert inertia.compound_pendulum_inertia(m, g, length, T) == pytest.approx(i_c, rel=1e-13)


@settings(max_examples=50, deadline=None)
@given(
    ixx=st.floats(0.1, 2.0),
    izz=st.floats(0.1, 2.0),
    ixz_frac=st.floats(-0.9, 0.9),
    n=st.integers(3, 6),
    offset=st.floats(0.0, 180.0),
)
def test_inertia_tensor_from_any_number_of_orientations(
    ixx: float, izz: float, ixz_frac: float, n: int, offset: float
) -> None:
    """Eq 31–35: moments about n ≥ 3 axes, J_i = R_i I R_iᵀ (first entry), give back I."""
    ixz = ixz_frac * np.sqrt(ixx * izz)
    tensor = np.array([[ixx, ixz], [ixz, izz]])
    betas = radians(offset + np.arange(n) * 180.0 / n)
    J = []
    for b in betas:
        R = np.array([[np.cos(b), -np.sin(b)], [np.sin(b), np.cos(b)]])  # Eq 33
        J.append((R @ tensor @ R.T)[0, 0])  # Eq 31
    got = inertia.inertia_from_pendulum_axes(J, list(betas))
    assert np.allclose(got, (ixx, ixz, izz), rtol=1e-10, atol=1e-12)


def test_pendulum_lengths_eq36_eq37() -> None:
    assert inertia.frame_pendulum_length(0.3, -0.74, 0.34) == pytest.approx(0.5)
    assert inertia.fork_pendulum_length(1.4, -0.745, 1.1, 0.345) == pytest.approx(0.5)
