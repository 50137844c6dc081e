"""A rider from Yeadon's 95 body measurements, seated on the bicycle.

A rider YAML with ``yeadon_measurements`` (the yeadon package's file) and
``yeadon_configuration`` (the initial pose, as BicycleParameters' ``YeadonCFG.txt``) names such a
rider (:func:`load_yeadon_rider`). :func:`seat_rider` poses it from the bicycle's rider-geometry
keys (:mod:`bike_rig.core.rider_pose`) and returns a rigid :class:`~bike_rig.core.rider.Rider`
(mass kg, mass centre m, inertia kg m² in the benchmark frame), as BicycleParameters'
``Bicycle.add_rider`` computes it, with σ. The yeadon package is imported only when a Yeadon
rider is read.
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .benchmark import ParameterSet
from .errors import InputFileError, short_repr
from .io_yaml import load_yaml_document
from .rider import RIDER_FILE_KEYS, Rider, RiderError, RiderSensitivity
from .rider_pose import (
    LIMBS,
    YEADON_TO_BENCHMARK,
    RiderPoseError,
    bottom_bracket_point,
    grip_point,
    limb_end_point,
    pose_residual,
    seat_point,
    solve_pose,
    yeadon_to_benchmark,
)

__all__ = [
    "DEFAULT_MASS_SIGMA",
    "DEFAULT_MEASUREMENT_SIGMA",
    "POSE_PARAMETERS",
    "RIDER_GEOMETRY_KEYS",
    "YEADON_RIDER_KEYS",
    "YeadonMeasurements",
    "YeadonRider",
    "load_yeadon_rider",
    "pose_targets",
    "rider_geometry",
    "SeatedPose",
    "seat_rider",
    "seated_pose",
]

#: The bicycle's rider-geometry keys (BicycleParameters' raw file): seat-tube and seat-post
#: length, seat-tube angle (rad), bottom-bracket height, chain-stay length, handlebar width, and
#: the rear and front axle to grip distances; m unless said.
RIDER_GEOMETRY_KEYS = ("lst", "lsp", "lamst", "hbb", "lcs", "whb", "LhbR", "LhbF")
#: σ of each body length, perimeter, width and depth, m (see README, "A Yeadon rider").
DEFAULT_MEASUREMENT_SIGMA = 0.005
#: σ of the rider's total mass, kg.
DEFAULT_MASS_SIGMA = 0.5
#: The keys a Yeadon rider file may hold.
YEADON_RIDER_KEYS = (
    "name",
    "yeadon_measurements",
    "yeadon_configuration",
    "inertia",
    "measurement_sigma",
    "mass_sigma",
    "pose_sigma",
    "bicycle_geometry",
)
#: Forward-difference steps: body lengths (m), total mass (kg; it enters linearly, so only round-off
#: limits the step), joint angles (rad).
_STEP_LENGTH, _STEP_MASS, _STEP_ANGLE = 1e-7, 1e-3, 1e-8


@dataclass(frozen=True)
class YeadonMeasurements:
    """A yeadon measurement file, read.

    Attributes:
        lengths: The 95 measurements, m (after the file's conversion factor).
        mass: The measured total mass, kg, or None (yeadon's densities unscaled).
        path: The file.
    """

    lengths: Mapping[str, float]
    mass: float | None
    path: str


@dataclass(frozen=True)
class YeadonRider:
    """A rider named by a rider file through Yeadon measurements, not yet seated on a bicycle.

    Attributes:
        name: Label in outputs.
        measurements: The body measurements.
        configuration: The initial pose, yeadon configuration names -> rad (the limbs' angles are
            solved when seated).
        inertia: False: a point mass at the rider's mass centre (no inertia about it).
        measurement_sigma: σ of each body measurement, m.
        mass_sigma: σ of the total mass, kg.
        geometry: Rider-geometry keys given in the rider file (they win over the bicycle's).
        path: The rider file.
        pose_sigma: Whether the pose follows the bicycle's w, rR, rF in the covariance (their σ
            move the seat, grips and bottom bracket); False: as BicycleParameters, the pose is exact.
    """

    name: str
    measurements: YeadonMeasurements
    configuration: Mapping[str, float]
    inertia: bool = True
    measurement_sigma: float = DEFAULT_MEASUREMENT_SIGMA
    mass_sigma: float = DEFAULT_MASS_SIGMA
    geometry: Mapping[str, float] = field(default_factory=dict)
    path: str = "<memory>"
    pose_sigma: bool = True

    def seated(self, ps: ParameterSet) -> Rider:
        """This rider seated on the bicycle of ``ps`` (:func:`seat_rider`)."""
        return seat_rider(self, ps)


def _number(value: object) -> bool:
    """A finite int or float (not a bool; an int beyond any float is not one)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _positive(value: object, most: float = 1e4) -> float | None:
    """``value`` as a float if it is a number in (0, most], else None."""
    if not _number(value) or not 0 < float(value) <= most:  # type: ignore[arg-type]
        return None
    return float(value)  # type: ignore[arg-type]


def _relative(base: str, name: object, key: str, line: int | None) -> str:
    if not isinstance(name, str) or not name.strip():
        raise RiderError(f"needs a file name ({short_repr(name)} given)", base, key=key, line=line)
    p = Path(name)
    return str(p if p.is_absolute() else Path(base).parent / p)


def load_yeadon_rider(path: str, data: Mapping[str, Any], lines: Mapping[Any, int]) -> YeadonRider:
    """The Yeadon rider of a rider file (already read as ``data``, with its key lines).

    Keys: ``yeadon_measurements`` and ``yeadon_configuration`` (file paths, relative to the rider
    file), optional ``name``, ``inertia`` (bool, default true), ``measurement_sigma`` (m, default
    :data:`DEFAULT_MEASUREMENT_SIGMA`), ``mass_sigma`` (kg, default :data:`DEFAULT_MASS_SIGMA`),
    ``pose_sigma`` (bool, default true) and ``bicycle_geometry`` (a mapping of some of
    :data:`RIDER_GEOMETRY_KEYS`).

    Raises:
        RiderError: An unknown key, a missing or unreadable file, a bad value (file, key, line).
    """
    for key in data:
        if key not in YEADON_RIDER_KEYS:
            reason = f"not a key of a Yeadon rider file (known: {', '.join(YEADON_RIDER_KEYS)})"
            raise RiderError(reason, path, key=str(key), line=lines.get((key,)))
    meas_path = _relative(
        path, data.get("yeadon_measurements"), "yeadon_measurements", lines.get(("yeadon_measurements",))
    )
    cfg_key = "yeadon_configuration"
    cfg_path = _relative(path, data.get(cfg_key), cfg_key, lines.get((cfg_key,)))
    flags = {}
    for key in ("inertia", "pose_sigma"):
        v = data.get(key, True)
        if not isinstance(v, bool):
            raise RiderError(f"needs true or false ({short_repr(v)} given)", path, key, lines.get((key,)))
        flags[key] = v
    sigmas = {}
    for key, default in (("measurement_sigma", DEFAULT_MEASUREMENT_SIGMA), ("mass_sigma", DEFAULT_MASS_SIGMA)):
        v = data.get(key, default)
        if not _number(v) or v < 0 or v > 1e3:
            raise RiderError(f"needs a number from 0 to 1000 ({short_repr(v)} given)", path, key, lines.get((key,)))
        sigmas[key] = float(v)
    geometry: dict[str, float] = {}
    given = data.get("bicycle_geometry", {})
    if not isinstance(given, dict):
        raise RiderError(
            "needs a mapping of rider-geometry keys", path, "bicycle_geometry", lines.get(("bicycle_geometry",))
        )
    for key, v in given.items():
        line = lines.get(("bicycle_geometry", key))
        if key not in RIDER_GEOMETRY_KEYS:
            raise RiderError(
                f"not a rider-geometry key (known: {', '.join(RIDER_GEOMETRY_KEYS)})", path, str(key), line
            )
        if not _number(v):
            raise RiderError(f"needs a number ({short_repr(v)} given)", path, key, line)
        geometry[key] = float(v)
    return YeadonRider(
        name=str(data.get("name", Path(path).stem)),
        measurements=read_yeadon_measurements(meas_path),
        configuration=read_yeadon_configuration(cfg_path),
        inertia=flags["inertia"],
        pose_sigma=flags["pose_sigma"],
        geometry=geometry,
        path=path,
        **sigmas,
    )


def _read_mapping(path: str) -> tuple[dict[Any, Any], Mapping[Any, int]]:
    try:
        data, lines = load_yaml_document(path)
    except InputFileError as exc:
        raise RiderError(exc.reason, exc.path, exc.key, exc.line) from None
    if not isinstance(data, dict):
        raise RiderError("a yeadon file is a mapping of 'name: value' lines", path)
    return data, lines


def read_yeadon_measurements(file: str | Path) -> YeadonMeasurements:
    """Read a yeadon measurement file: ``measurementconversionfactor``, optional ``totalmass`` (kg), 95 lengths.

    Raises:
        RiderError: Unreadable, an unknown or missing measurement, or a value that is not positive.
    """
    import yeadon

    path = str(file)
    data, lines = _read_mapping(path)
    names = tuple(yeadon.Human.measnames)
    factor = _positive(data.get("measurementconversionfactor"))
    if factor is None:
        line = lines.get(("measurementconversionfactor",))
        given = short_repr(data.get("measurementconversionfactor"))
        raise RiderError(
            f"needs a positive number (m per unit of the file; {given} given)",
            path,
            "measurementconversionfactor",
            line,
        )
    mass = _positive(data.get("totalmass"))
    if "totalmass" in data and mass is None:
        given = short_repr(data.get("totalmass"))
        raise RiderError(f"needs a positive mass in kg ({given} given)", path, "totalmass", lines.get(("totalmass",)))
    lengths = {}
    for key, v in data.items():
        if key in ("measurementconversionfactor", "totalmass"):
            continue
        if key not in names:
            raise RiderError("not one of yeadon's 95 measurement names", path, str(key), lines.get((key,)))
        length = _positive(v)
        if length is None:
            raise RiderError(f"needs a positive length ({short_repr(v)} given)", path, key, lines.get((key,)))
        lengths[key] = length * factor
    missing = [k for k in names if k not in lengths]
    if missing:
        raise RiderError(f"missing {len(missing)} of yeadon's 95 measurements: {', '.join(missing)}", path)
    return YeadonMeasurements(lengths, mass, path)


def read_yeadon_configuration(file: str | Path) -> dict[str, float]:
    """Read a yeadon configuration file: configuration names -> rad (absent ones are 0).

    Raises:
        RiderError: Unreadable, an unknown name or a value that is not a number.
    """
    import yeadon

    path = str(file)
    data, lines = _read_mapping(path)
    cfg = {name: 0.0 for name in yeadon.Human.CFGnames}
    for key, v in data.items():
        if key not in cfg:
            raise RiderError("not a yeadon configuration name", path, str(key), lines.get((key,)))
        if not _number(v) or abs(v) > 2 * math.pi:
            raise RiderError(f"needs an angle in rad ({short_repr(v)} given)", path, key, lines.get((key,)))
        cfg[key] = float(v)
    return cfg


def _extra_number(ps: ParameterSet, key: str) -> float | None:
    text = ps.extras.get(key)
    if text is None:
        return None
    try:
        return float(str(text).split("+/-")[0])
    except ValueError:
        raise RiderError(
            f"the bicycle's rider-geometry key needs a number ({short_repr(text)} given)", ps.source, key
        ) from None


def rider_geometry(rider: YeadonRider, ps: ParameterSet) -> dict[str, float]:
    """The rider-geometry keys for seating ``rider`` on ``ps``: the rider file's, else the bicycle's.

    Raises:
        RiderError: Keys neither gives (named, with where they are looked for).
    """
    geometry: dict[str, float] = {}
    for key in RIDER_GEOMETRY_KEYS:
        value = rider.geometry.get(key, _extra_number(ps, key))
        if value is not None:
            geometry[key] = value
    missing = [k for k in RIDER_GEOMETRY_KEYS if k not in geometry]
    if missing:
        raise RiderError(
            f"seating the Yeadon rider of {rider.path} on {ps.bicycle} needs the bicycle's rider-geometry keys "
            f"{', '.join(missing)}: give them in the bicycle's raw measurement file (BicycleParameters' "
            "<Bike>Measured.txt) or under 'bicycle_geometry' in the rider file"
        )
    return geometry


@contextlib.contextmanager
def _yeadon_guard() -> Iterator[Any]:
    """Import yeadon; keep its prints off standard output and its class-wide densities unchanged.

    yeadon prints a message for an out-of-range joint angle (the solver may try one) and
    ``scale_human_by_mass`` rescales the class's density table in place.
    """
    import yeadon

    densities = copy.deepcopy(yeadon.Human.segmental_densities)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            yield yeadon
    finally:
        yeadon.Human.segmental_densities = densities


def _human(yeadon: Any, lengths: Mapping[str, float], mass: float | None, cfg: Mapping[str, float]) -> Any:
    """A yeadon human of these measurements (m), scaled to ``mass`` (kg), in configuration ``cfg`` (rad)."""
    try:
        human = yeadon.Human(dict(lengths))
        if mass is not None:
            human.scale_human_by_mass(mass)
        human.set_CFG_dict(dict(cfg))
    except Exception as exc:  # yeadon raises bare Exception / ValueError on impossible measurements
        raise RiderError(f"the yeadon model cannot be built from these measurements ({exc})") from None
    return human


def _outputs(human: Any, origin: NDArray[np.float64], inertia: bool, mass: float | None = None) -> NDArray[np.float64]:
    """The rider's ``mass, x, z, Ixx, Iyy, Izz, Ixz`` (kg, m, kg m²; benchmark frame, about its mass centre).

    With ``mass``, as if yeadon had scaled the human's densities to it (``scale_human_by_mass``):
    every density times one factor scales the mass and the inertia by it and keeps the mass centre,
    so the human need not be rebuilt.
    """
    com = yeadon_to_benchmark(np.asarray(human.center_of_mass, dtype=float), origin)
    tensor = np.asarray(human.inertia_transformed(rotmat=YEADON_TO_BENCHMARK), dtype=float)
    factor = 1.0 if mass is None else mass / float(human.mass)
    scale = factor if inertia else 0.0
    return np.array(
        [
            human.mass * factor,
            com[0],
            com[2],
            tensor[0, 0] * scale,
            tensor[1, 1] * scale,
            tensor[2, 2] * scale,
            tensor[2, 0] * scale,
        ],
        dtype=float,
    )


def _angles(human: Any) -> NDArray[np.float64]:
    return np.array([human.CFG[a] for limb in LIMBS for a in limb.angles], dtype=float)


@dataclass(frozen=True)
class SeatedPose:
    """A Yeadon human posed on a bicycle.

    Attributes:
        human: The posed ``yeadon.Human`` (Yeadon's frame).
        origin: Yeadon's origin (hip joint centre) in the benchmark frame, m.
        targets: Limb name -> its target (bottom bracket or grip) in Yeadon's frame, m.
        angles: The solved joint angles, rad.
    """

    human: Any
    origin: NDArray[np.float64]
    targets: Mapping[str, NDArray[np.float64]]
    angles: Mapping[str, float]

    def end_point(self, limb: str) -> NDArray[np.float64]:
        """The end point of a limb (``"left arm"``...: hand or heel point) in the benchmark frame, m."""
        chosen = next(x for x in LIMBS if x.name == limb)
        return yeadon_to_benchmark(limb_end_point(self.human, chosen), self.origin)


#: The bicycle's parameters the pose depends on (the seat and bottom bracket through rR, the grips
#: through w, rR, rF).
POSE_PARAMETERS = ("rR", "rF", "w")


def pose_targets(
    g: Mapping[str, float], p: Mapping[str, float]
) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """Yeadon's origin in the benchmark frame and each limb's target in Yeadon's frame, m."""
    origin = seat_point(g["lst"], g["lsp"], g["lamst"], g["hbb"], g["lcs"], p["rR"])
    bb = bottom_bracket_point(g["hbb"], g["lcs"], p["rR"])
    grip = grip_point(p["w"], p["rR"], p["rF"], g["whb"], g["LhbR"], g["LhbF"])
    to_yeadon = YEADON_TO_BENCHMARK  # its own inverse
    targets = {
        "left leg": to_yeadon @ (bb - origin),
        "right leg": to_yeadon @ (bb - origin),
        "left arm": to_yeadon @ (grip - origin),
        "right arm": to_yeadon @ (grip * np.array([1.0, -1.0, 1.0]) - origin),
    }
    return origin, targets


def _pose(yeadon: Any, rider: YeadonRider, ps: ParameterSet) -> SeatedPose:
    """Build the rider's yeadon human and pose it on the bicycle of ``ps`` (inside :func:`_yeadon_guard`)."""
    g = rider_geometry(rider, ps)
    try:
        origin, targets = pose_targets(g, ps.values())
        m = rider.measurements
        human = _human(yeadon, m.lengths, m.mass, rider.configuration)
        angles = solve_pose(human, targets)
    except RiderPoseError as exc:
        keys = ", ".join(f"{k} = {v:.4g}" for k, v in g.items())
        raise RiderPoseError(f"{exc} (bicycle {ps.source}: {keys}; rider {rider.path})") from None
    return SeatedPose(human, origin, targets, angles)


def seated_pose(rider: YeadonRider, ps: ParameterSet) -> SeatedPose:
    """The rider's yeadon human posed on the bicycle of ``ps`` (feet on the bottom bracket, hands on the grips).

    Raises:
        RiderError: Missing rider-geometry keys, or a yeadon model that cannot be built.
        RiderPoseError: The rider cannot be seated (the geometry that cannot be reached is named).
    """
    with _yeadon_guard() as yeadon:
        return _pose(yeadon, rider, ps)


def seat_rider(rider: YeadonRider, ps: ParameterSet) -> Rider:
    """The Yeadon rider seated on the bicycle of ``ps``, as a rigid rider with its σ.

    Each body measurement has an independent σ (``measurement_sigma``, default
    :data:`DEFAULT_MEASUREMENT_SIGMA`; total mass ``mass_sigma``, :data:`DEFAULT_MASS_SIGMA`).
    The Jacobian of the rider's seven numbers to them is by forward differences through yeadon
    (no complex step), the pose moving along (dq/dm = −(∂r/∂q)⁻¹ ∂r/∂m). With ``pose_sigma``
    (default true) the pose also follows w, rR and rF, so their σ reach the rider, correlated;
    the rider-geometry keys and the torso angles are exact.

    Raises:
        RiderError: Missing rider-geometry keys, or a yeadon model that cannot be built.
        RiderPoseError: The rider cannot be seated (a limb cannot reach, or the pose is not
            symmetric about the bicycle's plane).
    """
    key = _seat_key(rider, ps)
    if key in _SEATED:
        return _SEATED[key]
    with _yeadon_guard() as yeadon:
        pose = _pose(yeadon, rider, ps)
        human, origin = pose.human, pose.origin
        com = yeadon_to_benchmark(np.asarray(human.center_of_mass, dtype=float), origin)
        if abs(com[1]) > 1e-6:
            raise RiderPoseError(
                f"the seated rider's mass centre is {com[1]:.3g} m off the bicycle's plane: the Whipple model needs a "
                f"rider symmetric about it (tilt, twist, PTbending, TCspinalTorsion of {rider.path}'s configuration)"
            )
        values = _outputs(human, origin, rider.inertia)
        sensitivity = _sensitivity(yeadon, rider, human, ps, origin, values)
    mass, x, z, Ixx, Iyy, Izz, Ixz = (float(v) for v in values)
    seated = Rider(mass, x, z, Ixx, Iyy, Izz, Ixz, name=rider.name, sensitivity=sensitivity)
    if len(_SEATED) >= _SEATED_MAX:
        _SEATED.pop(next(iter(_SEATED)))
    _SEATED[key] = seated
    return seated


#: Riders seated in this process, by everything the result depends on (a figure run or a report
#: seats the same rider on the same bicycle many times, and a live session's parameter sets
#: differ in their inertia only, not in the w, rR, rF the pose depends on; the rider's σ cost
#: ~1 s each).
_SEATED: dict[tuple[Any, ...], Rider] = {}
_SEATED_MAX = 16


def _seat_key(rider: YeadonRider, ps: ParameterSet) -> tuple[Any, ...]:
    """Everything :func:`seat_rider`'s result depends on, hashable (of the bicycle's parameters: w, rR, rF)."""
    m = rider.measurements
    values = ps.values()
    return (
        rider.name,
        rider.path,
        tuple(sorted(m.lengths.items())),
        m.mass,
        tuple(sorted(rider.configuration.items())),
        rider.inertia,
        rider.measurement_sigma,
        rider.mass_sigma,
        rider.pose_sigma,
        tuple(sorted(rider.geometry.items())),
        tuple((k, values[k]) for k in POSE_PARAMETERS),
        tuple(str(ps.extras.get(k)) for k in RIDER_GEOMETRY_KEYS),
        ps.source,
        ps.bicycle,
    )


def _sensitivity(
    yeadon: Any,
    rider: YeadonRider,
    human: Any,
    ps: ParameterSet,
    origin: NDArray[np.float64],
    values: NDArray[np.float64],
) -> RiderSensitivity | None:
    """d(rider's seven numbers)/d(body measurements, and the bicycle's w, rR, rF), the pose following.

    Forward differences of the pose residual r and the outputs o at the solved angles q, then the
    implicit-function theorem: dq/dx = -(∂r/∂q)⁻¹ ∂r/∂x, do/dx = ∂o/∂x + ∂o/∂q dq/dx.
    """
    m = rider.measurements
    inputs: list[tuple[str, float, float]] = []  # name, σ, step
    if rider.measurement_sigma > 0:
        inputs += [(k, rider.measurement_sigma, _STEP_LENGTH) for k in m.lengths]
    if rider.mass_sigma > 0 and m.mass is not None:
        inputs.append(("totalmass", rider.mass_sigma, _STEP_MASS))
    bicycle = POSE_PARAMETERS if rider.pose_sigma else ()
    if not inputs and not bicycle:
        return None
    g, p = rider_geometry(rider, ps), ps.values()
    _, targets = pose_targets(g, p)
    q0, cfg = _angles(human), dict(human.CFG)
    r0 = pose_residual(human, targets)
    dr_dq = np.empty((r0.size, q0.size))
    do_dq = np.empty((values.size, q0.size))
    names = [a for limb in LIMBS for a in limb.angles]
    for j, name in enumerate(names):
        human.set_CFG_dict({**cfg, name: cfg[name] + _STEP_ANGLE})
        dr_dq[:, j] = (pose_residual(human, targets) - r0) / _STEP_ANGLE
        do_dq[:, j] = (_outputs(human, origin, rider.inertia) - values) / _STEP_ANGLE
    human.set_CFG_dict(cfg)
    n = len(inputs) + len(bicycle)
    dr_dx, do_dx = np.empty((r0.size, n)), np.empty((values.size, n))
    for j, (name, _, step) in enumerate(inputs):
        lengths, mass = dict(m.lengths), m.mass
        if name == "totalmass":
            mass = (mass or 0.0) + step
        else:
            lengths[name] += step
        moved = _human(yeadon, lengths, None, cfg)  # unscaled: scaling the densities is linear (below)
        dr_dx[:, j] = (pose_residual(moved, targets) - r0) / step
        do_dx[:, j] = (_outputs(moved, origin, rider.inertia, mass) - values) / step
    for j, name in enumerate(bicycle, start=len(inputs)):
        origin_h, targets_h = pose_targets(g, {**p, name: p[name] + _STEP_LENGTH})
        dr_dx[:, j] = (pose_residual(human, targets_h) - r0) / _STEP_LENGTH
        do_dx[:, j] = (_outputs(human, origin_h, rider.inertia) - values) / _STEP_LENGTH
    jacobian = do_dx - do_dq @ np.linalg.solve(dr_dq, dr_dx)
    k = len(inputs)
    return RiderSensitivity(
        tuple(f"rider {name}" for name, _, _ in inputs),
        np.array([s for _, s, _ in inputs]),
        jacobian[:, :k],
        RIDER_FILE_KEYS,
        bicycle,
        jacobian[:, k:],
    )
