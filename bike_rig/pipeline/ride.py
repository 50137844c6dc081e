"""Ride validation: the model's weave eigenvalue at each measured speed, and the comparison.

:func:`predicted_weave` gives, at each speed, the model's oscillatory eigenvalue (open loop,
or with a feedback the closed loop ``A − B K``) with the σ of its real and imaginary parts
from the parameter covariance — :func:`bike_rig.core.uncertainty.eigen_sigma.eigenvalues_with_sigma`,
the eigen-solver and σ of ``bike-rig model`` and the eigenvalue figures. Where several
complex pairs exist the one nearest the measured eigenvalue is taken, and a note says so; where
the model has none at a measured speed, its eigenvalue nearest the measured one (a real root, Im λ
= 0). Where the first-order σ is not defined (near a branch point, NaN) it is a Monte Carlo σ
(:mod:`bike_rig.core.ride.weave_mc`), and the prediction says so (``sigma_method``). With a
feedback that has a rate (``rate_hz``: a digital controller holding its torque each period) the
eigenvalue is the sampled loop's (:func:`bike_rig.core.whipple.sampled.sampled_closed_loop_eigenvalues`):
the continuous loop's eigenvalue shifted by the sampled-minus-continuous difference at the
nominal parameters, its σ the continuous loop's (the shift is a few % of λ, its own σ smaller
still), and a note says so.

:func:`compare_ride` sets each measured segment (:mod:`bike_rig.core.ride.eigen`) against it:
the normalised deviation of each part ``z = (measured − predicted) / sqrt(σ_m² + σ_p²)``, a
segment's ``sqrt((z_re² + z_im²) / 2)``; per speed the same for the segments combined; overall
the root mean square of every clean segment's z (≈ 1 when the model and the σ are right). Each
comparison, each speed and the whole ride get a verdict in words (:mod:`bike_rig.core.ride.verdict`);
a speed without a clean segment gets one too.
Units: speeds m/s, eigenvalues 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.benchmark import ParameterSet
from ..core.errors import ModelError
from ..core.feedback import Feedback
from ..core.ride.eigen import CombinedEigenvalue, MeasuredEigenvalue, combine_eigenvalues
from ..core.ride.verdict import Verdict, overall_verdict, pair_verdict
from ..core.ride.weave_mc import eigenvalue_monte_carlo
from ..core.uncertainty.eigen_sigma import eigenvalues_with_sigma
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..core.whipple import canonical_matrices
from ..core.whipple.sampled import NYQUIST_SHARE, aliased, sampled_closed_loop_eigenvalues

__all__ = [
    "MONTE_CARLO",
    "Agreement",
    "PredictedWeave",
    "RideComparison",
    "RideSpeedError",
    "SampledLoopError",
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
#: ``sigma_method`` of a prediction whose σ is first order, or by Monte Carlo, or absent.
LINEAR, MONTE_CARLO, NO_SIGMA = "linear", "monte_carlo", "none"
#: What the verdicts say after a comparison with a Monte Carlo σ.
MONTE_CARLO_NOTE = "model σ by Monte Carlo: the linear σ is not defined near a branch point"


class RideSpeedError(ModelError):
    """A segment has no speed, so no prediction."""


class SampledLoopError(ModelError):
    """The feedback's controller rate is too slow for the mode compared."""


@dataclass(frozen=True)
class PredictedWeave:
    """The model's oscillatory eigenvalue at each speed.

    Attributes:
        speeds: m/s.
        real: Re λ [1/s] (NaN: no oscillatory mode).
        real_sigma: Its σ [1/s]: first order, or by Monte Carlo near branch points.
        imag: Im λ > 0 [rad/s] (0: the model's nearest mode is real, at a measured speed).
        imag_sigma: Its σ [rad/s].
        notes: What was chosen where it was not obvious.
        sigma_method: How each speed's σ was found: ``linear``, ``monte_carlo`` or ``none``.
        branches: At each speed, which eigenvalue branch the curve follows (-1: none): the
            number changes where the chosen eigenvalue is not the continuation of the one
            before, i.e. the curve switches to another mode and may jump.
    """

    speeds: FloatArray
    real: FloatArray
    real_sigma: FloatArray
    imag: FloatArray
    imag_sigma: FloatArray
    notes: tuple[str, ...]
    sigma_method: tuple[str, ...] = ()
    branches: tuple[int, ...] = ()


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
            pairs exist, the nearest is taken; where none, the nearest eigenvalue. None: the pair
            labelled weave, else the fastest (NaN where none).

    Raises:
        SampledLoopError: The feedback's rate is too slow for the chosen mode (its sampled
            ``|Im λ|`` beyond :data:`~bike_rig.core.whipple.sampled.NYQUIST_SHARE` of ``π/T``).
        ModelError: Bad speeds or a singular mass matrix.
    """
    v = np.atleast_1d(np.asarray(speeds, dtype=float))
    es = eigenvalues_with_sigma(ps, v, convention, feedback=feedback)
    lam = es.sweep.eigenvalues
    targets = None if near is None else np.atleast_1d(np.asarray(near, dtype=complex))
    out = np.full((4, v.size), math.nan)
    branch = [-1] * v.size
    notes: list[str] = []
    for i in range(v.size):
        cand = [j for j in range(lam.shape[1]) if lam[i, j].imag > MIN_IMAG]
        target = targets[i] if targets is not None else complex(math.nan, math.nan)
        if not cand and np.isfinite(target):
            j = int(np.argmin(np.abs(lam[i] - target)))
            notes.append(
                f"{v[i]:.3g} m/s: the model has no oscillatory mode; its eigenvalue nearest the measured one "
                f"({lam[i, j].real:+.3g} 1/s) is taken"
            )
            out[:, i] = lam[i, j].real, math.nan, abs(lam[i, j].imag), math.nan  # σ by Monte Carlo below
            branch[i] = j
            continue
        if not cand:
            notes.append(f"{v[i]:.3g} m/s: the model has no oscillatory mode")
            continue
        if np.isfinite(target):
            j = min(cand, key=lambda c: abs(lam[i, c] - target))
            if len(cand) > 1:
                notes.append(f"{v[i]:.3g} m/s: {len(cand)} complex pairs, the nearest to the measured one is taken")
        else:
            weave = [c for c in cand if es.sweep.labels[c] == "weave"]
            j = weave[0] if weave else max(cand, key=lambda c: lam[i, c].imag)
        out[:, i] = lam[i, j].real, es.sigma_real[i, j], lam[i, j].imag, es.sigma_imag[i, j]
        branch[i] = j
    branch_index = list(branch)
    branch = _branches(lam, branch)
    method = [LINEAR if np.isfinite(out[1, i]) else NO_SIGMA for i in range(v.size)]
    missing = np.flatnonzero(np.isfinite(out[0]) & ~(np.isfinite(out[1]) & np.isfinite(out[3])))
    if missing.size:
        mc = eigenvalue_monte_carlo(ps, v[missing], out[0, missing] + 1j * out[2, missing], feedback, convention)
        out[1, missing], out[3, missing] = mc.real_sigma, mc.imag_sigma
        for k, m in enumerate(missing.tolist()):
            method[m] = MONTE_CARLO
            if mc.real_fraction[k] > 0 and out[2, m] > 0:
                notes.append(
                    f"{v[m]:.3g} m/s: near a branch point: the weave pair is real in "
                    f"{100 * mc.real_fraction[k]:.0f} % of the Monte Carlo draws"
                )
    if feedback is not None and feedback.rate_hz is not None:
        notes += _sample_and_hold(ps, v, lam, branch_index, out, feedback)
    return PredictedWeave(v, out[0], out[1], out[2], out[3], tuple(notes), tuple(method), tuple(branch))


def _sample_and_hold(
    ps: ParameterSet, v: FloatArray, lam: NDArray[np.complex128], picked: list[int], out: FloatArray, feedback: Feedback
) -> list[str]:
    """Shift each chosen eigenvalue in ``out`` (rows Re, σ, Im, σ) to the sampled loop's; the notes to add.

    The continuous loop's eigenvalues ``lam`` (N, 4) [1/s] are matched one to one with the
    sampled loop's at the same speed (least total distance); the chosen one's counterpart minus
    it is added to Re λ and |Im λ|. σ stays the continuous loop's.

    Raises:
        SampledLoopError: A chosen mode's counterpart is too fast for the rate.
    """
    from scipy.optimize import linear_sum_assignment

    rate, period = float(feedback.rate_hz or math.nan), float(feedback.period or math.nan)
    values = ps.parameters.as_dict()
    sampled = sampled_closed_loop_eigenvalues(
        canonical_matrices(values), v, ps.parameters.value("g"), feedback.gains(v), period
    )
    notes: list[str] = []
    moved_re, moved_im = [], []
    for i, j in enumerate(picked):
        if j < 0 or not (np.isfinite(lam[i]).all() and np.isfinite(sampled[i]).all()):
            continue
        rows, cols = linear_sum_assignment(np.abs(lam[i][:, None] - sampled[i][None, :]))
        mu = complex(sampled[i][int(cols[list(rows).index(j)])])
        if aliased(mu, period):
            raise SampledLoopError(
                f"the feedback's controller at {rate:g} Hz is too slow for the mode at {v[i]:.3g} m/s: its sampled "
                f"|Im λ| {abs(mu.imag):.3g} rad/s is beyond {NYQUIST_SHARE:g} × π/T = "
                f"{NYQUIST_SHARE * math.pi * rate:.3g} rad/s"
            )
        if (abs(mu.imag) > MIN_IMAG) != (abs(lam[i, j].imag) > MIN_IMAG):
            kind = "oscillates" if abs(mu.imag) > MIN_IMAG else "is real"
            notes.append(f"{v[i]:.3g} m/s: sampled at {rate:g} Hz the mode {kind}, unlike the continuous loop's")
        d_re, d_im = mu.real - lam[i, j].real, abs(mu.imag) - abs(lam[i, j].imag)
        moved_re.append(abs(d_re))
        moved_im.append(abs(d_im))
        out[0, i] += d_re
        out[2, i] += d_im
    if moved_re:
        notes.insert(
            0,
            f"the assist samples the state at {rate:g} Hz and holds its torque (zero-order hold): the model's "
            f"eigenvalue is the sampled loop's, up to {max(moved_re):.2g} 1/s (Re λ) and "
            f"{max(moved_im):.2g} rad/s (Im λ) from the continuous loop's; its σ is the continuous loop's",
        )
    return notes


def _branches(lam: NDArray[np.complex128], picked: list[int]) -> list[int]:
    """A number per speed that changes where the chosen eigenvalue is not the continuation of the last.

    Consecutive speeds' eigenvalues are matched one to one by least total distance (1/s); the
    chosen one continues the last where it is the match of the one chosen before. -1: none chosen.
    """
    from scipy.optimize import linear_sum_assignment

    out = [-1] * len(picked)
    current = 0
    for i, j in enumerate(picked):
        if j < 0:
            continue
        if i > 0 and picked[i - 1] >= 0:
            a, b = lam[i - 1], lam[i]
            ok = np.isfinite(a).all() and np.isfinite(b).all()
            if ok:
                rows, cols = linear_sum_assignment(np.abs(a[:, None] - b[None, :]))
                ok = int(cols[list(rows).index(picked[i - 1])]) == j
            current += 0 if ok else 1
        elif i > 0:
            current += 1
        out[i] = current
    return out


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
        sigma_method: How the model's σ was found (``linear``, ``monte_carlo``, ``none``).
        verdict: The comparison in words (:mod:`bike_rig.core.ride.verdict`).
    """

    predicted_real: float
    predicted_real_sigma: float
    predicted_imag: float
    predicted_imag_sigma: float
    z_real: float
    z_imag: float
    deviation: float
    sigma_method: str
    verdict: Verdict


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
        unmeasured: The speeds without a clean segment (their segments grouped, ``n_used`` 0).
        verdict: The whole ride's verdict (:func:`bike_rig.core.ride.verdict.overall_verdict`).
    """

    segments: tuple[SegmentComparison, ...]
    speeds: tuple[SpeedComparison, ...]
    overall: float
    notes: tuple[str, ...]
    unmeasured: tuple[CombinedEigenvalue, ...] = ()
    verdict: Verdict = Verdict("no_clean_segment", "no verdict: no segment", math.nan)


def _against(m: MeasuredEigenvalue | CombinedEigenvalue, pred: PredictedWeave, i: int) -> tuple[Any, ...]:
    """The prediction ``i`` (Re, σ, Im, σ), the normalised deviations of ``m`` (re, im, pair), σ method, verdict."""
    p = (float(pred.real[i]), float(pred.real_sigma[i]), float(pred.imag[i]), float(pred.imag_sigma[i]))
    method = pred.sigma_method[i] if pred.sigma_method else LINEAR
    if isinstance(m, MeasuredEigenvalue) and not m.valid:
        why = "; ".join(m.flags) or "the fit found none"
        nan = math.nan
        return (*p, nan, nan, nan, method, Verdict("no_eigenvalue", f"no verdict: no measured eigenvalue ({why})", nan))
    z_re = normalised_deviation(m.real, m.real_sigma, p[0], p[1])
    z_im = normalised_deviation(m.imag, m.imag_sigma, p[2], p[3])
    note = MONTE_CARLO_NOTE if method == MONTE_CARLO else ""
    verdict = pair_verdict(complex(m.real, m.imag), complex(p[0], p[2]), z_re, z_im, note)
    if isinstance(m, MeasuredEigenvalue) and not m.clean:
        verdict = Verdict(verdict.code, f"{verdict.text}; flagged, left out of the means", verdict.sigma)
    return (*p, z_re, z_im, _pair(z_re, z_im), method, verdict)


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
    if not segments:  # nothing to predict at: the verdict says no segment was found
        return RideComparison((), (), math.nan, (), (), overall_verdict([], [], 0))
    near = [complex(s.real, s.imag) if s.valid else complex(math.nan, math.nan) for s in segments]
    pred = predicted_weave(ps, [s.speed for s in segments], feedback, convention, near)
    rows = [SegmentComparison(*_against(s, pred, i), segment=s) for i, s in enumerate(segments)]
    zs = [z for r in rows if r.segment.clean for z in (r.z_real, r.z_imag) if math.isfinite(z)]
    groups = combine_eigenvalues(segments)
    combined = [c for c in groups if c.n_used]
    per_speed = []
    if combined:
        cp = predicted_weave(
            ps, [c.speed for c in combined], feedback, convention, [complex(c.real, c.imag) for c in combined]
        )
        per_speed = [SpeedComparison(*_against(c, cp, k), combined=c) for k, c in enumerate(combined)]
    overall = math.sqrt(float(np.mean(np.square(zs)))) if zs else math.nan
    unmeasured = tuple(c for c in groups if not c.n_used)
    verdict = overall_verdict(
        [(s.combined.speed, s.verdict) for s in per_speed], [c.speed for c in unmeasured], len(segments)
    )
    notes = tuple(dict.fromkeys(pred.notes))  # one per segment's speed: each said once
    return RideComparison(tuple(rows), tuple(per_speed), overall, notes, unmeasured, verdict)


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
