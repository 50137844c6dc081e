"""A rigid rider lumped into the rear frame (paper section 10, Table 1; Tables 4–5).

The rider is a rigid body fixed to the rear frame; the combined rear frame has the summed
mass, the mass-weighted mass centre, and the inertia of both parts about the new mass centre
(parallel-axis theorem). Broadcasting arithmetic only, so σ propagate by the complex step.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .benchmark import PARAMETER_NAMES, ParameterSet
from .uncertainty.uncertain import UncertainVector, complex_step_jacobian

__all__ = ["PAPER_RIDER", "Rider", "add_rider", "combine_rear_frame"]


@dataclass(frozen=True)
class Rider:
    """A rigid rider in the benchmark frame (x forward from the rear contact, z down).

    Attributes:
        mass: m_P, kg.
        x: x_P of the mass centre, m.
        z: z_P of the mass centre, m.
        Ixx: Moment of inertia about the mass centre, x axis, kg m².
        Iyy: Same, y axis, kg m².
        Izz: Same, z axis, kg m².
        Ixz: Product of inertia (tensor entry, as IBxz), kg m².
        name: Label used in outputs.
    """

    mass: float
    x: float
    z: float
    Ixx: float
    Iyy: float
    Izz: float
    Ixz: float
    name: str = "rider"


#: The paper's rigid rider, Table 1 (from Moore et al. 2009).
PAPER_RIDER = Rider(72.0, 0.2909, -1.1091, 7.9985, 8.0689, 2.3624, -1.9272, "paper rider (Table 1)")


def combine_rear_frame(p: Mapping[str, Any], r: Rider) -> dict[str, Any]:
    """Rear frame plus rider as one body: new mB, xB, zB and IB** (parallel-axis theorem).

    Args:
        p: Benchmark parameters (floats or broadcasting arrays).
        r: The rider.

    Returns:
        A copy of ``p`` with the rear-frame entries replaced by the combined body's.
    """
    mB, xB, zB = p["mB"], p["xB"], p["zB"]
    m = mB + r.mass
    x = (mB * xB + r.mass * r.x) / m
    z = (mB * zB + r.mass * r.z) / m
    dxB, dzB, dxP, dzP = xB - x, zB - z, r.x - x, r.z - z
    out = dict(p)
    out.update(
        mB=m,
        xB=x,
        zB=z,
        IBxx=p["IBxx"] + mB * dzB**2 + r.Ixx + r.mass * dzP**2,
        IByy=p["IByy"] + mB * (dxB**2 + dzB**2) + r.Iyy + r.mass * (dxP**2 + dzP**2),
        IBzz=p["IBzz"] + mB * dxB**2 + r.Izz + r.mass * dxP**2,
        IBxz=p["IBxz"] - mB * dxB * dzB + r.Ixz - r.mass * dxP * dzP,
    )
    return out


def add_rider(ps: ParameterSet, rider: Rider) -> ParameterSet:
    """The parameter set of bicycle plus rider, with the covariance carried through.

    The rider's values are taken as exact; σ of the combined parameters come from the
    bicycle's parameter covariance through the exact Jacobian of :func:`combine_rear_frame`.
    """
    values = ps.parameters.as_dict()
    prop = complex_step_jacobian(lambda x: combine_rear_frame(x, rider), values, PARAMETER_NAMES, PARAMETER_NAMES)
    cov = prop.covariance(ps.parameters.covariance)
    params = UncertainVector(PARAMETER_NAMES, prop.values, cov)
    raw = None
    if ps.raw is not None:
        raw = type(ps.raw)(ps.raw.names, ps.raw.covariance, prop.jacobian @ ps.raw.jacobian)
    return ParameterSet(f"{ps.bicycle} + {rider.name}", params, ps.source, raw, ps.com)


def rider_inertia_matrix(r: Rider) -> np.ndarray[Any, np.dtype[np.float64]]:
    """The rider's 3 × 3 inertia tensor as printed in Table 1."""
    return np.array([[r.Ixx, 0.0, r.Ixz], [0.0, r.Iyy, 0.0], [r.Ixz, 0.0, r.Izz]])
