"""A rigid rider lumped into the rear frame (paper section 10, Table 1; Tables 4–5).

The rider is a rigid body fixed to the rear frame; the combined rear frame has the summed
mass, the mass-weighted mass centre, and the inertia of both parts about the new mass centre
(parallel-axis theorem). Broadcasting arithmetic only, so σ propagate by the complex step.

The rider choice of every entry point (command line, nodes, figures, report) is resolved here,
by :func:`resolve_rider`: no rider (``None``, ``""`` or ``"none"``), the paper's rider
(``"paper"``, Table 1) or a rider YAML file; :func:`rider_key` is the choice's name in records.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .benchmark import PARAMETER_NAMES, ParameterSet
from .errors import InputFileError, ModelError, short_repr
from .io_yaml import load_yaml_document
from .measurements import MAX_MAGNITUDE
from .uncertainty.uncertain import UncertainVector, complex_step_jacobian

__all__ = [
    "NO_RIDER",
    "PAPER",
    "PAPER_RIDER",
    "Rider",
    "RiderError",
    "add_rider",
    "combine_rear_frame",
    "load_rider",
    "resolve_rider",
    "rider_key",
]

#: The record name of "no rider".
NO_RIDER = ""
#: The name of the paper's rider (Table 1).
PAPER = "paper"
#: The keys of a rider file, in kg, m and kg m² (benchmark frame).
RIDER_FILE_KEYS = ("mass", "x", "z", "Ixx", "Iyy", "Izz", "Ixz")


class RiderError(ModelError):
    """The rider choice is unknown, or its rider file cannot be read or lacks a number."""

    def __init__(self, reason: str, path: str | None = None, key: str | None = None, line: int | None = None):
        """The error; with a ``path`` its message reads like :class:`InputFileError`'s.

        Args:
            reason: What is wrong.
            path: The rider file, if the error is in one.
            key: The offending key of the file, if there is one.
            line: Its 1-based line number, if known.
        """
        self.reason, self.path, self.key, self.line = reason, path, key, line
        where = ""
        if path is not None:
            where = path + (f":{line}" if line is not None else "") + (f": key '{key}'" if key is not None else "")
        super().__init__(f"{where}: {reason}" if where else reason)


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


def rider_key(spec: str | Path | None, files: bool = True) -> str:
    """The rider choice's name in records: ``""`` (no rider), ``"paper"`` or the rider file's path.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no rider), ``"paper"`` (Table 1), or the path of a
            rider YAML file.
        files: Whether a rider file may be named (else only the names above are known).

    Raises:
        RiderError: ``files`` is false and ``spec`` is none of the names.
    """
    if spec is None or spec in (NO_RIDER, "none"):
        return NO_RIDER
    if spec == PAPER:
        return PAPER
    if not files:
        raise RiderError(f"unknown rider '{spec}': expected '', 'none' or 'paper'")
    return str(spec)


def resolve_rider(spec: str | Path | None, files: bool = True) -> Rider | None:
    """The rider chosen by ``spec``: the one place a rider choice is turned into a rider.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no rider), ``"paper"`` (:data:`PAPER_RIDER`,
            Table 1), or the path of a rider YAML file (:func:`load_rider`).
        files: Whether a rider file may be named (else only the names above are known).

    Returns:
        The rider, or ``None`` for no rider.

    Raises:
        RiderError: An unknown name (``files`` false), or a rider file that is missing,
            unreadable or lacks a number.
    """
    key = rider_key(spec, files)
    if key == NO_RIDER:
        return None
    if key == PAPER:
        return PAPER_RIDER
    return load_rider(key)


def load_rider(path: str | Path) -> Rider:
    """A rider from a YAML file: a mapping of ``mass, x, z, Ixx, Iyy, Izz, Ixz``.

    In kg, m and kg m² (benchmark frame: x forward from the rear contact, z down); an optional
    ``name`` labels it (default: the file's stem).

    Raises:
        RiderError: The file is missing, unreadable or not YAML, or lacks a number (with the
            file, key and line), or the mass is not positive.
    """
    spec = str(path)
    try:
        data, lines = load_yaml_document(spec)
    except InputFileError as exc:
        raise RiderError(exc.reason, exc.path, exc.key, exc.line) from None
    if not isinstance(data, dict):
        raise RiderError(f"a rider file is a mapping of {', '.join(RIDER_FILE_KEYS)}", spec)
    values = {}
    for k in RIDER_FILE_KEYS:
        v = data.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (isinstance(v, float) and not math.isfinite(v)):
            raise RiderError(f"needs a number ({short_repr(v)} given)", spec, key=k, line=lines.get((k,)))
        if abs(v) > MAX_MAGNITUDE:  # an integer of 400 digits cannot even become a float
            reason = f"{short_repr(v)} is beyond any rider (magnitude above {MAX_MAGNITUDE:g})"
            raise RiderError(reason, spec, key=k, line=lines.get((k,)))
        values[k] = float(v)
    if values["mass"] <= 0:
        raise RiderError("rider mass must be positive", spec, key="mass", line=lines.get(("mass",)))
    return Rider(name=str(data.get("name", Path(spec).stem)), **values)
