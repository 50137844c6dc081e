"""Geometry from a surface plate: wheelbase, steer-axis tilt and fork offset (refined method).

Moore's dissertation (2012, section "Geometry"; BicycleParameters' ``Measured.txt`` keys
``h1..h5``, ``d1..d4``, ``d``, defined in its ``docs/data.rst``) measures the frame and fork on a
surface plate with the steer axis parallel to the plate, so that heights are distances normal to
the steer axis:

* ``a`` the rear-frame offset, the perpendicular distance from the rear axle to the steer axis:
  the rear axle's centre (h1 + h2 − d2/2: the height gauge on a block h2 reads h1 to the top of
  a dummy axle of diameter d2) above the head tube's axis (h3 − d1/2: top of the head tube of
  outer diameter d1),
* ``b`` the fork offset, the front axle's centre (h4 − d3/2) above the steer tube's axis
  (h5 − d4/2),
* ``c_s`` the steer-axis distance, between the feet of those two perpendiculars along the axis:
  with the fork reversed both axles lie on the same side of the steer axis, their centres
  (inside distance d, so d + (d2 + d3)/2 apart) differ by a − b across the axis and c_s along it.

With the rear and front axle centres at ``O − a n`` and ``O + c_s s + b n`` in riding position
(``s`` = (sin λ, cos λ) down the steer axis, ``n`` = (cos λ, −sin λ) normal to it, benchmark x
forward, z down), both wheels touching the ground (axles at z = −r_R and −r_F) fixes λ and the
wheelbase follows.

What a zero reading means (BicycleParameters computes such files as they are, and so do we):

* a diameter ``d1``…``d4`` of 0: that height was read to the tube's or axle's axis itself (a
  centre mark), not to the top of a round tube; for ``d2``, ``d3`` also the distance ``d`` was
  read to that axle's centre;
* ``h2`` = 0: the height gauge stood on the plate itself;
* ``h4`` = ``h5`` = 0 with ``d3`` = ``d4`` = 0: the front axle's centre and the steer axis are at the
  same height, a fork offset b of exactly 0 (the front axle on the steer axis);
* any tube or axle still lies on or above the plate (its top at least its diameter up), and the
  offsets must close Pythagoras' triangle: :func:`tube_clearance`, :func:`axle_centre_distance`.

Every function is plain analytic numpy arithmetic (complex-step safe, broadcasting).
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
