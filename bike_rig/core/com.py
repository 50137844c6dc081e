"""Paper section 8: mass centres of the rear frame and the fork/handlebar (Eq 10–22).

A part hung from a pivot at several orientations aligns its mass centre with the pendulum
axis. Each orientation gives one line ``z = m x + b`` in the bicycle's benchmark frame (x
forward from the rear contact point, z down); the mass centre is where the lines cross. With
more than two lines measurement error spreads the crossings; the paper offers the centroid of
the pairwise intersections (Eq 17–19, its and BicycleParameters' choice, our default) and the
least-squares point (Eq 20).

All functions broadcast over their arguments (complex-step and Monte Carlo friendly).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np

__all__ = [
    "LineConditioning",
    "centroid_com",
    "com_line_slope",
    "frame_com_line_intercept",
    "fork_com_line_intercept",
    "least_squares_com",
    "line_conditioning",
    "line_intersection",
    "pendulum_rotation_angle",
]


def pendulum_rotation_angle(lam: Any, alpha: Any) -> Any:
    """Rotation β of a part from its nominal pose to its hanging pose about the y axis (Eq 10).

    Args:
        lam: Steer-axis tilt λ, rad.
        alpha: Measured orientation of the head tube (frame) or steer tube (fork) relative
            to the earth horizontal, rad (converted from degrees at the input boundary).

    Returns:
        β = λ − α, rad.
    """
    return lam - alpha


def com_line_slope(beta: Any) -> Any:
    """Slope of the pendulum axis in the benchmark x–z plane (Eq 12).

    Args:
        beta: Rotation angle of the hanging orientation, rad.

    Returns:
        m = −tan β, 1.
    """
    return -np.tan(beta)


def frame_com_line_intercept(a: Any, beta: Any, rR: Any) -> Any:
    """z-intercept of a rear-frame pendulum axis (Eq 14).

    Args:
        a: Horizontal distance from the pendulum axis (string) to the rear axle, m;
            positive when the string passes to the left of the axle.
        beta: Rotation angle of the orientation, rad.
        rR: Rear wheel radius, m (the axle is at z = −r_R).

    Returns:
        b = −(a / cos β + r_R), m.
    """
    return -(a / np.cos(beta) + rR)


def fork_com_line_intercept(a: Any, beta: Any, w: Any, rF: Any) -> Any:
    """z-intercept of a fork/handlebar pendulum axis (Eq 21).

    Args:
        a: Horizontal distance from the pendulum axis to the front axle, m (sign as for
            the frame).
        beta: Rotation angle of the orientation, rad.
        w: Wheelbase, m (the front axle is at x = w, z = −r_F).
        rF: Front wheel radius, m.

    Returns:
        b = w tan β − r_F − a / cos β, m.
    """
    return w * np.tan(beta) - rF - a / np.cos(beta)


def line_intersection(m1: Any, b1: Any, m2: Any, b2: Any) -> tuple[Any, Any]:
    """Crossing point of the lines z = m1 x + b1 and z = m2 x + b2 (Eq 17).

    Solves ``[[-m1, 1], [-m2, 1]] [x, z]ᵀ = [b1, b2]ᵀ`` in closed form.

    Returns:
        (x, z) of the intersection, m. Infinite or NaN for parallel lines: callers check the
        angles first (see :func:`bike_rig.core.benchmark.check_orientations`).
    """
    x = (b1 - b2) / (m2 - m1)
    return x, m1 * x + b1


def centroid_com(slopes: Sequence[Any], intercepts: Sequence[Any]) -> tuple[Any, Any]:
    """Mass centre as the mean of every pairwise line intersection (Eq 17–19).

    With three lines this is the centroid of their triangle; with two, their crossing; with
    n lines the mean of the n (n − 1) / 2 crossings (BicycleParameters' definition).

    Args:
        slopes: Slope m_i of each line (Eq 12).
        intercepts: Intercept b_i of each line (Eq 14 or 21), m.

    Returns:
        (x, z) of the mass centre, m.
    """
    pairs = list(combinations(range(len(slopes)), 2))
    xs, zs = 0.0, 0.0
    for i, j in pairs:
        x, z = line_intersection(slopes[i], intercepts[i], slopes[j], intercepts[j])
        xs = xs + x
        zs = zs + z
    return xs / len(pairs), zs / len(pairs)


def least_squares_com(slopes: Sequence[Any], intercepts: Sequence[Any]) -> tuple[Any, Any]:
    """Mass centre as the least-squares solution of the overdetermined lines (Eq 20).

    Minimises ``sum_i (z − m_i x − b_i)^2`` by the normal equations of
    ``[[-m_i, 1]] [x, z]ᵀ = [b_i]``, solved in closed form (2 × 2).

    Returns:
        (x, z) of the mass centre, m.
    """
    n = len(slopes)
    smm = sum(m * m for m in slopes)
    sm = sum(slopes)
    smb = sum(m * b for m, b in zip(slopes, intercepts))
    sb = sum(intercepts)
    # normal equations: [[smm, -sm], [-sm, n]] [x, z] = [-smb, sb]
    det = smm * n - sm * sm
    x = (-smb * n + sm * sb) / det
    z = (smm * sb - sm * smb) / det
    return x, z


@dataclass(frozen=True)
class LineConditioning:
    """How well a set of mass-centre lines fixes their crossing.

    Attributes:
        min_angle: Smallest angle between any two lines, rad (0 for parallel lines).
        condition_number: 2-norm condition number of the line system ``[[-m_i, 1]]``
            (infinite for parallel lines).
    """

    min_angle: float
    condition_number: float


def line_conditioning(slopes: Sequence[float]) -> LineConditioning:
    """Conditioning of the lines z = m_i x + b_i whose crossing is a mass centre.

    The crossing is linear in the intercepts but not in the slopes; nearly parallel lines
    (a small ``min_angle``, a large ``condition_number``) make it strongly nonlinear in the
    measured angles, where linear σ propagation understates the scatter.

    Args:
        slopes: Slope m_i of each line (Eq 12), at least two.

    Returns:
        The smallest pairwise angle (rad) and the system's condition number.
    """
    m = np.asarray(slopes, dtype=float)
    if m.size < 2:
        raise ValueError(f"line conditioning needs at least two lines, got {m.size}")
    angles = np.arctan(m)
    diffs = [abs(angles[i] - angles[j]) for i, j in combinations(range(m.size), 2)]
    min_angle = float(min(min(d, np.pi - d) for d in diffs))
    a = np.column_stack([-m, np.ones_like(m)])
    sv = np.linalg.svd(a, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0.0 else float("inf")
    return LineConditioning(min_angle=min_angle, condition_number=cond)
