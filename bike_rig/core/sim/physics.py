"""The paper's physics inverted: from a bicycle's true parameters to what the rig reads.

The science core (:mod:`bike_rig.core.geometry`, :mod:`~bike_rig.core.com`,
:mod:`~bike_rig.core.inertia`) turns readings into parameters, one paper equation per
function. Each function here is the inverse of one of them, named after what it produces,
and reuses the forward functions wherever the paper's equation is itself a forward model
(β = λ − α, the hanging-line slope, the rod's inertia, the pendulum lengths). The tests put
every true reading back through the core's chain and get the true parameters to 1e-10.

:func:`true_readings` applies them all to one bicycle on one rig.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import com, inertia
from ..symbols import PARAMETER_NAMES
from ..units import DEGREE, radians
from .errors import SimulationError
from .plan import PlannedMeasurement, measurement_plan
from .rig import RigConfig

__all__ = [
    "TrueReadings",
    "compound_period",
    "distance_rolled",
    "fork_offset",
    "fork_string_distance",
    "frame_string_distance",
    "head_tube_angle",
    "pendulum_axis_inertia",
    "torsional_period",
    "true_readings",
]

#: Smallest |cos β| of a hanging orientation: Eq 14 and Eq 21 divide by cos β.
MIN_COS_BETA = 1e-3


def distance_rolled(r: Any, n: Any) -> Any:
    """Distance a wheel rolls in ``n`` rotations, m (inverse of Eq 6).

    Args:
        r: Wheel radius, m.
        n: Whole rotations, 1.

    Returns:
        d = 2 π n r, m.
    """
    return 2.0 * np.pi * n * r


def head_tube_angle(lam: Any) -> Any:
    """Head-tube angle from the horizontal, rad (inverse of Eq 7).

    Args:
        lam: Steer-axis tilt λ, rad.

    Returns:
        λ_ht = π/2 − λ, rad (the measurement file holds it in degrees).
    """
    return np.pi / 2.0 - lam


def fork_offset(rF: Any, lam: Any, c: Any) -> Any:
    """Fork offset that gives trail ``c`` (inverse of Eq 8).

    Args:
        rF: Front wheel radius, m.
        lam: Steer-axis tilt λ, rad.
        c: Trail, m.

    Returns:
        f_o = r_F sin λ − c cos λ, m.
    """
    return rF * np.sin(lam) - c * np.cos(lam)


def _axis_intercept(x: Any, z: Any, beta: Any) -> Any:
    """z-intercept b of the hanging line of slope m(β) (Eq 12) through the mass centre (x, z)."""
    return z - com.com_line_slope(beta) * x


def frame_string_distance(xB: Any, zB: Any, beta: Any, rR: Any) -> Any:
    """String-to-rear-axle distance when the frame hangs with its mass centre on the axis (inverse Eq 14).

    The pendulum axis passes through the mass centre (x_B, z_B) with slope −tan β (Eq 12),
    so its intercept is b = z_B + x_B tan β, and Eq 14, b = −(a / cos β + r_R), gives a.

    Args:
        xB: Mass centre, m (benchmark frame).
        zB: Mass centre, m (z down).
        beta: Rotation of the hanging orientation, rad (Eq 10).
        rR: Rear wheel radius, m.

    Returns:
        a = −(b + r_R) cos β, m; positive when the string passes left of the rear axle.
    """
    return -(_axis_intercept(xB, zB, beta) + rR) * np.cos(beta)


def fork_string_distance(xH: Any, zH: Any, beta: Any, w: Any, rF: Any) -> Any:
    """String-to-front-axle distance of the hanging fork/handlebar (inverse Eq 21).

    Eq 21, b = w tan β − r_F − a / cos β, with b the intercept of the line through (x_H, z_H).

    Returns:
        a = (w tan β − r_F − b) cos β, m; positive when the string passes left of the front axle.
    """
    return (w * np.tan(beta) - rF - _axis_intercept(xH, zH, beta)) * np.cos(beta)


def pendulum_axis_inertia(Ixx: Any, Ixz: Any, Izz: Any, beta: Any) -> Any:
    """Moment of inertia about the pendulum axis of a hanging orientation (Eq 31–34).

    Args:
        Ixx: In-plane inertia tensor entries in the benchmark frame, kg m².
        Ixz: kg m² (tensor entry, not the negated product of inertia).
        Izz: kg m².
        beta: Rotation of the orientation, rad (Eq 10).

    Returns:
        J = (R I Rᵀ)₁₁ with R = [[cos β, −sin β], [sin β, cos β]] (Eq 33), kg m².
    """
    c, s = np.cos(beta), np.sin(beta)
    R = np.array([[c, -s], [s, c]])
    tensor = np.array([[Ixx, Ixz], [Ixz, Izz]])
    J = np.einsum("i...,ij...,j...->...", R[0], tensor, R[0])
    return J[()] if np.ndim(J) == 0 else J


def torsional_period(J: Any, k: Any) -> Any:
    """Period of a torsional pendulum (inverse of Eq 29, Eq 30 and Fig 9).

    Args:
        J: Moment of inertia about the torsion-rod axis, kg m².
        k: Torsion-rod stiffness, N m/rad.

    Returns:
        T = 2 π √(J / k), s.
    """
    return 2.0 * np.pi * np.sqrt(J / k)


def compound_period(I: Any, m: Any, l: Any, g: Any) -> Any:  # noqa: E741  (paper symbols)
    """Period of a compound pendulum (inverse of Eq 28).

    Args:
        I: Moment of inertia about the mass centre, about the pivot's direction, kg m².
        m: Mass, kg.
        l: Pivot to mass centre, m.
        g: Acceleration of gravity, m/s².

    Returns:
        T = 2 π √((I + m l²) / (m g l)), s.
    """
    return 2.0 * np.pi * np.sqrt((I + m * l**2) / (m * g * l))


@dataclass(frozen=True)
class TrueReadings:
    """What a perfect rig would read for one bicycle.

    Attributes:
        static: True value of every static reading under its flat key (``g``, ``w``,
            ``gamma`` in degrees, ``f``, ``nR``, ``dR``, ... ``alphaB1`` in degrees, ``aB1``, ...).
        periods: True (undamped) period of every planned measurement by flat key, s.
        stiffness: The torsion rod's k, N m/rad.
        rod_inertia: The calibration rod's inertia about the torsion axis, kg m².
        plan: The planned measurements, in order.
    """

    static: Mapping[str, float]
    periods: Mapping[str, float]
    stiffness: float
    rod_inertia: float
    plan: tuple[PlannedMeasurement, ...]


def _check_parameters(p: Mapping[str, float], rig: RigConfig) -> None:
    missing = [k for k in PARAMETER_NAMES if k not in p]
    if missing:
        raise SimulationError(f"true parameters lack {', '.join(missing)}")
    bad = [k for k in PARAMETER_NAMES if not np.isfinite(p[k])]
    if bad:
        raise SimulationError(f"true parameters are not finite: {', '.join(bad)}")
    for k in ("g", "w", "mB", "mF", "mH", "mR", "rF", "rR", "IRxx", "IRyy", "IFxx", "IFyy", "IByy", "IHyy"):
        if p[k] <= 0:
            raise SimulationError(f"true parameter {k} must be positive, got {p[k]:g}")
    if not abs(p["lam"]) < np.pi / 2:
        raise SimulationError(f"steer-axis tilt lam must lie within ±90°, got {p['lam']:g} rad")
    for part in "BH":
        xx, xz, zz = p[f"I{part}xx"], p[f"I{part}xz"], p[f"I{part}zz"]
        if not (xx > 0 and zz > 0 and xx * zz - xz * xz > 0):
            raise SimulationError(
                f"the in-plane inertia tensor of {'the frame' if part == 'B' else 'the fork'} "
                f"(I{part}xx {xx:g}, I{part}xz {xz:g}, I{part}zz {zz:g}) is not positive definite"
            )
    for name, fixture, r in (("rear", rig.rear_wheel, p["rR"]), ("front", rig.front_wheel, p["rF"])):
        if fixture.pendulum_arm >= r:
            raise SimulationError(
                f"the rig's {name} wheel pendulum arm ({fixture.pendulum_arm:g} m) is not shorter than the "
                f"wheel radius ({r:g} m): the wheel cannot hang from its rim on that rod"
            )


def true_readings(params: Mapping[str, float], rig: RigConfig) -> TrueReadings:
    """Every reading of a session on a perfect rig, from the true benchmark parameters.

    Args:
        params: The 25 benchmark parameters and g (:data:`~bike_rig.core.symbols.PARAMETER_NAMES`),
            SI, ``lam`` in rad; with the refined method's truth (:func:`.refined.refined_truth`)
            the geometry is read on a surface plate and/or the fork and handlebar are hung apart.
        rig: The rig: orientations, wheel fixtures, torsion and calibration rods.

    Returns:
        The true static readings and true periods.

    Raises:
        SimulationError: the parameters are impossible or the rig cannot measure them.
    """
    from . import refined  # the refined method's inverses build on this module's

    _check_parameters(params, rig)
    split, plate = refined.is_split(params), refined.uses_surface_plate(params)
    p = {k: float(params[k]) for k in PARAMETER_NAMES}
    g, w, lam, rR, rF = p["g"], p["w"], p["lam"], p["rR"], p["rF"]
    rod = rig.calibration_rod
    static: dict[str, float] = {
        "g": g,
        "w": w,
        "gamma": head_tube_angle(lam) / DEGREE,  # Eq 7 inverted, degrees
        "f": fork_offset(rF, lam, p["c"]),  # Eq 8 inverted
        "nR": float(rig.rear_wheel.rotations),
        "dR": distance_rolled(rR, rig.rear_wheel.rotations),  # Eq 6 inverted
        "mR": p["mR"],
        "lR": rig.rear_wheel.pendulum_arm,
        "nF": float(rig.front_wheel.rotations),
        "dF": distance_rolled(rF, rig.front_wheel.rotations),
        "mF": p["mF"],
        "lF": rig.front_wheel.pendulum_arm,
        "mB": p["mB"],
        "mH": p["mH"],
        "mP": rod.mass,
        "lP": rod.length,
        "dP": rod.diameter,
    }
    k = rig.stiffness
    rod_inertia = float(inertia.rod_inertia(rod.mass, rod.length, rod.diameter))  # Fig 9
    periods: dict[str, float] = {
        "TcR1": compound_period(p["IRyy"], p["mR"], rig.rear_wheel.pendulum_arm, g),  # Eq 28
        "TtR1": torsional_period(p["IRxx"], k),  # Eq 29
        "TcF1": compound_period(p["IFyy"], p["mF"], rig.front_wheel.pendulum_arm, g),
        "TtF1": torsional_period(p["IFxx"], k),
        "TcB1": compound_period(p["IByy"], p["mB"], inertia.frame_pendulum_length(p["xB"], p["zB"], rR), g),  # Eq 36
        "TcH1": compound_period(p["IHyy"], p["mH"], inertia.fork_pendulum_length(p["xH"], p["zH"], w, rF), g),  # 37
        "TtP1": torsional_period(rod_inertia, k),
    }
    extra = {k: float(v) for k, v in params.items() if k not in p}
    if plate:
        for key in ("w", "gamma", "f"):
            del static[key]
        static.update(refined.surface_plate_readings({**p, **extra}))
    hung = [("B", rig.frame_orientations_deg)]
    if split:
        del static["mH"], periods["TcH1"]
        split_static, split_periods = refined.split_fork_readings({**p, **extra}, rig.fork_orientations_deg, k)
        static.update(split_static)
        periods.update(split_periods)
    else:
        hung.append(("H", rig.fork_orientations_deg))
    for part, angles in hung:
        for i, alpha in enumerate(angles, start=1):
            beta = com.pendulum_rotation_angle(lam, radians(alpha))  # Eq 10
            if abs(np.cos(beta)) < MIN_COS_BETA:
                raise SimulationError(
                    f"{'frame' if part == 'B' else 'fork'} orientation {i} ({alpha:g}°) hangs the part with its "
                    "pendulum axis vertical in the benchmark frame (cos β ≈ 0): Eq 14/21 cannot use it"
                )
            if part == "B":
                a = frame_string_distance(p["xB"], p["zB"], beta, rR)
            else:
                a = fork_string_distance(p["xH"], p["zH"], beta, w, rF)
            static[f"alpha{part}{i}"] = float(alpha)
            static[f"a{part}{i}"] = float(a)
            J = pendulum_axis_inertia(p[f"I{part}xx"], p[f"I{part}xz"], p[f"I{part}zz"], beta)  # Eq 31–34
            periods[f"Tt{part}{i}"] = torsional_period(J, k)  # Eq 30
    plan = measurement_plan(len(rig.frame_orientations_deg), len(rig.fork_orientations_deg), split)
    ordered = {m.key: float(periods[m.key]) for m in plan}
    return TrueReadings({k_: float(v) for k_, v in static.items()}, ordered, k, rod_inertia, plan)
