"""The refined method's readings from the truth: surface-plate geometry, fork and handlebar apart.

The inverses of :mod:`bike_rig.core.surface_plate` and :mod:`bike_rig.core.split_fork`, as
:mod:`.physics` inverts the paper's equations. The bicycle's fixed dimensions that the truth
does not determine (the surface plate's fixture heights and the rods' and axles' diameters:
``h2, h3, h5, d1..d4``; the front axle's height and diameter and the handlebar reference
circle's diameter: ``h6, d5, d6``) come with the truth, as does the handlebar reference centre
(``l1``, ``l2``: across and along the steer axis from the front axle), since the 25 parameters
do not fix them. :func:`refined_truth` takes them all from a measurement file of that method.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .. import com, split_fork
from ..benchmark import SPLIT_PART_NAMES
from ..measurements import Measurements, fork_is_split, geometry_from_surface_plate
from ..units import radians
from .errors import SimulationError
from .physics import (
    MIN_COS_BETA,
    compound_period,
    fork_offset,
    fork_string_distance,
    pendulum_axis_inertia,
    torsional_period,
)

__all__ = [
    "HANDLEBAR_FIXTURE_KEYS",
    "PLATE_FIXTURE_KEYS",
    "SPLIT_TRUTH_KEYS",
    "handlebar_reference_readings",
    "handlebar_string_distance",
    "is_split",
    "refined_truth",
    "split_fork_readings",
    "surface_plate_readings",
    "uses_surface_plate",
]

#: The surface plate's fixed dimensions (fixture heights, rod and axle diameters), m.
PLATE_FIXTURE_KEYS = ("h2", "h3", "h5", "d1", "d2", "d3", "d4")
#: The handlebar reference's fixed dimensions (front axle height and diameter, circle diameter), m.
HANDLEBAR_FIXTURE_KEYS = ("h6", "d5", "d6")
#: The per-part truth of a split fork, and the handlebar reference centre (l1, l2 in m).
SPLIT_TRUTH_KEYS = SPLIT_PART_NAMES + ("l1", "l2")


def uses_surface_plate(truth: Mapping[str, float]) -> bool:
    """Whether the truth carries a surface plate's fixed dimensions (simulate its readings)."""
    return all(k in truth for k in PLATE_FIXTURE_KEYS)


def is_split(truth: Mapping[str, float]) -> bool:
    """Whether the truth has the fork S and handlebar G apart (simulate them hung separately)."""
    return all(k in truth for k in SPLIT_TRUTH_KEYS + HANDLEBAR_FIXTURE_KEYS)


def surface_plate_readings(p: Mapping[str, float]) -> dict[str, float]:
    """Heights h1, h4 and distance d that give the true λ, w and trail (inverse of ``core.surface_plate``).

    Both axles on the ground give a + b = w cos λ + (r_F − r_R) sin λ and c_s = w sin λ −
    (r_F − r_R) cos λ; b is the fork offset (inverse Eq 8), then h1, h4 and d follow from the
    plate's fixed dimensions.

    Args:
        p: The true parameters (w, lam, c, rF, rR) and the plate's fixed dimensions
            (:data:`PLATE_FIXTURE_KEYS`), m and rad.

    Returns:
        Every surface-plate reading h1..h5, d1..d4, d, m.
    """
    lam, w, rF, rR = p["lam"], p["w"], p["rF"], p["rR"]
    a_plus_b = w * np.cos(lam) + (rF - rR) * np.sin(lam)
    c_s = w * np.sin(lam) - (rF - rR) * np.cos(lam)
    b = fork_offset(rF, lam, p["c"])
    a = a_plus_b - b
    out = {k: float(p[k]) for k in PLATE_FIXTURE_KEYS}
    out["h1"] = float(a - p["h2"] + p["h3"] - 0.5 * p["d1"] + 0.5 * p["d2"])
    out["h4"] = float(b + 0.5 * p["d3"] + p["h5"] - 0.5 * p["d4"])
    out["d"] = float(np.sqrt(c_s**2 + (a - b) ** 2) - 0.5 * (p["d2"] + p["d3"]))
    return out


def handlebar_reference_readings(p: Mapping[str, float]) -> dict[str, float]:
    """h7 and l that place the handlebar reference centre at (l1, l2) (inverse of ``handlebar_reference_offsets``).

    Returns:
        h6, h7, d5, d6, l, m.
    """
    out = {k: float(p[k]) for k in HANDLEBAR_FIXTURE_KEYS}
    out["h7"] = float(p["l1"] + p["h6"] - 0.5 * p["d5"] + 0.5 * p["d6"])
    out["l"] = float(np.hypot(p["l1"], p["l2"]) + 0.5 * p["d5"] + 0.5 * p["d6"])
    return out


def handlebar_string_distance(x: Any, z: Any, beta: Any, w: Any, rF: Any, u1: Any, u2: Any) -> Any:
    """String-to-reference-centre distance of the hanging handlebar (inverse of ``handlebar_com_line_intercept``).

    Returns:
        a = ((w − u1) tan β − r_F − u2 − b) cos β with b = z + x tan β, m.
    """
    b = z - com.com_line_slope(beta) * x
    return ((w - u1) * np.tan(beta) - rF - u2 - b) * np.cos(beta)


def split_fork_readings(
    p: Mapping[str, float], angles_deg: Sequence[float], k: float
) -> tuple[dict[str, float], dict[str, float]]:
    """Static readings and true periods of the fork S and the handlebar G hung apart.

    Args:
        p: The true parameters with the per-part truth and l1, l2 (:data:`SPLIT_TRUTH_KEYS`).
        angles_deg: The hanging angles of both parts, degree (the rig's fork orientations).
        k: The torsion rod's stiffness, N m/rad.

    Returns:
        (static readings by flat key, true periods by flat key).

    Raises:
        SimulationError: An orientation hangs a part with its axis vertical (cos β ≈ 0).
    """
    lam, w, rF, g = p["lam"], p["w"], p["rF"], p["g"]
    u1, u2 = split_fork.handlebar_reference_point(lam, p["l1"], p["l2"])
    pivots = {"S": (w, -rF), "G": (w - u1, -rF - u2)}
    static: dict[str, float] = handlebar_reference_readings(p)
    periods: dict[str, float] = {}
    for part in "SG":
        x, z, m = p[f"x{part}"], p[f"z{part}"], p[f"m{part}"]
        static[f"m{part}"] = m
        length = split_fork.pivot_distance(x, z, *pivots[part])
        periods[f"Tc{part}1"] = float(compound_period(p[f"I{part}yy"], m, length, g))  # Eq 28
        for i, alpha in enumerate(angles_deg, start=1):
            beta = com.pendulum_rotation_angle(lam, radians(alpha))  # Eq 10
            if abs(np.cos(beta)) < MIN_COS_BETA:
                raise SimulationError(f"part {part} orientation {i} ({alpha:g}°) hangs with cos β ≈ 0")
            if part == "S":
                a = fork_string_distance(x, z, beta, w, rF)
            else:
                a = handlebar_string_distance(x, z, beta, w, rF, u1, u2)
            static[f"alpha{part}{i}"] = float(alpha)
            static[f"a{part}{i}"] = float(a)
            J = pendulum_axis_inertia(p[f"I{part}xx"], p[f"I{part}xz"], p[f"I{part}zz"], beta)  # Eq 31–34
            periods[f"Tt{part}{i}"] = float(torsional_period(J, k))  # Eq 30
    return static, periods


def refined_truth(m: Measurements, computed: Mapping[str, float]) -> dict[str, float]:
    """What a simulation needs beyond the parameters to repeat a refined measurement of ``m``.

    Args:
        m: A measurement of the refined method (surface plate and/or split fork).
        computed: Its computed parameters and per-part outputs.

    Returns:
        The plate's fixed dimensions (surface plate), the handlebar reference's and l1, l2 and
        the per-part truth (split fork); empty for a measurement of the paper's method.
    """
    out: dict[str, float] = {}
    if geometry_from_surface_plate(m.readings):
        out.update({k: m.value(k) for k in PLATE_FIXTURE_KEYS})
    if fork_is_split(m.readings):
        out.update({k: m.value(k) for k in HANDLEBAR_FIXTURE_KEYS})
        l1, l2 = split_fork.handlebar_reference_offsets(*(m.value(k) for k in ("h6", "h7", "d5", "d6", "l")))
        out.update({"l1": float(l1), "l2": float(l2)})
        out.update({k: float(computed[k]) for k in SPLIT_TRUTH_KEYS if k in computed})
    return out
