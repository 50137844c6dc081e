"""The 25 benchmark parameters (Meijaard et al. 2007) from raw readings, with σ and correlations.

:func:`benchmark_formulas` chains the paper's equations (sections 6–9) on named readings; it is
pure broadcasting arithmetic, so :func:`compute_parameters` evaluates it once with the complex
step to get the exact Jacobian to every reading (linear σ with correlations, paper Eq 3), and
:func:`monte_carlo_parameters` evaluates it on random samples of the readings.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import com, geometry, inertia
from .errors import GeometryError
from .measurements import Measurements, validate
from .symbols import PARAMETER_NAMES
from .uncertainty.uncertain import Propagated, UncertainVector, complex_step_jacobian, monte_carlo
from .units import radians

__all__ = [
    "PARAMETER_NAMES",
    "ComEstimate",
    "ComMethod",
    "ParameterSet",
    "RawPropagation",
    "benchmark_formulas",
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
        part: 'B' (rear frame) or 'H' (fork/handlebar).
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
        extras: The raw file's entries the parameters do not need (e.g. the rider-geometry keys
            a Yeadon rider is seated with), when computed from measurements.
    """

    bicycle: str
    parameters: UncertainVector
    source: str
    raw: RawPropagation | None = None
    com: Mapping[str, ComEstimate] | None = None
    extras: Mapping[str, object] = field(default_factory=dict)

    def values(self) -> dict[str, float]:
        """``{name: value}`` for the 26 parameters."""
        return self.parameters.as_dict()


def _orientation_keys(readings: Mapping[str, Any], part: str) -> list[int]:
    return sorted(int(k[len("alpha") + 1 :]) for k in readings if k.startswith(f"alpha{part}"))


def _part_com(
    x: Mapping[str, Any], part: str, lam: Any, rR: Any, rF: Any, w: Any
) -> tuple[list[Any], dict[str, Any]]:
    """Hanging-line geometry of one part: its β_i and both mass-centre solutions."""
    betas, slopes, intercepts = [], [], []
    for i in _orientation_keys(x, part):
        beta = com.pendulum_rotation_angle(lam, radians(x[f"alpha{part}{i}"]))
        a = x[f"a{part}{i}"]
        if part == "B":
            b = com.frame_com_line_intercept(a, beta, rR)
        else:
            b = com.fork_com_line_intercept(a, beta, w, rF)
        betas.append(beta)
        slopes.append(com.com_line_slope(beta))
        intercepts.append(b)
    xc, zc = com.centroid_com(slopes, intercepts)
    xl, zl = com.least_squares_com(slopes, intercepts)
    return betas, {
        f"x{part}_centroid": xc,
        f"z{part}_centroid": zc,
        f"x{part}_lstsq": xl,
        f"z{part}_lstsq": zl,
    }


def benchmark_formulas(x: Mapping[str, Any], method: ComMethod = ComMethod.CENTROID) -> dict[str, Any]:
    """The paper's chain of equations from raw readings to the benchmark parameters.

    Args:
        x: Readings by flat key (see :mod:`bike_rig.core.measurements`); each a float or a
            broadcasting array (samples, or complex-step perturbations).
        method: Mass-centre method feeding x_B, z_B, x_H, z_H.

    Returns:
        The 26 parameters (PARAMETER_NAMES) followed by intermediate results: both
        mass-centre solutions per part and the torsion-rod stiffness ``k``.
    """
    g, w = x["g"], x["w"]
    rR = geometry.wheel_radius(x["dR"], x["nR"])  # Eq 6
    rF = geometry.wheel_radius(x["dF"], x["nF"])  # Eq 6
    lam = geometry.steer_axis_tilt(radians(x["gamma"]))  # Eq 7
    c = geometry.trail(rF, lam, x["f"])  # Eq 8
    betas_B, com_B = _part_com(x, "B", lam, rR, rF, w)  # Eq 10–20
    betas_H, com_H = _part_com(x, "H", lam, rR, rF, w)  # Eq 10–22
    suffix = "centroid" if method is ComMethod.CENTROID else "lstsq"
    xB, zB = com_B[f"xB_{suffix}"], com_B[f"zB_{suffix}"]
    xH, zH = com_H[f"xH_{suffix}"], com_H[f"zH_{suffix}"]
    k = inertia.torsional_stiffness(inertia.rod_inertia(x["mP"], x["lP"], x["dP"]), x["TtP1"])  # Fig 9
    J_B = [inertia.torsional_pendulum_inertia(k, x[f"TtB{i}"]) for i in _orientation_keys(x, "B")]  # Eq 30
    J_H = [inertia.torsional_pendulum_inertia(k, x[f"TtH{i}"]) for i in _orientation_keys(x, "H")]
    IBxx, IBxz, IBzz = inertia.inertia_from_pendulum_axes(J_B, betas_B)  # Eq 31–35
    IHxx, IHxz, IHzz = inertia.inertia_from_pendulum_axes(J_H, betas_H)
    lB = inertia.frame_pendulum_length(xB, zB, rR)  # Eq 36
    lH = inertia.fork_pendulum_length(xH, zH, w, rF)  # Eq 37
    out: dict[str, Any] = {
        "IBxx": IBxx,
        "IBxz": IBxz,
        "IByy": inertia.compound_pendulum_inertia(x["mB"], g, lB, x["TcB1"]),  # Eq 28
        "IBzz": IBzz,
        "IFxx": inertia.torsional_pendulum_inertia(k, x["TtF1"]),  # Eq 29
        "IFyy": inertia.compound_pendulum_inertia(x["mF"], g, x["lF"], x["TcF1"]),  # Eq 28
        "IHxx": IHxx,
        "IHxz": IHxz,
        "IHyy": inertia.compound_pendulum_inertia(x["mH"], g, lH, x["TcH1"]),  # Eq 28
        "IHzz": IHzz,
        "IRxx": inertia.torsional_pendulum_inertia(k, x["TtR1"]),  # Eq 29
        "IRyy": inertia.compound_pendulum_inertia(x["mR"], g, x["lR"], x["TcR1"]),  # Eq 28
        "c": c,
        "g": g,
        "lam": lam,
        "mB": x["mB"],
        "mF": x["mF"],
        "mH": x["mH"],
        "mR": x["mR"],
        "rF": rF,
        "rR": rR,
        "w": w,
        "xB": xB,
        "xH": xH,
        "zB": zB,
        "zH": zH,
    }
    out.update(com_B)
    out.update(com_H)
    out["k"] = k
    return out


def check_orientations(m: Measurements) -> None:
    """Reject hanging orientations that cannot determine a mass centre or inertia tensor.

    Two orientations whose pendulum axes are parallel (β_i ≡ β_j mod 180°) give no
    intersection (Eq 17) and identical rows of Eq 35.

    Raises:
        GeometryError: naming the part, the two orientations and their angle difference.
    """
    names = {"B": "frame", "H": "fork"}
    for part, name in names.items():
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


def _evaluator(method: ComMethod) -> Any:
    return lambda x: benchmark_formulas(x, method)


def compute_parameters(m: Measurements, method: ComMethod = ComMethod.CENTROID) -> ParameterSet:
    """Benchmark parameters of a measured bicycle with linear σ and correlations.

    Args:
        m: The bicycle's readings (validated here).
        method: Mass-centre method (the paper's centroid by default).

    Returns:
        The parameter set, its Jacobian to the readings and both mass-centre estimates.

    Raises:
        MeasurementError: a reading is missing or impossible.
        GeometryError: the hanging orientations are degenerate.
    """
    validate(m)
    check_orientations(m)
    values, perturbed, cov = _inputs(m)
    names = PARAMETER_NAMES + tuple(f"{q}{p}_{s}" for p in "BH" for s in ("centroid", "lstsq") for q in "xz")
    prop: Propagated = complex_step_jacobian(_evaluator(method), values, perturbed, names)
    n = len(PARAMETER_NAMES)
    full = prop.with_covariance(cov)
    params = UncertainVector(PARAMETER_NAMES, full.values[:n], full.covariance[:n, :n])
    coms = {}
    for part in "BH":
        ests = []
        for s in ("centroid", "lstsq"):
            sel = [full.index(f"x{part}_{s}"), full.index(f"z{part}_{s}")]
            ests.append(UncertainVector(("x", "z"), full.values[sel], full.covariance[np.ix_(sel, sel)]))
        coms[part] = ComEstimate(part, ests[0], ests[1], method)
    raw = RawPropagation(tuple(perturbed), cov, prop.jacobian[:n])
    return ParameterSet(m.bicycle, params, m.path, raw, coms, m.extras)


def monte_carlo_parameters(
    m: Measurements, samples: int, seed: int, method: ComMethod = ComMethod.CENTROID
) -> dict[str, NDArray[np.float64]]:
    """Benchmark parameters evaluated on ``samples`` normal draws of the readings.

    Returns:
        ``{parameter: samples}`` for the 26 parameters.
    """
    validate(m)
    check_orientations(m)
    values, perturbed, cov = _inputs(m)
    return monte_carlo(_evaluator(method), values, cov, perturbed, samples, seed, PARAMETER_NAMES)


def parameters_from_values(
    bicycle: str, values: Mapping[str, float], sigmas: Mapping[str, float], source: str
) -> ParameterSet:
    """A parameter set given directly (a parameter file): σ known, correlations unknown (zero)."""
    vals = np.array([float(values[n]) for n in PARAMETER_NAMES])
    cov = np.diag([float(sigmas.get(n, 0.0)) ** 2 for n in PARAMETER_NAMES])
    return ParameterSet(bicycle, UncertainVector(PARAMETER_NAMES, vals, cov), source)
