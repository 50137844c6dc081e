"""Geometry from a surface plate: wheelbase, steer-axis tilt and fork offset (refined method).

Moore's dissertation (2012, section "Geometry"; BicycleParameters' ``Measured.txt`` keys
``h1..h5``, ``d1..d4``, ``d``) measures the frame and fork on a surface plate instead of reading
the wheelbase, head-tube angle and fork offset. The heights and diameters give three offsets
relative to the steer axis:

* ``a`` the rear-frame offset, the perpendicular distance from the rear axle to the steer axis,
* ``b`` the fork offset, the perpendicular distance from the front axle to the steer axis,
* ``c_s`` the steer-axis distance, between the feet of those two perpendiculars along the axis.

With the rear and front axle centres at ``O − a n`` and ``O + c_s s + b n`` (``s`` = (sin λ, cos λ)
down the steer axis, ``n`` = (cos λ, −sin λ) normal to it, benchmark x forward, z down), both wheels
touching the ground (axles at z = −r_R and −r_F) fixes λ and the wheelbase follows.

Every function is plain analytic numpy arithmetic (complex-step safe, broadcasting).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "fork_offset",
    "rear_frame_offset",
    "steer_axis_distance",
    "steer_axis_tilt_from_offsets",
    "wheelbase_from_offsets",
]


def rear_frame_offset(h1: Any, h2: Any, h3: Any, d1: Any, d2: Any) -> Any:
    """Rear-frame offset ``a`` from surface-plate heights (Moore 2012, ``calculate_abc_geometry``).

    Args:
        h1: Surface-plate height (``Measured.txt`` key h1), m.
        h2: Surface-plate height (key h2), m.
        h3: Surface-plate height (key h3), m.
        d1: Diameter of a measured rod/axle (key d1), m.
        d2: Diameter of the rear axle (key d2), m.

    Returns:
        a = h1 + h2 − h3 + d1/2 − d2/2, the perpendicular distance from the rear axle to the
        steer axis, m.
    """
    return h1 + h2 - h3 + 0.5 * d1 - 0.5 * d2


def fork_offset(h4: Any, h5: Any, d3: Any, d4: Any) -> Any:
    """Fork offset ``b`` from surface-plate heights (Moore 2012, ``calculate_abc_geometry``).

    Args:
        h4: Surface-plate height (key h4), m.
        h5: Surface-plate height (key h5), m.
        d3: Diameter of the front axle (key d3), m.
        d4: Diameter of the steer-tube rod (key d4), m.

    Returns:
        b = h4 − d3/2 − h5 + d4/2, the perpendicular distance from the front axle to the steer
        axis, m (the paper's f_o).
    """
    return h4 - 0.5 * d3 - h5 + 0.5 * d4


def steer_axis_distance(a: Any, b: Any, d: Any, d2: Any, d3: Any) -> Any:
    """Steer-axis distance ``c_s`` by Pythagoras (Moore 2012, ``calculate_abc_geometry``).

    Args:
        a: Rear-frame offset, m.
        b: Fork offset, m.
        d: Distance between the facing edges of the axles (key d), m.
        d2: Rear axle diameter, m.
        d3: Front axle diameter, m (``d + (d2 + d3)/2`` is the centre-to-centre distance).

    Returns:
        c_s = sqrt((d + (d2 + d3)/2)² − (a − b)²), m.
    """
    return np.sqrt((d + 0.5 * (d2 + d3)) ** 2 - (a - b) ** 2)


def steer_axis_tilt_from_offsets(rF: Any, rR: Any, a: Any, b: Any, c_s: Any) -> Any:
    """Steer-axis tilt λ that puts both wheels on the ground (Moore 2012, ``lambda_from_abc``).

    Both axle heights in the benchmark frame give ``(a + b) sin λ − c_s cos λ = r_F − r_R``, i.e.
    ``R sin(λ − φ) = r_F − r_R`` with ``R = sqrt((a + b)² + c_s²)`` and ``tan φ = c_s / (a + b)``,
    solved here in closed form (BicycleParameters solves it by Newton's method: same value).

    Args:
        rF: Front wheel radius, m.
        rR: Rear wheel radius, m.
        a: Rear-frame offset, m.
        b: Fork offset, m.
        c_s: Steer-axis distance, m.

    Returns:
        λ = atan(c_s / (a + b)) + asin((r_F − r_R) / sqrt((a + b)² + c_s²)), rad.
    """
    return np.arctan(c_s / (a + b)) + np.arcsin((rF - rR) / np.sqrt((a + b) ** 2 + c_s**2))


def wheelbase_from_offsets(a: Any, b: Any, c_s: Any, lam: Any) -> Any:
    """Wheelbase, the horizontal distance between the axles (Moore 2012, ``calculate_benchmark_geometry``).

    Args:
        a: Rear-frame offset, m.
        b: Fork offset, m.
        c_s: Steer-axis distance, m.
        lam: Steer-axis tilt λ, rad.

    Returns:
        w = (a + b) cos λ + c_s sin λ, m.
    """
    return (a + b) * np.cos(lam) + c_s * np.sin(lam)
