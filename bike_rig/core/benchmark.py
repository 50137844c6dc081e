"""The 25 benchmark parameters (Meijaard et al. 2007) from raw readings, with σ and correlations.

:func:`benchmark_formulas` chains the paper's equations (sections 6–9) on named readings; it is
pure broadcasting arithmetic, so :func:`compute_parameters` evaluates it once with the complex
step to get the exact Jacobian to every reading (linear σ with correlations, paper Eq 3), and
:func:`monte_carlo_parameters` evaluates it on random samples of the readings.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import com, flywheel, geometry, inertia, split_fork, surface_plate
from .errors import GeometryError
from .measurements import (
    PART_NAMES,
    Measurements,
    fork_is_split,
    geometry_from_surface_plate,
    has_flywheel,
    hung_parts,
    validate,
)
from .symbols import PARAMETER_NAMES
from .uncertainty.uncertain import Propagated, UncertainVector, complex_step_jacobian, monte_carlo
from .units import radians

__all__ = [
    "PARAMETER_NAMES",
    "ComEstimate",
    "ComMethod",
    "FLYWHEEL_PART_NAMES",
    "PART_GROUPS",
    "ParameterSet",
    "RawPropagation",
    "SPLIT_PART_NAMES",
    "benchmark_formulas",
    "com_estimate_names",
    "part_output_names",
    "check_orientations",
    "compute_parameters",
    "monte_carlo_parameters",
]


#: Smallest difference between two hanging orientations (mod 180°) that still determines a
#: mass centre and an inertia tensor; closer pairs make Eq 17 and Eq 35 singular.
MIN_ORIENTATION_SPREAD_DEG = 1.0


class ComMethod(str, Enum):
    """How several hanging lines are combined into one mass centre (paper section 8.2)."""

    CENTROID = "centroid"  # Eq 17–19, the paper's and BicycleParameters' choice
    LEAST_SQUARES = "lstsq"  # Eq 20


@dataclass(frozen=True)
class ComEstimate:
    """One part's mass centre by both methods, with σ.

    Attributes:
        part: 'B' (rear frame), 'H' (fork/handlebar), or 'S' (fork) and 'G' (handlebar).
        centroid: (x, z) by Eq 17–19 with its 2 × 2 covariance.
        least_squares: (x, z) by Eq 20 with its covariance.
        used: The method that fed the parameters.
    """

    part: str
    centroid: UncertainVector
    least_squares: UncertainVector
    used: ComMethod

    @property
    def more_accurate(self) -> ComMethod:
        """The method with the smaller radial σ, sqrt(σ_x² + σ_z²) (the paper's preference)."""
        c = float(np.trace(self.centroid.covariance))
        s = float(np.trace(self.least_squares.covariance))
        return ComMethod.CENTROID if c <= s else ComMethod.LEAST_SQUARES


@dataclass(frozen=True)
class RawPropagation:
    """How the parameters depend on the raw readings.

    Attributes:
        names: Names of the uncertain readings (the Jacobian's columns).
        covariance: Their covariance (diagonal: readings are independent).
        jacobian: d parameter / d reading, shape (26, n), rows in PARAMETER_NAMES order.
    """

    names: tuple[str, ...]
    covariance: NDArray[np.float64]
    jacobian: NDArray[np.float64]


@dataclass(frozen=True)
class ParameterSet:
    """A bicycle's benchmark parameters with their covariance.

    Attributes:
        bicycle: The bicycle's name.
        parameters: The 26 values (PARAMETER_NAMES order) with covariance.
        source: Where they came from (a file path).
        raw: The link to the raw readings, when computed from measurements.
        com: Mass-centre estimates by both methods, when computed from measurements.
        parts: Per-part outputs beyond the 26 parameters (fork S and handlebar G measured
            separately: ``mG, xG, zG, IGxx, IGxz, IGyy, IGzz`` and the same for S), with their
            covariance; None when there are none.
        extras: The raw file's entries the parameters do not need (e.g. the rider-geometry keys
            a Yeadon rider is seated with), when computed from measurements.
    """

    bicycle: str
    parameters: UncertainVector
    source: str
    raw: RawPropagation | None = None
    com: Mapping[str, ComEstimate] | None = None
    parts: UncertainVector | None = None
    extras: Mapping[str, object] = field(default_factory=dict)

    def values(self) -> dict[str, float]:
        """``{name: value}`` for the 26 parameters."""
        return self.parameters.as_dict()


def _orientation_keys(readings: Mapping[str, Any], part: str) -> list[int]:
    return sorted(int(k[len("alpha") + 1 :]) for k in readings if k.startswith(f"alpha{part}"))


#: Per-part outputs of a split fork (fork S, handlebar G), reported beside the 26 parameters.
SPLIT_PART_NAMES: tuple[str, ...] = tuple(
    n for p in "GS" for n in (f"m{p}", f"x{p}", f"z{p}", f"I{p}xx", f"I{p}xz", f"I{p}yy", f"I{p}zz")
)


#: Per-part outputs of a flywheel D on the front wheel (:mod:`~bike_rig.core.flywheel`).
FLYWHEEL_PART_NAMES: tuple[str, ...] = ("mD", "IDxx", "IDyy")


#: The groups of per-part outputs, each reported whole or not at all.
PART_GROUPS: tuple[tuple[str, ...], ...] = (SPLIT_PART_NAMES, FLYWHEEL_PART_NAMES)


def part_output_names(readings: Mapping[str, Any]) -> tuple[str, ...]:
    """Names of the per-part outputs beyond the 26 parameters for these readings (may be empty)."""
    split = SPLIT_PART_NAMES if fork_is_split(readings) else ()
    return split + (FLYWHEEL_PART_NAMES if has_flywheel(readings) else ())


def _flywheel(x: Mapping[str, Any], k: Any, IFxx: Any, IFyy: Any) -> dict[str, Any]:
    """The flywheel D's mass and moments about the wheel centre (differences of Eq 28 and Eq 29)."""
    I_FD_yy = inertia.compound_pendulum_inertia(x["mD"], x["g"], x["lF"], x["TcD1"])  # Eq 28
    I_FD_xx = inertia.torsional_pendulum_inertia(k, x["TtD1"])  # Eq 29
    return {
        "mD": flywheel.flywheel_mass(x["mD"], x["mF"]),
        "IDxx": flywheel.flywheel_inertia(I_FD_xx, IFxx),
        "IDyy": flywheel.flywheel_inertia(I_FD_yy, IFyy),
    }


def com_estimate_names(readings: Mapping[str, Any]) -> tuple[str, ...]:
    """Names of both mass-centre solutions of every hung part (``xB_centroid``, ...)."""
    return tuple(f"{q}{p}_{s}" for p in hung_parts(readings) for s in ("centroid", "lstsq") for q in "xz")


Line = Callable[[Any, Any], Any]


def _part_com(x: Mapping[str, Any], part: str, lam: Any, line: Line) -> tuple[list[Any], dict[str, Any]]:
    """Hanging-line geometry of one part: its β_i and both mass-centre solutions.

    ``line(a, β)`` is the z-intercept of the pendulum axis for the part's pivot (Eq 14, 21).
    """
    betas, slopes, intercepts = [], [], []
    for i in _orientation_keys(x, part):
        beta = com.pendulum_rotation_angle(lam, radians(x[f"alpha{part}{i}"]))
        betas.append(beta)
        slopes.append(com.com_line_slope(beta))
        intercepts.append(line(x[f"a{part}{i}"], beta))
    xc, zc = com.centroid_com(slopes, intercepts)
    xl, zl = com.least_squares_com(slopes, intercepts)
    return betas, {
        f"x{part}_centroid": xc,
        f"z{part}_centroid": zc,
        f"x{part}_lstsq": xl,
        f"z{part}_lstsq": zl,
    }


def _geometry(x: Mapping[str, Any]) -> dict[str, Any]:
    """Wheel radii (Eq 6), steer-axis tilt, wheelbase and fork offset: given, or from the surface plate."""
    rR = geometry.wheel_radius(x["dR"], x["nR"])  # Eq 6
    rF = geometry.wheel_radius(x["dF"], x["nF"])  # Eq 6
    if not geometry_from_surface_plate(x):
        lam = geometry.steer_axis_tilt(radians(x["gamma"]))  # Eq 7
        return {"rR": rR, "rF": rF, "lam": lam, "w": x["w"], "f": x["f"]}
    a = surface_plate.rear_frame_offset(x["h1"], x["h2"], x["h3"], x["d1"], x["d2"])
    b = surface_plate.fork_offset(x["h4"], x["h5"], x["d3"], x["d4"])
    c_s = surface_plate.steer_axis_distance(a, b, x["d"], x["d2"], x["d3"])
    lam = surface_plate.steer_axis_tilt_from_offsets(rF, rR, a, b, c_s)
    w = surface_plate.wheelbase_from_offsets(a, b, c_s, lam)
    return {"rR": rR, "rF": rF, "lam": lam, "w": w, "f": b}


def _in_plane_part(
    x: Mapping[str, Any], part: str, k: Any, betas: list[Any], com_xz: tuple[Any, Any], pivot: Line
) -> dict[str, Any]:
    """A hung part's mass, mass centre and inertia.

    I_xx, I_xz, I_zz from the torsional periods (Eq 30–35), I_yy from its compound pendulum
    (Eq 28), ``pivot(x, z)`` being the distance from its pivot to the mass centre (Eq 36–37).
    """
    J = [inertia.torsional_pendulum_inertia(k, x[f"Tt{part}{i}"]) for i in _orientation_keys(x, part)]  # Eq 30
    Ixx, Ixz, Izz = inertia.inertia_from_pendulum_axes(J, betas)  # Eq 31–35
    length = pivot(com_xz[0], com_xz[1])  # Eq 36–37
    Iyy = inertia.compound_pendulum_inertia(x[f"m{part}"], x["g"], length, x[f"Tc{part}1"])  # Eq 28
    return {
        f"m{part}": x[f"m{part}"],
        f"x{part}": com_xz[0],
        f"z{part}": com_xz[1],
        f"I{part}xx": Ixx,
        f"I{part}xz": Ixz,
        f"I{part}yy": Iyy,
        f"I{part}zz": Izz,
    }


def _front_assembly(
    x: Mapping[str, Any], geo: Mapping[str, Any], k: Any, suffix: str, method_coms: dict[str, Any]
) -> dict[str, Any]:
    """The front assembly H: hung as one part, or combined from the fork S and handlebar G."""
    lam, w, rF = geo["lam"], geo["w"], geo["rF"]

    def axle(xc: Any, zc: Any) -> Any:
        return inertia.fork_pendulum_length(xc, zc, w, rF)  # Eq 37

    if not fork_is_split(x):
        betas, coms = _part_com(x, "H", lam, lambda a, beta: com.fork_com_line_intercept(a, beta, w, rF))  # Eq 21
        method_coms.update(coms)
        return _in_plane_part(x, "H", k, betas, (coms[f"xH_{suffix}"], coms[f"zH_{suffix}"]), axle)
    l1, l2 = split_fork.handlebar_reference_offsets(x["h6"], x["h7"], x["d5"], x["d6"], x["l"])
    u1, u2 = split_fork.handlebar_reference_point(lam, l1, l2)
    lines: dict[str, Line] = {
        "S": lambda a, beta: com.fork_com_line_intercept(a, beta, w, rF),  # Eq 21
        "G": lambda a, beta: split_fork.handlebar_com_line_intercept(a, beta, w, rF, u1, u2),
    }
    pivots: dict[str, Line] = {
        "S": axle,
        "G": lambda xc, zc: split_fork.pivot_distance(xc, zc, w - u1, -rF - u2),
    }
    out: dict[str, Any] = {}
    for part in "GS":
        betas, coms = _part_com(x, part, lam, lines[part])
        method_coms.update(coms)
        xz = (coms[f"x{part}_{suffix}"], coms[f"z{part}_{suffix}"])
        out.update(_in_plane_part(x, part, k, betas, xz, pivots[part]))
    mH, xH, zH = split_fork.combined_mass_centre([out["mG"], out["mS"]], [out["xG"], out["xS"]], [out["zG"], out["zS"]])
    IH = [0.0, 0.0, 0.0, 0.0]
    for part in "GS":
        I_xx, I_yy, I_zz, I_xz = (out[f"I{part}{ax}"] for ax in ("xx", "yy", "zz", "xz"))
        dx, dz = out[f"x{part}"] - xH, out[f"z{part}"] - zH
        moved = split_fork.parallel_axis_inertia(I_xx, I_yy, I_zz, I_xz, out[f"m{part}"], dx, dz)
        IH = [total + one for total, one in zip(IH, moved)]
    out.update({"mH": mH, "xH": xH, "zH": zH, "IHxx": IH[0], "IHyy": IH[1], "IHzz": IH[2], "IHxz": IH[3]})
    return out


def benchmark_formulas(
    x: Mapping[str, Any], method: ComMethod = ComMethod.CENTROID, lump_flywheel: bool = False
) -> dict[str, Any]:
    """The paper's chain of equations from raw readings to the benchmark parameters.

    The geometry is given (w, gamma, f) or measured on a surface plate
    (:mod:`~bike_rig.core.surface_plate`); the front assembly is hung as one part H or as the
    fork S and handlebar G (:mod:`~bike_rig.core.split_fork`); which one is decided by the keys
    present, never by values (the complex step stays analytic).

    Args:
        x: Readings by flat key (see :mod:`bike_rig.core.measurements`); each a float or a
            broadcasting array (samples, or complex-step perturbations).
        method: Mass-centre method feeding x_B, z_B, x_H, z_H (and x_S, z_S, x_G, z_G).
        lump_flywheel: With a flywheel D, give the model's front wheel its mass and moments
            (m_F, I_Fxx, I_Fyy of the wheel with it); by default the 26 parameters are those of
            the wheel alone, as BicycleParameters reports them.

    Returns:
        The 26 parameters (PARAMETER_NAMES), the per-part outputs (:func:`part_output_names`),
        both mass-centre solutions per hung part and the torsion-rod stiffness ``k``.
    """
    g = x["g"]
    geo = _geometry(x)
    rR, rF, lam = geo["rR"], geo["rF"], geo["lam"]
    c = geometry.trail(rF, lam, geo["f"])  # Eq 8
    suffix = "centroid" if method is ComMethod.CENTROID else "lstsq"
    k = inertia.torsional_stiffness(inertia.rod_inertia(x["mP"], x["lP"], x["dP"]), x["TtP1"])  # Fig 9
    coms: dict[str, Any] = {}
    betas_B, com_B = _part_com(x, "B", lam, lambda a, beta: com.frame_com_line_intercept(a, beta, rR))  # Eq 14
    coms.update(com_B)
    frame = _in_plane_part(
        x,
        "B",
        k,
        betas_B,
        (com_B[f"xB_{suffix}"], com_B[f"zB_{suffix}"]),
        lambda xc, zc: inertia.frame_pendulum_length(xc, zc, rR),  # Eq 36
    )
    front = _front_assembly(x, geo, k, suffix, coms)
    out: dict[str, Any] = {
        "IFxx": inertia.torsional_pendulum_inertia(k, x["TtF1"]),  # Eq 29
        "IFyy": inertia.compound_pendulum_inertia(x["mF"], g, x["lF"], x["TcF1"]),  # Eq 28
        "IRxx": inertia.torsional_pendulum_inertia(k, x["TtR1"]),  # Eq 29
        "IRyy": inertia.compound_pendulum_inertia(x["mR"], g, x["lR"], x["TcR1"]),  # Eq 28
        "c": c,
        "g": g,
        "lam": lam,
        "mF": x["mF"],
        "mR": x["mR"],
        "rF": rF,
        "rR": rR,
        "w": geo["w"],
    }
    out.update(frame)
    out.update(front)
    if has_flywheel(x):
        out.update(_flywheel(x, k, out["IFxx"], out["IFyy"]))
        if lump_flywheel:
            for name in ("mF", "IFxx", "IFyy"):
                out[name] = flywheel.wheel_with_flywheel(out[name], out[name.replace("F", "D", 1)])
    result = {name: out[name] for name in PARAMETER_NAMES}
    result.update({name: out[name] for name in part_output_names(x)})
    result.update(coms)
    result["k"] = k
    return result


def check_orientations(m: Measurements) -> None:
    """Reject hanging orientations that cannot determine a mass centre or inertia tensor.

    Two orientations whose pendulum axes are parallel (β_i ≡ β_j mod 180°) give no
    intersection (Eq 17) and identical rows of Eq 35.

    Raises:
        GeometryError: naming the part, the two orientations and their angle difference.
    """
    for part in hung_parts(m.readings):
        name = PART_NAMES[part]
        idx = m.orientations(part)
        for n, i in enumerate(idx):
            for j in idx[n + 1 :]:
                d = (m.value(f"alpha{part}{i}") - m.value(f"alpha{part}{j}")) % 180.0
                spread = min(d, 180.0 - d)
                if spread < MIN_ORIENTATION_SPREAD_DEG:
                    r = m.readings[f"alpha{part}{j}"]
                    o = r.origin
                    where = f"{o.path}: key '{o.key}'" if o else m.path
                    raise GeometryError(
                        f"{where}: {name} orientations {i} and {j} hang along parallel lines "
                        f"({spread:.3g}° apart modulo 180°), so they cannot locate the mass centre "
                        f"(Eq 17) or the inertia tensor (Eq 35); hang the {name} at a clearly "
                        "different angle"
                    )


def _inputs(m: Measurements) -> tuple[dict[str, float], list[str], NDArray[np.float64]]:
    values = {k: r.value for k, r in m.readings.items()}
    perturbed = [k for k, r in m.readings.items() if r.sigma > 0]
    cov = np.diag([m.readings[k].sigma ** 2 for k in perturbed])
    return values, perturbed, cov


def _evaluator(method: ComMethod, lump_flywheel: bool = False) -> Any:
    return lambda x: benchmark_formulas(x, method, lump_flywheel)


def compute_parameters(
    m: Measurements, method: ComMethod = ComMethod.CENTROID, lump_flywheel: bool = False
) -> ParameterSet:
    """Benchmark parameters of a measured bicycle with linear σ and correlations.

    Args:
        m: The bicycle's readings (validated here).
        method: Mass-centre method (the paper's centroid by default).
        lump_flywheel: A flywheel D turns with the front wheel: include it in m_F, I_Fxx, I_Fyy
            (see :func:`benchmark_formulas`).

    Returns:
        The parameter set, its Jacobian to the readings and both mass-centre estimates.

    Raises:
        MeasurementError: a reading is missing or impossible.
        GeometryError: the hanging orientations are degenerate.
    """
    validate(m)
    check_orientations(m)
    values, perturbed, cov = _inputs(m)
    extra = part_output_names(m.readings)
    parts = hung_parts(m.readings)
    names = PARAMETER_NAMES + extra + com_estimate_names(m.readings)
    prop: Propagated = complex_step_jacobian(_evaluator(method, lump_flywheel), values, perturbed, names)
    n = len(PARAMETER_NAMES)
    full = prop.with_covariance(cov)
    params = UncertainVector(PARAMETER_NAMES, full.values[:n], full.covariance[:n, :n])
    per_part = None
    if extra:
        sel = list(range(n, n + len(extra)))
        per_part = UncertainVector(extra, full.values[sel], full.covariance[np.ix_(sel, sel)])
    coms = {}
    for part in parts:
        ests = []
        for s in ("centroid", "lstsq"):
            sel = [full.index(f"x{part}_{s}"), full.index(f"z{part}_{s}")]
            ests.append(UncertainVector(("x", "z"), full.values[sel], full.covariance[np.ix_(sel, sel)]))
        coms[part] = ComEstimate(part, ests[0], ests[1], method)
    raw = RawPropagation(tuple(perturbed), cov, prop.jacobian[:n])
    return ParameterSet(m.bicycle, params, m.path, raw, coms, per_part, m.extras)


def monte_carlo_parameters(
    m: Measurements,
    samples: int,
    seed: int,
    method: ComMethod = ComMethod.CENTROID,
    lump_flywheel: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Benchmark parameters evaluated on ``samples`` normal draws of the readings.

    Returns:
        ``{parameter: samples}`` for the 26 parameters.
    """
    validate(m)
    check_orientations(m)
    values, perturbed, cov = _inputs(m)
    return monte_carlo(_evaluator(method, lump_flywheel), values, cov, perturbed, samples, seed, PARAMETER_NAMES)


def parameters_from_values(
    bicycle: str, values: Mapping[str, float], sigmas: Mapping[str, float], source: str
) -> ParameterSet:
    """A parameter set given directly (a parameter file): σ known, correlations unknown (zero)."""
    vals = np.array([float(values[n]) for n in PARAMETER_NAMES])
    cov = np.diag([float(sigmas.get(n, 0.0)) ** 2 for n in PARAMETER_NAMES])
    return ParameterSet(bicycle, UncertainVector(PARAMETER_NAMES, vals, cov), source)
