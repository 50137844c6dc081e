"""Paper section 9: moments of inertia from pendulum periods (Eq 28–37, Fig 9).

All functions broadcast over their arguments (complex-step and Monte Carlo friendly).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "compound_pendulum_inertia",
    "fork_pendulum_length",
    "frame_pendulum_length",
    "inertia_from_pendulum_axes",
    "rod_inertia",
    "torsional_pendulum_inertia",
    "torsional_stiffness",
]


def rod_inertia(mP: Any, lP: Any, dP: Any) -> Any:
    """Moment of inertia of the calibration rod about a transverse axis through its centre (Fig 9).

    Args:
        mP: Rod mass, kg.
        lP: Rod length, m.
        dP: Rod diameter, m.

    Returns:
        I = m (3 r² + l²) / 12 with r = d / 2, kg m².
    """
    r = dP / 2.0
    return mP / 12.0 * (3.0 * r**2 + lP**2)


def torsional_stiffness(I: Any, T: Any) -> Any:  # noqa: E741  (paper symbol)
    """Torsion-rod stiffness from a body of known inertia (Fig 9).

    Args:
        I: Known moment of inertia about the rod axis, kg m².
        T: Its torsional period, s.

    Returns:
        k = 4 π² I / T², N m / rad.
    """
    return 4.0 * np.pi**2 * I / T**2


def torsional_pendulum_inertia(k: Any, T: Any) -> Any:
    """Moment of inertia about a torsional pendulum's axis (Eq 29, Eq 30).

    Args:
        k: Torsion-rod stiffness, N m / rad.
        T: Mean torsional period, s.

    Returns:
        J = k T² / (4 π²), kg m².
    """
    return k * T**2 / (4.0 * np.pi**2)


def compound_pendulum_inertia(m: Any, g: Any, l: Any, T: Any) -> Any:  # noqa: E741
    """Moment of inertia about the mass centre from a compound pendulum (Eq 28).

    Args:
        m: Mass of the part, kg.
        g: Local acceleration of gravity, m/s².
        l: Distance from the pivot to the mass centre, m.
        T: Mean period of the swing, s.

    Returns:
        I = (T / 2π)² m g l − m l², kg m².
    """
    return (T / (2.0 * np.pi)) ** 2 * m * g * l - m * l**2


def frame_pendulum_length(xB: Any, zB: Any, rR: Any) -> Any:
    """Distance from the rear axle (pivot) to the rear frame's mass centre (Eq 36).

    Returns:
        l_B = sqrt(x_B² + (z_B + r_R)²), m.
    """
    return (xB**2 + (zB + rR) ** 2) ** 0.5


def fork_pendulum_length(xH: Any, zH: Any, w: Any, rF: Any) -> Any:
    """Distance from the front axle (pivot) to the fork/handlebar mass centre (Eq 37).

    The printed Eq 37 has z_B where the geometry requires z_H; this uses z_H (as does
    BicycleParameters).

    Returns:
        l_H = sqrt((x_H − w)² + (z_H + r_F)²), m.
    """
    return ((xH - w) ** 2 + (zH + rF) ** 2) ** 0.5


def inertia_from_pendulum_axes(J: Sequence[Any], beta: Sequence[Any]) -> tuple[Any, Any, Any]:
    """In-plane inertia tensor from moments about ≥ 3 pendulum axes (Eq 31–35).

    Each orientation gives Eq 34, ``J_i = c_i² I_xx − 2 s_i c_i I_xz + s_i² I_zz``; with n ≥ 3
    orientations the system (Eq 35) is solved by least squares (normal equations, exact for
    n = 3, and equal to BicycleParameters' pseudo-inverse).

    Args:
        J: Moment of inertia about each pendulum axis, kg m² (Eq 30).
        beta: Rotation angle β_i of each orientation, rad (Eq 10).

    Returns:
        (I_xx, I_xz, I_zz) in the benchmark frame, kg m².
    """
    rows = []
    for b in beta:
        s, c = np.sin(b), np.cos(b)
        rows.append((c * c, -2.0 * s * c, s * s))
    shape = np.broadcast_shapes(*(np.shape(v) for row in rows for v in row), *(np.shape(j) for j in J))
    A = np.stack([np.stack([np.broadcast_to(v, shape) for v in row], axis=-1) for row in rows], axis=-2)
    y = np.stack([np.broadcast_to(j, shape) for j in J], axis=-1)
    At = np.swapaxes(A, -1, -2)
    # plain transpose, never the conjugate: the complex step must stay analytic
    solution = np.linalg.solve(At @ A, (At @ y[..., None]))[..., 0]
    return solution[..., 0], solution[..., 1], solution[..., 2]
