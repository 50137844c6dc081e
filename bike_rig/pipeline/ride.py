"""Ride validation: the model's weave eigenvalue at each measured speed, and the comparison.

:func:`predicted_weave` gives, at each speed, the model's oscillatory eigenvalue (open loop,
or with a feedback the closed loop ``A − B K``) with the σ of its real and imaginary parts
from the parameter covariance — :func:`bike_rig.core.uncertainty.eigen_sigma.eigenvalues_with_sigma`,
the eigen-solver and σ of ``bike-rig model`` and the eigenvalue figures. Where several
complex pairs exist the one nearest the measured eigenvalue is taken, and a note says so.

:func:`compare_ride` sets each measured segment (:mod:`bike_rig.core.ride.eigen`) against it:
the normalised deviation of each part ``z = (measured − predicted) / sqrt(σ_m² + σ_p²)``, a
segment's ``sqrt((z_re² + z_im²) / 2)``; per speed the same for the segments combined; overall
the root mean square of every clean segment's z (≈ 1 when the model and the σ are right).
Units: speeds m/s, eigenvalues 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.benchmark import ParameterSet
from ..core.errors import ModelError
from ..core.feedback import Feedback
from ..core.ride.eigen import CombinedEigenvalue, MeasuredEigenvalue, combine_eigenvalues
from ..core.uncertainty.eigen_sigma import eigenvalues_with_sigma
from ..core.uncertainty.matrix_sigma import SigmaConvention

__all__ = [
    "Agreement",
    "PredictedWeave",
    "RideComparison",
    "RideSpeedError",
    "compare_ride",
    "normalised_deviation",
    "predicted_weave",
    "validate_ride",
]

FloatArray = NDArray[np.float64]

#: An eigenvalue with a smaller imaginary part [1/s] is real (no oscillation).
MIN_IMAG = 1e-9
#: Speeds of the predicted curve by default: from this [m/s] ...
CURVE_FROM = 0.5
#: ... to the larger of this [m/s] and 1.2 × the fastest segment, in this many steps.
CURVE_TO, CURVE_POINTS = 6.0, 111


class RideSpeedError(ModelError):
    """A segment has no speed, so no prediction."""


@dataclass(frozen=True)
class PredictedWeave:
    """The model's oscillatory eigenvalue at each speed.

    Attributes:
        speeds: m/s.
        real: Re λ [1/s] (NaN: no oscillatory mode).
        real_sigma: Its σ [1/s] (NaN near branch points).
        imag: Im λ > 0 [rad/s].
        imag_sigma: Its σ [rad/s].
        notes: What was chosen where it was not obvious.
    """

    speeds: FloatArray
    real: FloatArray
    real_sigma: FloatArray
    imag: FloatArray
    imag_sigma: FloatArray
    notes: tuple[str, ...]


def predicted_weave(
    ps: ParameterSet,
    speeds: ArrayLike,
    feedback: Feedback | None = None,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    near: ArrayLike | None = None,
) -> PredictedWeave:
    """The weave (oscillatory) eigenvalue with σ at ``speeds`` [m/s] (module docstring).

    Args:
        ps: The parameter set, with the rider already added.
        speeds: m/s.
        feedback: The closed loop's feedback, or None for the open loop.
        convention: The σ convention.
        near: The measured eigenvalues at those speeds (complex, 1/s): where several complex
            pairs exist, the nearest is taken. None: the pair labelled weave, else the fastest.

    Raises:
        ModelError: Bad speeds or a singular mass matrix.
    """
    v = np.atleast_1d(np.asarray(speeds, dtype=float))
    es = eigenvalues_with_sigma(ps, v, convention, feedback=feedback)
    lam = es.sweep.eigenvalues
    targets = None if near is None else np.atleast_1d(np.asarray(near, dtype=complex))
    out = np.full((4, v.size), math.nan)
    notes: list[str] = []
    for i in range(v.size):
        cand = [j for j in range(lam.shape[1]) if lam[i, j].imag > MIN_IMAG]
        if not cand:
            notes.append(f"{v[i]:.3g} m/s: the model has no oscillatory mode")
            continue
        if targets is not None and np.isfinite(targets[i]):
            j = min(cand, key=lambda c: abs(lam[i, c] - targets[i]))
            if len(cand) > 1:
                notes.append(f"{v[i]:.3g} m/s: {len(cand)} complex pairs, the nearest to the measured one is taken")
        else:
            weave = [c for c in cand if es.sweep.labels[c] == "weave"]
            j = weave[0] if weave else max(cand, key=lambda c: lam[i, c].imag)
        out[:, i] = lam[i, j].real, es.sigma_real[i, j], lam[i, j].imag, es.sigma_imag[i, j]
    return PredictedWeave(v, out[0], out[1], out[2], out[3], tuple(notes))


def normalised_deviation(measured: float, sigma_m: float, predicted: float, sigma_p: float) -> float:
    """The normalised deviation z = (measured − predicted) / sqrt(σ_m² + σ_p²) [-] (NaN without σ)."""
    combined = math.hypot(sigma_m, sigma_p)
    return (measured - predicted) / combined if combined > 0 else math.nan


def _pair(z_re: float, z_im: float) -> float:
    return math.sqrt(0.5 * (z_re**2 + z_im**2))


@dataclass(frozen=True)
class Agreement:
    """A measured eigenvalue against the model's at its speed.

    Attributes:
        predicted_real: Re λ of the model [1/s].
        predicted_real_sigma: Its σ [1/s].
        predicted_imag: Im λ of the model [rad/s].
        predicted_imag_sigma: Its σ [rad/s].
        z_real: Normalised deviation of the real parts [-].
        z_imag: Of the imaginary parts [-].
        deviation: sqrt((z_real² + z_imag²)/2) [-].
    """

    predicted_real: float
    predicted_real_sigma: float
    predicted_imag: float
    predicted_imag_sigma: float
    z_real: float
    z_imag: float
    deviation: float


@dataclass(frozen=True)
class SegmentComparison(Agreement):
    """One segment against the model (:class:`Agreement`).

    Attributes:
        segment: The measured eigenvalue.
    """

    segment: MeasuredEigenvalue = field(kw_only=True)


@dataclass(frozen=True)
class SpeedComparison(Agreement):
    """The segments at one speed combined, against the model (:class:`Agreement`).

    Attributes:
        combined: The measured eigenvalue, combined.
    """

    combined: CombinedEigenvalue = field(kw_only=True)


@dataclass(frozen=True)
class RideComparison:
    """Measured against predicted.

    Attributes:
        segments: One comparison per segment, in input order.
        speeds: One per speed, the segments combined.
        overall: RMS of every clean segment's z_real and z_imag [-] (NaN: none).
        notes: The prediction's notes.
    """

    segments: tuple[SegmentComparison, ...]
    speeds: tuple[SpeedComparison, ...]
    overall: float
    notes: tuple[str, ...]


def _against(
    m: MeasuredEigenvalue | CombinedEigenvalue, pred: PredictedWeave, i: int
) -> tuple[float, float, float, float, float, float, float]:
    """The prediction ``i`` (Re, σ, Im, σ) and the normalised deviations of ``m`` from it (re, im, pair)."""
    p = (float(pred.real[i]), float(pred.real_sigma[i]), float(pred.imag[i]), float(pred.imag_sigma[i]))
    valid = not isinstance(m, MeasuredEigenvalue) or m.valid
    z_re = normalised_deviation(m.real, m.real_sigma, p[0], p[1]) if valid else math.nan
    z_im = normalised_deviation(m.imag, m.imag_sigma, p[2], p[3]) if valid else math.nan
    return (*p, z_re, z_im, _pair(z_re, z_im))


def compare_ride(
    ps: ParameterSet,
    segments: Sequence[MeasuredEigenvalue],
    feedback: Feedback | None = None,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
) -> RideComparison:
    """Each segment's eigenvalue against the model's at its speed (module docstring).

    Args:
        ps: The parameter set, with the rider added.
        segments: The measured eigenvalues (each with a finite speed).
        feedback: The closed loop's feedback, or None.
        convention: The σ convention of the prediction.

    Raises:
        ModelError: Bad speeds or a singular mass matrix.
    """
    near = [complex(s.real, s.imag) if s.valid else complex(math.nan, math.nan) for s in segments]
    pred = predicted_weave(ps, [s.speed for s in segments], feedback, convention, near)
    rows = [SegmentComparison(*_against(s, pred, i), segment=s) for i, s in enumerate(segments)]
    zs = [z for r in rows if r.segment.clean for z in (r.z_real, r.z_imag) if math.isfinite(z)]
    combined = [c for c in combine_eigenvalues(segments) if c.n_used]
    per_speed = []
    if combined:
        cp = predicted_weave(ps, [c.speed for c in combined], feedback, convention,
                             [complex(c.real, c.imag) for c in combined])  # fmt: skip
        per_speed = [SpeedComparison(*_against(c, cp, k), combined=c) for k, c in enumerate(combined)]
    overall = math.sqrt(float(np.mean(np.square(zs)))) if zs else math.nan
    return RideComparison(tuple(rows), tuple(per_speed), overall, pred.notes)


def validate_ride(
    ps: ParameterSet,
    segments: Sequence[MeasuredEigenvalue],
    feedback: Feedback | None = None,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    speeds: ArrayLike | None = None,
) -> tuple[RideComparison, PredictedWeave]:
    """The comparison (:func:`compare_ride`) and the predicted curve over ``speeds`` [m/s] for the figure.

    Args:
        ps: The parameter set, with the rider added.
        segments: The measured eigenvalues.
        feedback: The closed loop's feedback, or None.
        convention: The σ convention of the prediction.
        speeds: The curve's speeds (default: :data:`CURVE_FROM` to the larger of
            :data:`CURVE_TO` and 1.2 × the fastest segment).

    Raises:
        RideSpeedError: A segment without a speed.
        ModelError: Bad speeds or a singular mass matrix.
    """
    for m in segments:
        if not math.isfinite(m.speed):
            raise RideSpeedError(f"{m.source}: segment {m.index} has no speed: give --speed or a speed column or topic")
    if speeds is None:
        top = max((m.speed for m in segments), default=CURVE_TO)
        speeds = np.linspace(CURVE_FROM, max(CURVE_TO, 1.2 * top), CURVE_POINTS)
    return compare_ride(ps, segments, feedback, convention), predicted_weave(ps, speeds, feedback, convention)
