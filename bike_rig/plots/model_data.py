"""The numbers behind the paper's section-10 figures, for one bicycle (with or without rider).

Each figure of :mod:`.eigen`, :mod:`.locus`, :mod:`.modes` and :mod:`.bode` draws one of the
records computed here, so tests check numbers, not pixels:

* :func:`eigen_curves` → :class:`EigenCurves`: tracked, labelled eigenvalues over speed with
  the first-order σ of their real and imaginary parts (:mod:`bike_rig.core.uncertainty.eigen_sigma`), the
  weave and capsize speeds with σ (:mod:`bike_rig.core.uncertainty.speed_sigma`), and the speed intervals
  where the capsize and caster roots form a complex pair (their ends refined to the double root
  of the characteristic polynomial);
* :func:`mode_shape` → :class:`ModeShape`: one mode's eigenvector ``[φ, δ, φ̇, δ̇]`` at one speed
  as phasors; :func:`capsize_caster_speed` → a speed inside the capsize–caster complex interval
  (where the paper's Fig 15 shows that pair);
* :func:`bode_curves` → :class:`BodeCurves`: magnitude and phase of any input → output pair at
  one speed (:mod:`bike_rig.core.frequency`).

Units: speeds m/s, eigenvalues and their σ 1/s, angles rad, frequencies rad/s, magnitudes dB
relative to one output unit per N m, phases degrees.

Nothing here imports matplotlib.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.benchmark import ParameterSet
from ..core.errors import BikeRigError, ModelError
from ..core.feedback import Feedback
from ..core.frequency import INPUTS, OUTPUTS, bode, frequency_response
from ..core.rider import add_rider, resolve_rider, rider_key
from ..core.uncertainty.eigen_sigma import eigenvalues_with_sigma
from ..core.uncertainty.matrix_sigma import MatrixSet, SigmaConvention, canonical_with_sigma
from ..core.uncertainty.speed_sigma import SpeedWithSigma, critical_speeds_with_sigma
from ..core.whipple import MODE_LABELS, WhippleMatrices, characteristic_coefficients, eigenvalues
from ..core.whipple.closed_loop import closed_loop_coefficients
from ..offline.subjects import Subject

__all__ = [
    "MAX_SPEED",
    "COMPLEX_TOL",
    "COMPONENTS",
    "DEFAULT_OMEGA",
    "DEFAULT_SPEEDS",
    "MODES",
    "BodeCurves",
    "EigenCurves",
    "FigureInputError",
    "ModeShape",
    "bode_curves",
    "capsize_caster_intervals",
    "capsize_caster_speed",
    "complex_intervals",
    "eigen_curves",
    "mode_shape",
    "model_parameters",
    "quartic_discriminant",
    "rider_title",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Default speeds of the eigenvalue figures: 0 to 10 m/s in 0.02 m/s steps.
DEFAULT_SPEEDS: FloatArray = np.linspace(0.0, 10.0, 501)
#: Default frequencies of the Bode figures: 0.1 to 100 rad/s, log-spaced.
DEFAULT_OMEGA: FloatArray = np.logspace(-1.0, 2.0, 400)
#: Mode labels a figure accepts (the eigenvalue columns of :data:`MODE_LABELS`).
MODES: tuple[str, ...] = ("weave", "capsize", "caster")
#: The components of an eigenvector, in state order ``[φ, δ, φ̇, δ̇]``.
COMPONENTS: tuple[str, ...] = ("roll angle", "steer angle", "roll rate", "steer rate")
#: An eigenvalue counts as complex when ``|Im λ| > COMPLEX_TOL · max(1, |λ|)``.
COMPLEX_TOL = 1e-9
#: The eigenvector figure sweeps from 0 to at least this speed (m/s) so its mode labels are
#: those of the eigenvalue figure (labels come from the structure at the sweep's top speed).
_LABEL_SWEEP_TOP = 10.0


class FigureInputError(BikeRigError):
    """A figure was asked for something that does not exist (unknown mode, input, output, speed)."""


@dataclass(frozen=True)
class EigenCurves:
    """Eigenvalues of one bicycle over speed, with σ and the critical speeds (paper Figs 13/16).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" (none) or "paper".
        speeds: Speeds, shape (N,), m/s, increasing.
        eigenvalues: Shape (N, 4), 1/s, columns :data:`labels` (tracked along speed).
        labels: ``("weave", "weave", "capsize", "caster")``.
        sigma_real: σ of ``Re λ``, shape (N, 4), 1/s; NaN near branch points.
        sigma_imag: σ of ``Im λ``, shape (N, 4), 1/s; NaN near branch points.
        weave: Weave speed with σ, m/s, or None.
        capsize: Capsize speed with σ, m/s, or None.
        capsize_caster_complex: Speed intervals ``(start, stop)`` (m/s) in which the capsize and
            caster roots are a complex pair; an end strictly inside the sweep is the speed of the
            double root (branch point), an end at the sweep's edge is that edge.
        feedback: "" (the open loop) or the name of the steer-torque feedback whose closed
            loop these are.
    """

    bicycle: str
    rider: str
    speeds: FloatArray
    eigenvalues: ComplexArray
    labels: tuple[str, ...]
    sigma_real: FloatArray
    sigma_imag: FloatArray
    weave: SpeedWithSigma | None
    capsize: SpeedWithSigma | None
    capsize_caster_complex: tuple[tuple[float, float], ...]
    feedback: str = ""

    def mode(self, label: str) -> ComplexArray:
        """The columns of one mode.

        Args:
            label: A mode label of :data:`bike_rig.core.whipple.MODE_LABELS`.

        Returns:
            Its eigenvalues, 1/s, shape (N, k) (k = 2 for weave).

        Raises:
            FigureInputError: Unknown mode label.
        """
        return self.eigenvalues[:, _mode_columns(label)]


@dataclass(frozen=True)
class ModeShape:
    """One mode's eigenvector at one speed as phasors (paper Fig 15).

    The state eigenvector ``x = [φ, δ, φ̇, δ̇]`` is scaled so that the larger of the two angle
    components has modulus 1 and phase 0; the rates are then ``λ`` times the angles.

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        mode: The mode label asked for.
        speed: m/s.
        eigenvalue: ``λ``, 1/s (the member with ``Im λ ≥ 0`` of a complex pair).
        components: ``[φ, δ, φ̇, δ̇]``, shape (4,): angles in rad, rates in rad/s, per unit of
            the reference angle.
        names: The components' names.
        reference: Index (0 roll, 1 steer) of the angle scaled to 1 at 0°.
    """

    bicycle: str
    rider: str
    mode: str
    speed: float
    eigenvalue: complex
    components: ComplexArray
    names: tuple[str, ...]
    reference: int

    @property
    def magnitude(self) -> FloatArray:
        """``|component|`` (rad or rad/s per unit reference angle)."""
        return np.asarray(np.abs(self.components))

    @property
    def phase_deg(self) -> FloatArray:
        """Phase of each component relative to the reference angle, degrees in (-180, 180]."""
        return np.asarray(np.degrees(np.angle(self.components)))

    @property
    def oscillatory(self) -> bool:
        """Whether the mode oscillates (a complex eigenvalue)."""
        return abs(self.eigenvalue.imag) > COMPLEX_TOL * max(1.0, abs(self.eigenvalue))


@dataclass(frozen=True)
class BodeCurves:
    """Frequency response of one input → output pair at one speed (paper Figs 17/18).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        speed: m/s.
        input: One of :data:`bike_rig.core.frequency.INPUTS`.
        output: One of :data:`bike_rig.core.frequency.OUTPUTS`.
        omega: Angular frequencies, rad/s.
        response: ``G(iω)``, rad/(N m) for angles, rad/(s N m) for rates.
        magnitude_db: ``20 log10 |G|``, dB.
        phase_deg: ``arg G`` unwrapped along ω, degrees.
        feedback: "" (the open loop) or the name of the feedback whose closed loop this is.
    """

    bicycle: str
    rider: str
    speed: float
    input: str
    output: str
    omega: FloatArray
    response: ComplexArray
    magnitude_db: FloatArray
    phase_deg: FloatArray
    feedback: str = ""


# --------------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------------


def rider_title(key: str) -> str:
    """A figure title's words for a rider key: "without rider", "with the paper's rider" or the rider file's name."""
    if key == "":
        return "without rider"
    if key == "paper":
        return "with the paper's rider"
    return f"with the rider of {Path(key).name}"


def _rider_key(rider: str) -> str:
    """The rider's key, "", "paper" or a rider file's path ("none" means no rider)."""
    return rider_key(rider)


def model_parameters(subject: Subject, rider: str = "") -> ParameterSet:
    """The subject's parameter set, with the named rider added.

    Args:
        subject: The bicycle.
        rider: "" or "none" (no rider), "paper" (Table 1, lumped into the rear frame), or a
            rider file (rigid or Yeadon; :func:`~bike_rig.core.rider.resolve_rider`).

    Returns:
        The parameters with σ.

    Raises:
        ModelError: Unknown rider, or a rider file that cannot be read or seated.
    """
    r = resolve_rider(rider)
    return subject.parameters if r is None else add_rider(subject.parameters, r)


def _mode_columns(label: str) -> list[int]:
    if label not in MODES:
        raise FigureInputError(f"unknown mode '{label}': expected one of {', '.join(MODES)}")
    return [j for j, name in enumerate(MODE_LABELS) if name == label]


#: Highest speed a figure accepts, m/s (far beyond any bicycle; the model's polynomials in v
#: would overflow long before float64 does at its own limit).
MAX_SPEED = 100.0


def _speeds(speeds: ArrayLike | None) -> FloatArray:
    """Sorted, distinct, finite speeds in [0, MAX_SPEED] (m/s), or the default sweep."""
    if speeds is None:
        return DEFAULT_SPEEDS.copy()
    arr = np.asarray(speeds, dtype=float).ravel()
    if arr.size < 2 or not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or np.any(arr > MAX_SPEED):
        raise FigureInputError(f"speeds must be at least two finite numbers from 0 to {MAX_SPEED:g} m/s")
    return np.unique(arr)


def _speed(speed: float) -> float:
    v = float(speed)
    if not (math.isfinite(v) and 0.0 <= v <= MAX_SPEED):
        raise FigureInputError(f"speed must be a finite number from 0 to {MAX_SPEED:g} m/s, got {speed}")
    return v


# --------------------------------------------------------------------------------------------
# Eigenvalues over speed
# --------------------------------------------------------------------------------------------


def quartic_discriminant(coefficients: ArrayLike) -> FloatArray:
    """Discriminant of ``a s⁴ + b s³ + c s² + d s + e`` (coefficients ``[..., a, b, c, d, e]``).

    Zero exactly where two roots coincide; negative when the quartic has two real roots and one
    complex pair, positive with four real roots or two complex pairs.

    Args:
        coefficients: The quartic's coefficients along the last axis, highest power first.

    Returns:
        The discriminant, one per quartic (the leading axes' shape).
    """
    co = np.asarray(coefficients, dtype=float)
    a, b, c, d, e = (co[..., k] for k in range(5))
    return np.asarray(
        256 * a**3 * e**3
        - 192 * a**2 * b * d * e**2
        - 128 * a**2 * c**2 * e**2
        + 144 * a**2 * c * d**2 * e
        - 27 * a**2 * d**4
        + 144 * a * b**2 * c * e**2
        - 6 * a * b**2 * d**2 * e
        - 80 * a * b * c**2 * d * e
        + 18 * a * b * c * d**3
        + 16 * a * c**4 * e
        - 4 * a * c**3 * d**2
        - 27 * b**4 * e**2
        + 18 * b**3 * c * d * e
        - 4 * b**3 * d**3
        - 4 * b**2 * c**3 * e
        + b**2 * c**2 * d**2
    )


def _branch_point(matrices: WhippleMatrices, g: float, lo: float, hi: float, feedback: Feedback | None = None) -> float:
    """The speed in ``[lo, hi]`` (m/s) where the discriminant changes sign, by bisection.

    Of the closed loop's characteristic polynomial with ``feedback``, else the open loop's.
    """

    def disc(v: float) -> float:
        speed = np.array([v])
        if feedback is None:
            return float(quartic_discriminant(characteristic_coefficients(matrices, g, speed))[0])
        return float(quartic_discriminant(closed_loop_coefficients(matrices, g, speed, feedback.gains(speed)))[0])

    f_lo = disc(lo)
    if f_lo == 0.0:
        return lo
    if disc(hi) * f_lo > 0.0:
        return 0.5 * (lo + hi)  # no single sign change in the bracket: its midpoint
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f_mid = disc(mid)
        if f_mid == 0.0 or mid in (lo, hi):
            return mid
        if f_mid * f_lo > 0.0:
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _is_complex(z: ComplexArray) -> NDArray[np.bool_]:
    return np.asarray(np.abs(z.imag) > COMPLEX_TOL * np.maximum(1.0, np.abs(z)))


def complex_intervals(
    matrices: WhippleMatrices, g: float, speeds: FloatArray, roots: ComplexArray, feedback: Feedback | None = None
) -> tuple[tuple[float, float], ...]:
    """Speed intervals (m/s) in which ``roots`` (shape (N,)) is complex.

    Each end between two sweep speeds is refined to the double root of the characteristic
    polynomial (the sign change of :func:`quartic_discriminant`) between them.

    Args:
        matrices: The bicycle's Whipple matrices.
        g: Gravity, m/s².
        speeds: The sweep's speeds, m/s, increasing.
        roots: One root's track over ``speeds``, 1/s.
        feedback: The steer-torque feedback of a closed loop's ``roots``; None: the open loop.

    Returns:
        (start, stop) pairs, m/s, in order.
    """
    flag = _is_complex(roots)
    out: list[tuple[float, float]] = []
    i, n = 0, flag.size
    while i < n:
        if not flag[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and flag[j + 1]:
            j += 1
        if i == 0:
            start = float(speeds[0])
        else:
            start = _branch_point(matrices, g, float(speeds[i - 1]), float(speeds[i]), feedback)
        if j == n - 1:
            stop = float(speeds[-1])
        else:
            stop = _branch_point(matrices, g, float(speeds[j]), float(speeds[j + 1]), feedback)
        out.append((start, stop))
        i = j + 1
    return tuple(out)


def eigen_curves(
    subject: Subject,
    rider: str = "",
    speeds: ArrayLike | None = None,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    feedback: Feedback | None = None,
) -> EigenCurves:
    """Eigenvalues with σ, critical speeds with σ and the complex capsize–caster intervals.

    Args:
        subject: The bicycle.
        rider: "" or "none" (no rider) or "paper" (Table 1, lumped into the rear frame).
        speeds: Speeds, m/s (at least two, ≥ 0; sorted and made distinct); default
            :data:`DEFAULT_SPEEDS`.
        convention: σ convention (``correlated`` keeps the parameter correlations).
        feedback: Steer-torque state feedback: the closed loop ``A − B K`` (σ from the
            parameters and the gains given with σ); None: the open loop.

    Returns:
        The curves (see :class:`EigenCurves`).

    Raises:
        ModelError: Unknown rider or a singular mass matrix.
        FigureInputError: Bad speeds.
    """
    key = _rider_key(rider)
    v = _speeds(speeds)
    ps = model_parameters(subject, key)
    ms: MatrixSet = canonical_with_sigma(ps, SigmaConvention(convention))
    es = eigenvalues_with_sigma(ps, v, convention, feedback=feedback)
    cs = critical_speeds_with_sigma(ps, SigmaConvention(convention), ms, feedback=feedback)
    z = es.sweep.eigenvalues
    return EigenCurves(
        bicycle=subject.name,
        rider=key,
        speeds=es.sweep.speeds,
        eigenvalues=z,
        labels=es.sweep.labels,
        sigma_real=es.sigma_real,
        sigma_imag=es.sigma_imag,
        weave=cs.weave,
        capsize=cs.capsize,
        capsize_caster_complex=complex_intervals(ms.matrices, ms.g, v, z[:, MODE_LABELS.index("capsize")], feedback),
        feedback="" if feedback is None else feedback.name,
    )


# --------------------------------------------------------------------------------------------
# Mode shapes
# --------------------------------------------------------------------------------------------


def mode_shape(subject: Subject, mode: str = "capsize", speed: float = 2.0, rider: str = "") -> ModeShape:
    """One mode's eigenvector at one speed, as phasors (paper Fig 15).

    The labels are those of :func:`eigen_curves` (tracked from 0 m/s to at least 10 m/s), so
    "capsize" inside a complex capsize–caster interval is that oscillatory pair; for a complex
    pair the member with ``Im λ ≥ 0`` is used (a phase > 0 then means the component leads).

    Args:
        subject: The bicycle.
        mode: A mode label of :data:`bike_rig.core.whipple.MODE_LABELS`.
        speed: m/s.
        rider: "" or "none" (no rider), or "paper".

    Returns:
        The eigenvector, scaled to its larger angle (see :class:`ModeShape`).

    Raises:
        FigureInputError: Unknown mode, or a speed that is not a finite number ≥ 0.
        ModelError: Unknown rider.
    """
    cols = _mode_columns(mode)
    v = _speed(speed)
    key = _rider_key(rider)
    ms = canonical_with_sigma(model_parameters(subject, key))
    grid = np.union1d(np.linspace(0.0, max(_LABEL_SWEEP_TOP, 1.5 * v), 501), [v])
    sweep = eigenvalues(ms.matrices, ms.g, grid, vectors=True)
    assert sweep.eigenvectors is not None
    row = int(np.searchsorted(grid, v))
    cands = sweep.eigenvalues[row, cols]
    pick = cols[int(np.argmax(cands.imag))] if len(cols) > 1 else cols[0]
    lam = complex(sweep.eigenvalues[row, pick])
    vec = np.asarray(sweep.eigenvectors[row, :, pick], dtype=complex)
    if lam.imag < 0.0:  # the conjugate member of a capsize–caster pair: take the Im ≥ 0 one
        lam, vec = lam.conjugate(), vec.conj()
    ref = int(np.argmax(np.abs(vec[:2])))
    vec = vec / vec[ref]
    vec[ref] = 1.0  # exactly (complex division can leave 1 - 1e-16)
    return ModeShape(subject.name, key, mode, v, lam, vec, COMPONENTS, ref)


def capsize_caster_intervals(subject: Subject, rider: str = "") -> tuple[tuple[float, float], ...]:
    """The speed intervals (m/s) in which the capsize and caster roots are a complex pair.

    From the model alone (no σ): the eigenvalues over :data:`DEFAULT_SPEEDS`, the ends refined
    to the double roots (:func:`complex_intervals`; the same intervals as
    :attr:`EigenCurves.capsize_caster_complex` of the default sweep).

    Args:
        subject: The bicycle.
        rider: "" or "none" (no rider), or "paper".

    Returns:
        (start, stop) pairs, m/s, in order; empty when the bicycle has no such pair (e.g. the
        paper's bicycles with the rider).

    Raises:
        ModelError: Unknown rider or a singular mass matrix.
    """
    ms = canonical_with_sigma(model_parameters(subject, _rider_key(rider)))
    v = DEFAULT_SPEEDS.copy()
    z = eigenvalues(ms.matrices, ms.g, v).eigenvalues
    return complex_intervals(ms.matrices, ms.g, v, z[:, MODE_LABELS.index("capsize")])


def capsize_caster_speed(subject: Subject, rider: str = "") -> tuple[float, tuple[float, float]] | None:
    """A speed at which the capsize and caster roots are a complex pair (paper Fig 15), m/s.

    The middle of the lowest interval of :func:`capsize_caster_intervals`, rounded to 0.01 m/s
    when that stays strictly inside it.

    Args:
        subject: The bicycle.
        rider: "" or "none" (no rider), or "paper".

    Returns:
        (speed, (start, stop) of its interval), m/s; None when there is no such pair.

    Raises:
        ModelError: Unknown rider or a singular mass matrix.
    """
    intervals = capsize_caster_intervals(subject, rider)
    if not intervals:
        return None
    lo, hi = intervals[0]
    mid = 0.5 * (lo + hi)
    rounded = round(mid, 2)
    return (rounded if lo < rounded < hi else mid), (lo, hi)


# --------------------------------------------------------------------------------------------
# Frequency response
# --------------------------------------------------------------------------------------------


def bode_curves(
    subject: Subject,
    speed: float = 2.0,
    rider: str = "",
    input: str = "steer torque",
    output: str = "roll angle",
    omega: ArrayLike | None = None,
    feedback: Feedback | None = None,
) -> BodeCurves:
    """Magnitude (dB) and unwrapped phase (deg) of ``input → output`` at one speed.

    Args:
        subject: The bicycle.
        speed: m/s.
        rider: "" or "none" (no rider), or "paper".
        input: One of :data:`bike_rig.core.frequency.INPUTS`.
        output: One of :data:`bike_rig.core.frequency.OUTPUTS`.
        omega: Frequencies, rad/s (all > 0); default :data:`DEFAULT_OMEGA`.
        feedback: Steer-torque state feedback: the closed loop's response to the torque added
            to the controller's; None: the open loop.

    Returns:
        The response (see :class:`BodeCurves`).

    Raises:
        FigureInputError: Unknown input or output, bad speed or frequencies.
        ModelError: Unknown rider.
    """
    if input not in INPUTS:
        raise FigureInputError(f"unknown input '{input}': expected one of {', '.join(INPUTS)}")
    if output not in OUTPUTS:
        raise FigureInputError(f"unknown output '{output}': expected one of {', '.join(OUTPUTS)}")
    v = _speed(speed)
    w = DEFAULT_OMEGA.copy() if omega is None else np.atleast_1d(np.asarray(omega, dtype=float))
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0.0):
        raise FigureInputError("frequencies must be finite numbers > 0 rad/s")
    key = _rider_key(rider)
    ms = canonical_with_sigma(model_parameters(subject, key))
    try:
        gains = None if feedback is None else feedback.gains(v)
        resp = frequency_response(ms.matrices, ms.g, v, w, input, output, gains)
        diagram = bode(ms.matrices, ms.g, v, w, input, output, gains)
    except ModelError as exc:
        raise FigureInputError(str(exc)) from None
    name = "" if feedback is None else feedback.name
    return BodeCurves(subject.name, key, v, input, output, w, resp, diagram.magnitude_db, diagram.phase_deg, name)
