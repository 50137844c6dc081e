"""A rigid rider lumped into the rear frame (paper section 10, Table 1; Tables 4–5).

The combined rear frame has the summed mass, the mass-weighted mass centre and both parts'
inertia about it (parallel-axis theorem); broadcasting arithmetic, so σ propagate by the complex
step. :func:`resolve_rider` resolves every entry point's choice: none (``None``, ``""``,
``"none"``), ``"paper"`` (Table 1) or a rider YAML file (rigid numbers, or a Yeadon rider seated
by :func:`add_rider`, :mod:`bike_rig.core.rider_yeadon`); :func:`rider_key` names it in records.
A rider with σ (:class:`RiderSensitivity`) adds them to the covariance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
from numpy.typing import NDArray

from .benchmark import PARAMETER_NAMES, ParameterSet
from .errors import InputFileError, ModelError, short_repr
from .io_yaml import load_yaml_document
from .measurements import MAX_MAGNITUDE
from .plausibility import body_violations, rider_body
from .uncertainty.uncertain import UncertainVector, complex_step_jacobian

if TYPE_CHECKING:
    from .rider_yeadon import YeadonRider

__all__ = [
    "NO_RIDER",
    "PAPER",
    "PAPER_RIDER",
    "AnyRider",
    "Rider",
    "RiderError",
    "RiderSensitivity",
    "add_rider",
    "check_rider_body",
    "combine_rear_frame",
    "combine_rear_frame_values",
    "load_rider",
    "resolve_rider",
    "rider_draws",
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
class RiderSensitivity:
    """How a rider's seven numbers depend on its own uncertain inputs (e.g. body measurements).

    Attributes:
        names: The inputs (the Jacobian's columns), labelled for budgets.
        sigma: Their σ, independent, in their units.
        jacobian: d(rider number)/d(input), shape (7, n), rows in ``outputs`` order.
        outputs: The rider numbers of the rows (:data:`RIDER_FILE_KEYS`).
        bicycle: Benchmark parameters of the bicycle the rider's numbers depend on (e.g. the
            wheelbase through the pose), shared with the bicycle, so correlated with it.
        bicycle_jacobian: d(rider number)/d(those parameters), shape (7, k).
    """

    names: tuple[str, ...]
    sigma: NDArray[np.float64]
    jacobian: NDArray[np.float64]
    outputs: tuple[str, ...] = RIDER_FILE_KEYS
    bicycle: tuple[str, ...] = ()
    bicycle_jacobian: NDArray[np.float64] = field(default_factory=lambda: np.zeros((len(RIDER_FILE_KEYS), 0)))


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
        sensitivity: The σ of these numbers through their own inputs; None: exact.
    """

    mass: float
    x: float
    z: float
    Ixx: float
    Iyy: float
    Izz: float
    Ixz: float
    name: str = "rider"
    sensitivity: RiderSensitivity | None = field(default=None, compare=False, repr=False)


#: A rider choice: rigid, or a Yeadon rider to be seated on the bicycle.
AnyRider: TypeAlias = "Rider | YeadonRider"

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
    return combine_rear_frame_values(p, {k: getattr(r, k) for k in RIDER_FILE_KEYS})


def combine_rear_frame_values(p: Mapping[str, Any], r: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`combine_rear_frame` with the rider given as ``{mass, x, z, Ixx, Iyy, Izz, Ixz}`` (may be complex)."""
    mB, xB, zB, mP = p["mB"], p["xB"], p["zB"], r["mass"]
    m = mB + mP
    x = (mB * xB + mP * r["x"]) / m
    z = (mB * zB + mP * r["z"]) / m
    dxB, dzB, dxP, dzP = xB - x, zB - z, r["x"] - x, r["z"] - z
    out = dict(p)
    out.update(
        mB=m,
        xB=x,
        zB=z,
        IBxx=p["IBxx"] + mB * dzB**2 + r["Ixx"] + mP * dzP**2,
        IByy=p["IByy"] + mB * (dxB**2 + dzB**2) + r["Iyy"] + mP * (dxP**2 + dzP**2),
        IBzz=p["IBzz"] + mB * dxB**2 + r["Izz"] + mP * dxP**2,
        IBxz=p["IBxz"] - mB * dxB * dzB + r["Ixz"] - mP * dxP * dzP,
    )
    return out


def rider_draws(
    rider: Rider, bicycle: Mapping[str, Any], nominal: Mapping[str, float], samples: int, seed: int
) -> dict[str, Any]:
    """The rider's ``mass, x, z, Ixx, Iyy, Izz, Ixz`` over Monte Carlo draws (linear in its inputs).

    A rider without :class:`RiderSensitivity` is the same in every draw. Otherwise its numbers
    move by its Jacobian times normal draws of its own inputs (a generator seeded from ``[seed,
    1]``, independent of the bicycle's) plus its Jacobian to the bicycle parameters it depends
    on times their drawn deviations from ``nominal``.

    Args:
        rider: The (seated) rider.
        bicycle: The bicycle's drawn parameters, ``{name: array of samples}``.
        nominal: The bicycle's nominal parameters.
        samples: Number of draws.
        seed: The Monte Carlo's seed.

    Returns:
        ``{key: float or array of samples}``.
    """
    out: dict[str, Any] = {k: getattr(rider, k) for k in RIDER_FILE_KEYS}
    sens = rider.sensitivity
    if sens is None:
        return out
    delta = np.zeros((len(RIDER_FILE_KEYS), samples))
    if sens.names:
        z = np.random.default_rng([seed, 1]).standard_normal((len(sens.names), samples))
        delta += sens.jacobian @ (sens.sigma[:, None] * z)
    for k, name in enumerate(sens.bicycle):
        delta += np.outer(sens.bicycle_jacobian[:, k], np.asarray(bicycle[name], dtype=float) - nominal[name])
    return {key: out[key] + delta[i] for i, key in enumerate(RIDER_FILE_KEYS)}


def add_rider(ps: ParameterSet, rider: AnyRider) -> ParameterSet:
    """The parameter set of bicycle plus rider, with the covariance carried through.

    A Yeadon rider is first seated on this bicycle (:meth:`YeadonRider.seated`). σ of the
    combined parameters come from the bicycle's parameter covariance and, for a rider with a
    :class:`RiderSensitivity`, from the rider's own inputs (independent of the bicycle's) and its
    dependence on bicycle parameters, all through the exact Jacobian of
    :func:`combine_rear_frame_values`; a rider without one is exact.
    The link to the raw readings gains the rider's inputs as further readings.
    """
    from .rider_yeadon import YeadonRider

    if isinstance(rider, YeadonRider):
        rider = rider.seated(ps)
        check_rider_body(rider, rider.name)
    values: dict[str, float] = dict(ps.parameters.as_dict())
    rider_inputs = {f"rider.{k}": float(getattr(rider, k)) for k in RIDER_FILE_KEYS}
    sens = rider.sensitivity
    perturbed = PARAMETER_NAMES + (tuple(rider_inputs) if sens is not None else ())

    def combined(x: Mapping[str, Any]) -> dict[str, Any]:
        return combine_rear_frame_values(x, {k: x[f"rider.{k}"] for k in RIDER_FILE_KEYS})

    prop = complex_step_jacobian(combined, {**values, **rider_inputs}, perturbed, PARAMETER_NAMES)
    n = len(PARAMETER_NAMES)
    jb = prop.jacobian[:, :n].copy()
    if sens is not None:
        for k, name in enumerate(sens.bicycle):  # the rider moves with these bicycle parameters
            jb[:, PARAMETER_NAMES.index(name)] += prop.jacobian[:, n:] @ sens.bicycle_jacobian[:, k]
    cov = jb @ ps.parameters.covariance @ jb.T
    jr = np.zeros((n, 0))
    if sens is not None:
        jr = prop.jacobian[:, n:] @ sens.jacobian  # d parameters / d rider inputs
        cov = cov + (jr * sens.sigma**2) @ jr.T
    params = UncertainVector(PARAMETER_NAMES, prop.values, cov)
    raw = None
    if ps.raw is not None:
        names, rcov, jac = ps.raw.names, ps.raw.covariance, jb @ ps.raw.jacobian
        if sens is not None:
            names = names + sens.names
            rcov = np.block(
                [
                    [rcov, np.zeros((rcov.shape[0], sens.sigma.size))],
                    [np.zeros((sens.sigma.size, rcov.shape[0])), np.diag(sens.sigma**2)],
                ]
            )
            jac = np.hstack([jac, jr])
        raw = type(ps.raw)(names, rcov, jac)
    return ParameterSet(f"{ps.bicycle} + {rider.name}", params, ps.source, raw, ps.com, ps.parts, ps.extras)


def rider_key(spec: str | Path | None, files: bool = True) -> str:
    """The rider choice's name in records: ``""`` (no rider), ``"paper"`` or the rider file's path.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no rider), ``"paper"`` (Table 1), or the path of a
            rider YAML file.
        files: Whether a rider file may be named (else only the names above are known).

    Raises:
        RiderError: ``spec`` is none of the names, and ``files`` is false or it is neither an
            existing file nor a ``.yaml``/``.yml`` name (a missing YAML file is named when read).
    """
    if spec is None or spec in (NO_RIDER, "none"):
        return NO_RIDER
    if spec == PAPER:
        return PAPER
    if not files:
        raise RiderError(f"unknown rider '{spec}': expected '', 'none' or 'paper'")
    if Path(spec).suffix.lower() not in (".yaml", ".yml") and not Path(spec).exists():
        raise RiderError(f"unknown rider '{spec}': expected '', 'none', 'paper' or a rider YAML file")
    return str(spec)


def resolve_rider(spec: str | Path | None, files: bool = True) -> AnyRider | None:
    """The rider chosen by ``spec``: the one place a rider choice is turned into a rider.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no rider), ``"paper"`` (:data:`PAPER_RIDER`,
            Table 1), or the path of a rider YAML file (:func:`load_rider`: a rigid rider, or a
            Yeadon rider that :func:`add_rider` seats on the bicycle).
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


def load_rider(path: str | Path) -> AnyRider:
    """A rider from a YAML file: a mapping of ``mass, x, z, Ixx, Iyy, Izz, Ixz``, or a Yeadon rider.

    In kg, m and kg m² (benchmark frame: x forward from the rear contact, z down); an optional
    ``name`` labels it (default: the file's stem). A file with ``yeadon_measurements`` names a
    Yeadon rider instead (:func:`bike_rig.core.rider_yeadon.load_yeadon_rider`).

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
    if "yeadon_measurements" in data or "yeadon_configuration" in data:
        from .rider_yeadon import load_yeadon_rider

        return load_yeadon_rider(spec, data, lines)
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
    name = str(data.get("name", Path(spec).stem))
    v = values
    rider = Rider(v["mass"], v["x"], v["z"], v["Ixx"], v["Iyy"], v["Izz"], v["Ixz"], name)
    check_rider_body(rider, spec)
    return rider


def check_rider_body(rider: Rider, where: str | None = None) -> None:
    """Refuse a rider no rigid body can be (:func:`~bike_rig.core.plausibility.body_violations`).

    Its mass centre must be above the ground, its tensor positive definite with principal
    moments obeying the triangle rule (e.g. Iyy ≤ Ixx + Izz for Ixz = 0).

    Raises:
        RiderError: naming ``where`` (the rider file) and every broken rule.
    """
    found = body_violations(rider_body(rider, "the rider"))
    if found:
        raise RiderError("not physically possible: " + "; ".join(str(f) for f in found), where)
