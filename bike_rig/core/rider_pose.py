"""Seat a Yeadon human on the bicycle: feet on the bottom bracket, hands on the grips.

As BicycleParameters' ``rider_on_bike`` (Moore's dissertation, ch. 4): the hip joint centre
sits at the top of the seat post, the torso keeps the configuration's angles, and each limb's
joint angles are solved (:func:`solve_pose`) so that a leg's heel point (``Lj5L + Lj6L`` from
the hip) lies on the bottom-bracket axis (hip and knee, 2 equations) and a hand's thumb base
(``La4L + La5L`` from the shoulder) on its grip with the elbow's hinge axis horizontal (shoulder
and elbow, 4 equations), through yeadon's own kinematics. Each solution is checked; a pose out
of reach raises :class:`RiderPoseError` naming the geometry. Lengths in m, angles in rad.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .rider import RiderError

__all__ = [
    "LIMBS",
    "POSE_TOLERANCE",
    "YEADON_TO_BENCHMARK",
    "Limb",
    "RiderPoseError",
    "bottom_bracket_point",
    "grip_point",
    "limb_end_point",
    "limb_residual",
    "pose_residual",
    "reaching_lean",
    "seat_point",
    "solve_pose",
    "yeadon_to_benchmark",
]

#: Direction-cosine matrix from Yeadon's frame (x to the rider's left, y backward, z up, origin
#: at the hip joint centres) to the benchmark frame (x forward, y right, z down): it is its own
#: inverse.
YEADON_TO_BENCHMARK = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: Largest distance, m, between a hand and its grip (or a heel point and the bottom-bracket axis)
#: that the solved pose may leave.
POSE_TOLERANCE = 1e-9


class RiderPoseError(RiderError):
    """The rider cannot be seated on the bicycle with feet and hands where they belong."""


def seat_point(lst: float, lsp: float, lamst: float, hbb: float, lcs: float, rR: float) -> NDArray[np.float64]:
    """The hip joint centre (Yeadon's origin) in the benchmark frame, m (BicycleParameters' rider.py).

    The seat is at the top of the seat post, ``lst + lsp`` up the seat tube from the bottom
    bracket (:func:`bottom_bracket_point`), the seat tube at ``lamst`` from the ground behind it.

    Args:
        lst: Seat-tube length, m.
        lsp: Seat-post length (out of the tube), m.
        lamst: Seat-tube angle from the horizontal, rad.
        hbb: Bottom-bracket height above the ground, m.
        lcs: Chain-stay length (rear axle to bottom bracket), m.
        rR: Rear-wheel radius, m.

    Returns:
        ``[x, y, z]`` with y = 0, m.
    """
    bb = bottom_bracket_point(hbb, lcs, rR)
    seat = lst + lsp
    return bb + np.array([-seat * np.cos(lamst), 0.0, -seat * np.sin(lamst)])


def bottom_bracket_point(hbb: float, lcs: float, rR: float) -> NDArray[np.float64]:
    """The bottom-bracket axis in the benchmark frame, m: ``x = √(lcs² − (rR − hbb)²)``, ``z = −hbb``.

    Args:
        hbb: Bottom-bracket height above the ground, m.
        lcs: Chain-stay length (rear axle to bottom bracket), m.
        rR: Rear-wheel radius, m.

    Raises:
        RiderPoseError: ``lcs`` is shorter than the height between axle and bottom bracket.
    """
    drop = rR - hbb
    if lcs <= abs(drop):
        raise RiderPoseError(
            f"the chain stay lcs = {lcs:g} m is not longer than the height between the rear axle and the "
            f"bottom bracket (rR - hbb = {drop:g} m): no bottom-bracket position"
        )
    return np.array([math.sqrt(lcs**2 - drop**2), 0.0, -hbb])


def grip_point(w: float, rR: float, rF: float, whb: float, LhbR: float, LhbF: float) -> NDArray[np.float64]:
    """The left grip in the benchmark frame, m (the right one mirrors y).

    The grips are ``whb`` apart; each is ``LhbR`` from the rear axle's centre and ``LhbF`` from
    the front axle's centre, so in the bicycle's plane the grip is where the circles of radii
    ``√(LhbR² − whb²/4)`` and ``√(LhbF² − whb²/4)`` about the axles meet, above the axles.

    Args:
        w: Wheelbase, m.
        rR: Rear-wheel radius, m.
        rF: Front-wheel radius, m.
        whb: Handlebar width between the grips, m.
        LhbR: Rear axle to grip, m.
        LhbF: Front axle to grip, m.

    Returns:
        ``[x, -whb/2, z]``, m.

    Raises:
        RiderPoseError: No such point: a distance shorter than half the handlebar, or the two
            circles do not meet.
    """
    half = whb / 2.0
    for key, value in (("LhbR", LhbR), ("LhbF", LhbF)):
        if value <= half:
            raise RiderPoseError(f"{key} = {value:g} m is not longer than half the handlebar width whb/2 = {half:g} m")
    dR, dF = math.sqrt(LhbR**2 - half**2), math.sqrt(LhbF**2 - half**2)
    rear, front = np.array([0.0, -rR]), np.array([w, -rF])
    axle = front - rear
    d = float(np.hypot(*axle))
    along = (dR**2 - dF**2 + d**2) / (2.0 * d)
    h2 = dR**2 - along**2
    if h2 <= 0.0:
        raise RiderPoseError(
            f"no grip position: the grip cannot be LhbR = {LhbR:g} m from the rear axle and LhbF = {LhbF:g} m "
            f"from the front axle with whb = {whb:g} m, the axles being {d:g} m apart (w = {w:g} m)"
        )
    u = axle / d
    up = np.array([u[1], -u[0]])  # perpendicular to the axle line, pointing up (z down)
    if up[1] > 0.0:
        up = -up
    xz = rear + along * u + math.sqrt(h2) * up
    return np.array([xz[0], -half, xz[1]])


def yeadon_to_benchmark(point: NDArray[np.float64], origin: NDArray[np.float64]) -> NDArray[np.float64]:
    """A point given in Yeadon's frame, expressed in the benchmark frame (``origin``: Yeadon's origin there), m."""
    return origin + YEADON_TO_BENCHMARK @ np.asarray(point, dtype=float).reshape(3)


@dataclass(frozen=True)
class Limb:
    """One limb whose joint angles the pose solver sets.

    Attributes:
        name: Label in messages.
        angles: The yeadon configuration names solved for, proximal first.
        upper: The yeadon segment attribute of the proximal part (thigh or upper arm).
        lower: The segment attribute of the distal part (shank-foot or forearm-hand).
        reach: The yeadon measurements whose sum is the distance from the proximal joint to the
            end point (``Lj5L + Lj6L`` heel point; ``La4L + La5L`` base of the thumb).
        arm: Whether it is an arm (3-D end point and horizontal elbow hinge) or a leg (end point in
            the sagittal plane).
        sign: +1 for the left side, -1 for the right (mirrors the initial guess).
    """

    name: str
    angles: tuple[str, ...]
    upper: str
    lower: str
    reach: tuple[str, str]
    arm: bool
    sign: float


_LEFT_ARM = ("CA1extension", "CA1adduction", "CA1rotation", "A1A2extension")
_RIGHT_ARM = ("CB1extension", "CB1abduction", "CB1rotation", "B1B2extension")
#: The four limbs, each with its own unknowns.
LIMBS = (
    Limb("left leg", ("PJ1extension", "J1J2flexion"), "J1", "J2", ("Lj5L", "Lj6L"), False, 1.0),
    Limb("right leg", ("PK1extension", "K1K2flexion"), "K1", "K2", ("Lk5L", "Lk6L"), False, -1.0),
    Limb("left arm", _LEFT_ARM, "A1", "A2", ("La4L", "La5L"), True, 1.0),
    Limb("right arm", _RIGHT_ARM, "B1", "B2", ("Lb4L", "Lb5L"), True, -1.0),
)

#: Initial guess of each limb's angles, rad: thigh forward and knee bent; upper arm forward and
#: a little out, elbow bent (the natural branch; the sign mirrors the right side).
_GUESS = {False: (-1.4, 1.3), True: (-0.4, -0.05, 0.05, -0.6)}
#: Further starts, tried in turn when a start ends off the target or on the unnatural branch.
_MORE_GUESSES = {False: ((-0.8, 0.6), (-2.0, 2.2)), True: ((-1.0, -0.2, 0.3, -1.2), (0.2, -0.1, 0.1, -0.2))}


def _natural(limb: Limb, q: NDArray[np.float64]) -> bool:
    """The knee bends forward (flexion > 0), the elbow bends the same way (extension < 0)."""
    return bool(q[-1] < 0.0) if limb.arm else bool(q[-1] > 0.0)


def limb_end_point(human: Any, limb: Limb) -> NDArray[np.float64]:
    """The limb's end point in Yeadon's frame, m: ``reach`` from the proximal joint along the limb."""
    upper, lower = getattr(human, limb.upper), getattr(human, limb.lower)
    beyond = sum(float(human.meas[k]) for k in limb.reach) - float(np.linalg.norm(upper.end_pos - upper.pos))
    axis = lower.end_pos - lower.pos
    return np.asarray(lower.pos + axis / np.linalg.norm(axis) * beyond, dtype=float).reshape(3)


def limb_residual(human: Any, limb: Limb, target: NDArray[np.float64]) -> NDArray[np.float64]:
    """How far the posed limb is from its target (Yeadon's frame), m.

    A leg: the heel point's (y, z) minus the bottom bracket's. An arm: the base of the thumb minus
    the grip (x, y, z), and the vertical component of the elbow's hinge axis (the upper arm's x
    axis, about which the elbow extends), which the pose makes zero.
    """
    miss = limb_end_point(human, limb) - target
    if not limb.arm:
        return np.asarray(miss[1:], dtype=float)
    hinge_vertical = float(getattr(human, limb.upper).rot_mat[2, 0])
    return np.append(miss, hinge_vertical)


def pose_residual(human: Any, targets: Mapping[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """All four limbs' residuals (:func:`limb_residual`) for the human's current configuration."""
    return np.concatenate([limb_residual(human, limb, targets[limb.name]) for limb in LIMBS])


def _set_angles(human: Any, limb: Limb, q: NDArray[np.float64]) -> None:
    cfg = dict(human.CFG)
    cfg.update({name: float(v) for name, v in zip(limb.angles, q, strict=True)})
    human.set_CFG_dict(cfg)


def _span(human: Any, limb: Limb, target: NDArray[np.float64]) -> tuple[float, float, float]:
    """The target's distance from the limb's proximal joint, and the shortest and longest the limb spans, m."""
    upper = getattr(human, limb.upper)
    joint = np.asarray(upper.pos, dtype=float).reshape(3)
    if not limb.arm:  # a leg moves in its sagittal plane: only y and z count
        joint, target = joint[1:], target[1:]
    first = float(np.linalg.norm(upper.end_pos - upper.pos))
    second = sum(float(human.meas[k]) for k in limb.reach) - first
    return float(np.linalg.norm(target - joint)), abs(first - second), first + second


def reaching_lean(human: Any, limb: Limb, target: NDArray[np.float64], most: float = 1.2) -> float | None:
    """The least forward lean (``somersault``, rad) at which an arm, straight, reaches its grip.

    Scans the lean from the human's own up to ``most`` in 0.01 rad steps, then refines the first
    that reaches by bisection to 1e-6 rad; the human's configuration is restored.

    Returns:
        The lean, or None if none up to ``most`` reaches.
    """
    cfg = dict(human.CFG)

    def gap(lean: float) -> float:
        human.set_CFG_dict({**cfg, "somersault": lean})
        distance, _, longest = _span(human, limb, target)
        return distance - longest

    try:
        leans = np.arange(cfg["somersault"], most, 0.01)
        hit = next((k for k, lean in enumerate(leans) if gap(float(lean)) <= 0.0), None)
        if hit is None or hit == 0:
            return None
        lo, hi = float(leans[hit - 1]), float(leans[hit])
        while hi - lo > 1e-6:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if gap(mid) <= 0.0 else (mid, hi)
        return hi
    finally:
        human.set_CFG_dict(cfg)


def _reach_check(human: Any, limb: Limb, target: NDArray[np.float64], what: str) -> None:
    """Raise if the target lies beyond the limb's reach from its proximal joint (an arm: naming a lean that reaches)."""
    distance, shortest, longest = _span(human, limb, target)
    if distance > longest or distance < shortest:
        keys = "LhbF, LhbR, whb" if limb.arm else "hbb, lcs"
        hint = ""
        if limb.arm and distance > longest:
            lean = reaching_lean(human, limb, target)
            if lean is not None:
                was = human.CFG["somersault"]
                hint = f"; straight arms reach it from a lean of somersault = {lean:.3f} rad (the file's: {was:g})"
        raise RiderPoseError(
            f"the rider's {limb.name} cannot reach the {what}: it is {distance:.3f} m from the "
            f"{'shoulder' if limb.arm else 'hip'}, and the limb spans {shortest:.3f} to {longest:.3f} m "
            f"({' + '.join(limb.reach)}){hint}; the geometry: the bicycle's {keys} and the seat (lst, lsp, lamst), "
            "and the rider's lean (somersault in the configuration file)"
        )


def solve_pose(human: Any, targets: Mapping[str, NDArray[np.float64]]) -> dict[str, float]:
    """Set each limb's joint angles so that it ends on its target; the human is left posed.

    Args:
        human: A ``yeadon.Human`` whose torso is in its final configuration.
        targets: Limb name -> target point in Yeadon's frame, m (bottom bracket or grip).

    Returns:
        The solved configuration angles, rad.

    Raises:
        RiderPoseError: A target out of a limb's reach, a solution that leaves a limb off its
            target, or a joint beyond yeadon's anatomical bounds.
    """
    from scipy.optimize import root

    solved: dict[str, float] = {}
    for limb in LIMBS:
        what = "grip" if limb.arm else "bottom bracket"
        _reach_check(human, limb, targets[limb.name], what)
        mirror = np.array([1.0, limb.sign, limb.sign, 1.0]) if limb.arm else 1.0

        def residual(q: NDArray[np.float64], limb: Limb = limb) -> NDArray[np.float64]:
            _set_angles(human, limb, q)
            return limb_residual(human, limb, targets[limb.name])

        best: tuple[float, NDArray[np.float64], str] | None = None
        for start in (_GUESS[limb.arm], *_MORE_GUESSES[limb.arm]):
            sol = root(residual, np.array(start) * mirror, method="hybr", options={"xtol": 1e-13})
            miss = float(np.max(np.abs(residual(sol.x))))
            if miss <= POSE_TOLERANCE and _natural(limb, sol.x):
                best = (miss, sol.x, "")
                break
            if best is None or miss < best[0]:
                reason = "" if _natural(limb, sol.x) else "; only with the joint bent backwards"
                best = (miss, sol.x, f"{sol.message}{reason}")
        assert best is not None
        miss, q, why = best
        _set_angles(human, limb, q)
        if miss > POSE_TOLERANCE or why:
            reason = f"the rider's {limb.name} could not be placed on the {what} (closest {miss:.2g} m away: {why})"
            raise RiderPoseError(reason)
        solved.update(zip(limb.angles, (float(v) for v in q), strict=True))
    _check_bounds(human, solved)
    return solved


def _check_bounds(human: Any, angles: Mapping[str, float]) -> None:
    """Raise if a solved angle is outside yeadon's joint range (``Human.CFGbounds``) or on the unnatural branch."""
    bounds = dict(zip(human.CFGnames, human.CFGbounds, strict=True))
    for name, value in angles.items():
        lo, hi = bounds[name]
        if not lo <= value <= hi:
            raise RiderPoseError(
                f"seating the rider needs {name} = {math.degrees(value):.1f} deg, outside the joint's range "
                f"{math.degrees(lo):.0f} to {math.degrees(hi):.0f} deg (yeadon's bounds): check the bicycle's "
                "seat and handlebar keys (lst, lsp, lamst, hbb, lcs, whb, LhbR, LhbF) and the rider's lean"
            )
    for knee in ("J1J2flexion", "K1K2flexion"):
        if angles[knee] < 0.0:
            raise RiderPoseError(f"the knee would bend backwards ({knee} = {math.degrees(angles[knee]):.1f} deg)")
    for elbow in ("A1A2extension", "B1B2extension"):
        if angles[elbow] > 0.0:
            raise RiderPoseError(f"the elbow would bend backwards ({elbow} = {math.degrees(angles[elbow]):.1f} deg)")
