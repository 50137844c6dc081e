"""Geometry from a surface plate: wheelbase, steer-axis tilt and fork offset (refined method).

Moore's dissertation (2012, "Geometry"; BicycleParameters' keys ``h1..h7``, ``d1..d6``, ``d``,
``l``) measures frame and fork with the steer axis parallel to the plate, so heights are normal
to it: the rear-frame offset ``a``, the fork offset ``b`` and, with the fork reversed, the
steer-axis distance ``c_s`` along the axis. Both wheels on the ground then fix λ, and the
wheelbase follows (benchmark x forward, z down). Each function gives its formula and units; what
a reading of 0 means is in ``docs/formats.md``. All are analytic numpy arithmetic
(complex-step safe, broadcasting).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "axle_centre_distance",
    "fork_offset",
    "rear_frame_offset",
    "steer_axis_distance",
    "steer_axis_tilt_from_offsets",
    "tube_clearance",
    "wheelbase_from_offsets",
]


def rear_frame_offset(h1: Any, h2: Any, h3: Any, d1: Any, d2: Any) -> Any:
    """Rear-frame offset ``a`` from surface-plate heights (Moore 2012, ``calculate_abc_geometry``).

    Args:
        h1: Height gauge base to the top of the dummy rear axle (key h1), m.
        h2: Plate to the height gauge's base (key h2), m.
        h3: Plate to the top of the head tube (key h3), m.
        d1: Outer diameter of the head tube (key d1), m.
        d2: Diameter of the dummy rear axle (key d2), m.

    Returns:
        a = h1 + h2 − h3 + d1/2 − d2/2, the perpendicular distance from the rear axle to the
        steer axis, m.
    """
    return h1 + h2 - h3 + 0.5 * d1 - 0.5 * d2


def fork_offset(h4: Any, h5: Any, d3: Any, d4: Any) -> Any:
    """Fork offset ``b`` from surface-plate heights (Moore 2012, ``calculate_abc_geometry``).

    Args:
        h4: Plate to the top of the dummy front axle (key h4), m.
        h5: Plate to the top of the steer tube (key h5), m.
        d3: Diameter of the dummy front axle (key d3), m.
        d4: Outer diameter of the steer tube (key d4), m.

    Returns:
        b = h4 − d3/2 − h5 + d4/2, the perpendicular distance from the front axle to the steer
        axis, m (the paper's f_o).
    """
    return h4 - 0.5 * d3 - h5 + 0.5 * d4


def tube_clearance(top: Any, diameter: Any) -> Any:
    """Gap between the plate and the underside of a tube or axle lying on or above it (Moore 2012).

    A height on the surface plate is read to the top of a round tube or axle (to its axis when
    its diameter is given as 0), so the tube's underside is one diameter lower.

    Args:
        top: Plate to the top of the tube (h3, h4, h5, h6, h7; h1 + h2 for the rear axle), m.
        diameter: The tube's outer diameter (d1…d6), m; 0 when the height is read to its axis.

    Returns:
        top − diameter, m: ≥ 0 for any tube resting on or above the plate.
    """
    return top - diameter


def axle_centre_distance(d: Any, d2: Any, d3: Any) -> Any:
    """Distance between the rear and front axle centres, the fork reversed (Moore 2012, ``calculate_abc_geometry``).

    Args:
        d: Inside distance between the axles (key d), m; read to an axle's centre when that
            axle's diameter is given as 0.
        d2: Rear axle diameter, m.
        d3: Front axle diameter, m.

    Returns:
        d + (d2 + d3)/2, m: the hypotenuse of the triangle whose legs are |a − b| across the steer
        axis and c_s along it, so it must exceed |a − b|.
    """
    return d + 0.5 * (d2 + d3)


def steer_axis_distance(a: Any, b: Any, d: Any, d2: Any, d3: Any) -> Any:
    """Steer-axis distance ``c_s`` by Pythagoras, the fork reversed (Moore 2012, ``calculate_abc_geometry``).

    Args:
        a: Rear-frame offset, m.
        b: Fork offset, m.
        d: Inside distance between the rear and front axles with the fork reversed (key d), m.
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
