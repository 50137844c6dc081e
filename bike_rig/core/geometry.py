"""Paper section 6: wheel radii (Eq 6), steer-axis tilt (Eq 7) and trail (Eq 8).

Every function is plain broadcasting numpy arithmetic (see :mod:`bike_rig.core.uncertainty.uncertain`):
arguments may be floats, arrays of samples, or complex-step perturbed arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["steer_axis_tilt", "trail", "wheel_radius"]


def wheel_radius(d: Any, n: Any) -> Any:
    """Wheel radius from the distance rolled over a number of rotations (Eq 6).

    Args:
        d: Distance the wheel centre travelled along the ground, m.
        n: Number of whole wheel rotations over that distance (exact count), 1.

    Returns:
        r = d / (2 π n), the effective rolling radius, m.
    """
    return d / (2.0 * np.pi * n)


def steer_axis_tilt(lambda_ht: Any) -> Any:
    """Steer-axis tilt λ, the complement of the head-tube angle (Eq 7).

    Args:
        lambda_ht: Head-tube angle measured from the horizontal, rad (converted from the
            degrees of the measurement file at the input boundary).

    Returns:
        λ = π/2 − λ_ht, rad; positive when the steer axis leans back.
    """
    return np.pi / 2.0 - lambda_ht


def trail(rF: Any, lam: Any, f_o: Any) -> Any:
    """Trail c from the front wheel radius, steer-axis tilt and fork offset (Eq 8).

    Args:
        rF: Front wheel radius, m.
        lam: Steer-axis tilt λ, rad.
        f_o: Fork offset, the perpendicular distance from the steer axis to the front axle, m.

    Returns:
        c = (r_F sin λ − f_o) / cos λ, m; positive when the contact point trails the steer axis.
    """
    return (rF * np.sin(lam) - f_o) / np.cos(lam)
