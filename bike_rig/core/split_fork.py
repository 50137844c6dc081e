"""Fork ``S`` and handlebar ``G`` hung separately, combined into the front assembly ``H``.

Moore's dissertation (2012) hangs the fork and the handlebar as two pendulums. The fork pivots
about the front axle like the paper's fork/handlebar (Eq 21, Eq 37); the handlebar, which has no
axle, pivots about a reference circle on it, located from the front axle with the fork clamped
on a surface plate (keys ``h6, h7, d5, d6, l``). The two parts' masses, mass centres and inertia
tensors then add up to the benchmark's front assembly ``H`` (sum of masses, mass-weighted mean of
the mass centres, parallel-axis theorem).

Every function is plain analytic numpy arithmetic (complex-step safe, broadcasting).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "combined_mass_centre",
    "handlebar_centre_distance",
    "handlebar_com_line_intercept",
    "handlebar_normal_offset",
    "handlebar_reference_offsets",
    "handlebar_reference_point",
    "parallel_axis_inertia",
    "pivot_distance",
]


def handlebar_reference_offsets(h6: Any, h7: Any, d5: Any, d6: Any, l: Any) -> tuple[Any, Any]:  # noqa: E741
    """The handlebar reference centre relative to the front axle centre, across and along the steer axis.

    The fork lies on the surface plate with its steer axis parallel to the plate, so heights
    above the plate are distances normal to the steer axis (Moore 2012; BicycleParameters
    ``calculate_l1_l2``).

    Args:
        h6: Plate to the top of the front axle, m.
        h7: Plate to the top of the handlebar reference circle, m.
        d5: Front axle diameter, m.
        d6: Handlebar reference circle diameter, m.
        l: Outer distance from the front axle to the reference circle, m.

    Returns:
        (l1, l2): l1 = h7 − h6 + d5/2 − d6/2 normal to the steer axis (positive forward), and
        l2 = sqrt(l0² − l1²) along it (positive up), with l0 = l − d5/2 − d6/2 the distance
        between the centres, m.
    """
    l1 = handlebar_normal_offset(h6, h7, d5, d6)
    l0 = handlebar_centre_distance(l, d5, d6)
    return l1, np.sqrt(l0**2 - l1**2)


def handlebar_normal_offset(h6: Any, h7: Any, d5: Any, d6: Any) -> Any:
    """Offset l1 of the handlebar reference centre from the front axle's across the steer axis (``calculate_l1_l2``).

    Args:
        h6: Plate to the top of the front axle, m (to its axis when d5 is 0).
        h7: Plate to the top of the handlebar reference circle, m (to its centre when d6 is 0).
        d5: Front axle diameter, m.
        d6: Handlebar reference circle diameter, m.

    Returns:
        l1 = h7 − h6 + d5/2 − d6/2, m.
    """
    return h7 - h6 + 0.5 * d5 - 0.5 * d6


def handlebar_centre_distance(l: Any, d5: Any, d6: Any) -> Any:  # noqa: E741
    """Distance from the front axle centre to the handlebar reference centre (BicycleParameters ``calculate_l1_l2``).

    Args:
        l: Outer distance from the front axle to the reference circle, m (to a centre whose
            diameter is given as 0).
        d5: Front axle diameter, m.
        d6: Handlebar reference circle diameter, m.

    Returns:
        l0 = l − d5/2 − d6/2, m: the hypotenuse over l1 (normal to the steer axis) and l2 (along
        it), so it must exceed |l1|.
    """
    return l - 0.5 * d5 - 0.5 * d6


def handlebar_reference_point(lam: Any, l1: Any, l2: Any) -> tuple[Any, Any]:
    """Benchmark-frame offsets (u1, u2) from the handlebar reference centre back and up to the front axle.

    The reference centre lies l2 up the steer axis, direction (−sin λ, −cos λ), and l1 along its
    forward normal (cos λ, −sin λ) from the front axle (x = w, z = −r_F), i.e. at
    (w − u1, −r_F − u2) (BicycleParameters ``fwheel_to_handlebar_ref``).

    Args:
        lam: Steer-axis tilt λ, rad.
        l1: Offset normal to the steer axis (forward positive), m.
        l2: Offset along the steer axis (up positive), m.

    Returns:
        (u1, u2) = (l2 sin λ − l1 cos λ, l2 cos λ + l1 sin λ), m.
    """
    return l2 * np.sin(lam) - l1 * np.cos(lam), l2 * np.cos(lam) + l1 * np.sin(lam)


def handlebar_com_line_intercept(a: Any, beta: Any, w: Any, rF: Any, u1: Any, u2: Any) -> Any:
    """z-intercept of a handlebar pendulum axis through its reference centre (Eq 21 for this pivot).

    A line of slope −tan β passing at horizontal distance ``a`` from the pivot (x_p, z_p) =
    (w − u1, −r_F − u2) has intercept z_p + x_p tan β − a / cos β (as Eq 14 and Eq 21 for their pivots).

    Args:
        a: Horizontal distance from the pendulum axis to the reference centre, m (sign as Eq 21).
        beta: Rotation angle of the orientation, rad (Eq 10).
        w: Wheelbase, m.
        rF: Front wheel radius, m.
        u1: Reference centre offset back from the front axle (:func:`handlebar_reference_point`), m.
        u2: Reference centre offset up from the front axle, m.

    Returns:
        b = (w − u1) tan β − r_F − u2 − a / cos β, m.
    """
    return (w - u1) * np.tan(beta) - rF - u2 - a / np.cos(beta)


def pivot_distance(x: Any, z: Any, x_p: Any, z_p: Any) -> Any:
    """Distance from a compound pendulum's pivot to the part's mass centre (as Eq 36, Eq 37).

    Returns:
        l = sqrt((x − x_p)² + (z − z_p)²), m.
    """
    return ((x - x_p) ** 2 + (z - z_p) ** 2) ** 0.5


def combined_mass_centre(masses: Sequence[Any], xs: Sequence[Any], zs: Sequence[Any]) -> tuple[Any, Any, Any]:
    """Total mass and mass centre of rigidly joined parts.

    Returns:
        (m, x, z) = (Σ m_i, Σ m_i x_i / m, Σ m_i z_i / m), kg and m.
    """
    m = sum(masses)
    x = sum(mi * xi for mi, xi in zip(masses, xs)) / m
    z = sum(mi * zi for mi, zi in zip(masses, zs)) / m
    return m, x, z


def parallel_axis_inertia(
    Ixx: Any, Iyy: Any, Izz: Any, Ixz: Any, m: Any, dx: Any, dz: Any
) -> tuple[Any, Any, Any, Any]:
    """A symmetric part's inertia tensor moved from its mass centre to a point (parallel-axis theorem).

    For a displacement (dx, 0, dz) from the new point to the part's mass centre (the part lies
    in the bicycle's x–z symmetry plane, so the y offset is zero). ``Ixz`` is the tensor's
    off-diagonal element (−∫xz dm), the benchmark's convention.

    Returns:
        (I_xx + m dz², I_yy + m (dx² + dz²), I_zz + m dx², I_xz − m dx dz), kg m².
    """
    return Ixx + m * dz**2, Iyy + m * (dx**2 + dz**2), Izz + m * dx**2, Ixz - m * dx * dz
