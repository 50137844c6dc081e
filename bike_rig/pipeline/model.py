"""The model, the fourth stage: a parameter set → what the model node publishes.

:func:`compute_model` turns a parameter set into the canonical matrices with σ, the eigenvalue
sweep and the weave and capsize speeds with σ; :func:`state_space_at` gives A, B and the
labelled eigenvalues at one speed, :func:`state_space_with_sigma_at` the same with the σ of
every number (for the ride-speed topic). The model node and the offline runner call these same
functions. Units: SI (speeds in m/s, eigenvalues in 1/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.benchmark import ParameterSet
from ..core.errors import ModelError
from ..core.feedback import Feedback, feedback_key, resolve_feedback
from ..core.rider import add_rider, resolve_rider, rider_key
from ..core.uncertainty.eigen_sigma import eigenvalues_with_sigma
from ..core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from ..core.uncertainty.speed_sigma import SpeedWithSigma, critical_speeds_with_sigma
from ..core.uncertainty.state_space_sigma import state_space_sigma
from ..core.whipple import MODE_LABELS, EigenvalueSweep, WhippleMatrices, eigenvalues, state_space
from ..core.whipple.closed_loop import closed_loop_state_space

__all__ = [
    "ModelMatrices",
    "StabilitySweep",
    "StateSpaceAt",
    "StateSpaceWithSigma",
    "compute_model",
    "state_space_at",
    "state_space_with_sigma_at",
    "with_rider",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ModelMatrices:
    """Canonical matrices with σ of one bicycle (the fields of a ``CanonicalMatrices`` message).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        g: Gravity, m/s².
        matrices: M (kg m²), C1 (kg m), K0 (kg m), K2 (kg).
        sigma: σ of every entry, same layout.
        convention: How σ were computed.
    """

    bicycle: str
    rider: str
    g: float
    matrices: WhippleMatrices
    sigma: WhippleMatrices
    convention: SigmaConvention


@dataclass(frozen=True)
class StabilitySweep:
    """Eigenvalues over speeds and the critical speeds (the fields of an ``EigenSweep`` message).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        sweep: Speeds (m/s), eigenvalues (1/s, shape (N, 4)) and mode labels.
        weave: Weave speed with σ (m/s), None when absent.
        capsize: Capsize speed with σ (m/s), None when absent.
        feedback: "" (the open loop) or the feedback file whose closed loop ``A − B K`` the
            eigenvalues and speeds are of.
    """

    bicycle: str
    rider: str
    sweep: EigenvalueSweep
    weave: SpeedWithSigma | None
    capsize: SpeedWithSigma | None
    feedback: str = ""


def with_rider(ps: ParameterSet, rider: str, files: bool = False) -> ParameterSet:
    """``ps`` with ``rider`` ("" none, "paper", or with ``files`` a rider file) lumped into its rear frame."""
    r = resolve_rider(rider, files=files)
    return ps if r is None else add_rider(ps, r)


def compute_model(
    ps: ParameterSet,
    speeds: ArrayLike,
    rider: str = "",
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    feedback: str | Feedback | None = "",
    files: bool = False,
) -> tuple[ModelMatrices, StabilitySweep]:
    """The model products of a parameter set.

    Args:
        ps: The bicycle's parameter set (without rider).
        speeds: Speeds of the eigenvalue sweep, m/s.
        rider: "" (none) or "paper" (lumped into the rear frame, σ carried through), or with
            ``files`` a rider file (rigid or Yeadon).
        convention: σ convention of the matrices and the critical speeds.
        feedback: "" or None (none), a feedback file
            (:func:`bike_rig.core.feedback.resolve_feedback`) or a loaded feedback: the sweep
            and the speeds are then the closed loop's (the matrices stay the bicycle's own).
        files: Whether ``rider`` may name a rider file.

    Raises:
        ModelError: unknown rider, a rider file that cannot be read or seated, bad speeds or a
            singular mass matrix.
        FeedbackError: the feedback file cannot be read or is invalid.
    """
    convention = SigmaConvention(convention)
    name = rider_key(rider, files=files)
    if isinstance(feedback, Feedback):
        fb: Feedback | None = feedback
        fb_key = feedback.source or feedback.name
    else:
        fb, fb_key = resolve_feedback(feedback), feedback_key(feedback)
    full = with_rider(ps, name, files)
    ms = canonical_with_sigma(full, convention)
    if fb is None:
        sweep = eigenvalues(ms.matrices, ms.g, speeds)
    else:
        sweep = eigenvalues(ms.matrices, ms.g, speeds, gains=fb.gains(np.asarray(speeds, dtype=float).reshape(-1)))
    cs = critical_speeds_with_sigma(full, convention, ms, feedback=fb)
    return (
        ModelMatrices(ps.bicycle, name, ms.g, ms.matrices, ms.sigma, convention),
        StabilitySweep(ps.bicycle, name, sweep, cs.weave, cs.capsize, fb_key),
    )


#: Speeds above the asked one over which :func:`state_space_at` tracks the modes to label them, m/s.
LABEL_SWEEP_SPAN = 10.0
#: Speeds in that sweep.
LABEL_SWEEP_COUNT = 201


@dataclass(frozen=True)
class StateSpaceAt:
    """``ẋ = A x + B u`` at one speed (the fields of a ``StateSpace`` response).

    Attributes:
        speed: m/s.
        a: A, shape (4, 4) (1/s, 1/s²).
        b: B, shape (4, 2) (1/(kg m²)).
        eigenvalues: Shape (4,), 1/s, columns as ``labels``.
        labels: Mode of each eigenvalue.
    """

    speed: float
    a: FloatArray
    b: FloatArray
    eigenvalues: NDArray[np.complex128]
    labels: tuple[str, ...] = MODE_LABELS


def state_space_at(model: ModelMatrices, speed: float, feedback: Feedback | None = None) -> StateSpaceAt:
    """A, B and the labelled eigenvalues of ``model`` at ``speed``.

    With ``feedback``, ``a`` is the closed loop's ``A − B K`` and the eigenvalues are its own.

    Raises:
        ModelError: the speed is not a finite number ≥ 0 m/s.
    """
    v = float(speed)
    if not (math.isfinite(v) and v >= 0.0):
        raise ModelError(f"speed must be a finite number >= 0 m/s, got {speed}")
    # Labels come from the structure at the highest speed of a sweep and are carried back along
    # the tracks; one speed alone would name the low-speed capsize–caster pair "weave".
    label_speeds = np.linspace(v, v + LABEL_SWEEP_SPAN, LABEL_SWEEP_COUNT)
    if feedback is None:
        a, b = state_space(model.matrices, v, model.g)
        sweep = eigenvalues(model.matrices, model.g, label_speeds)
    else:
        a, b = closed_loop_state_space(model.matrices, v, model.g, feedback.gains(v))
        sweep = eigenvalues(model.matrices, model.g, label_speeds, gains=feedback.gains(label_speeds))
    return StateSpaceAt(v, np.asarray(a, dtype=float), np.asarray(b, dtype=float), sweep.eigenvalues[0], sweep.labels)


@dataclass(frozen=True)
class StateSpaceWithSigma:
    """:class:`StateSpaceAt` with the σ of every number (the fields of a ``StateSpaceModel`` message).

    Attributes:
        state: A, B and the labelled eigenvalues, equal to :func:`state_space_at`'s.
        a_sigma: σ of A's entries, shape (4, 4) (1/s, 1/s²).
        b_sigma: σ of B's entries, shape (4, 2) (1/(kg m²)).
        eigenvalues_sigma_real: σ of the eigenvalues' real parts, shape (4,), 1/s; NaN near a
            branch point (:mod:`bike_rig.core.uncertainty.eigen_sigma`).
        eigenvalues_sigma_imag: σ of the imaginary parts, likewise.
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        feedback: "" (open loop) or the feedback's name (A is then the closed loop's A − B K).
        convention: How σ were computed.
    """

    state: StateSpaceAt
    a_sigma: FloatArray
    b_sigma: FloatArray
    eigenvalues_sigma_real: FloatArray
    eigenvalues_sigma_imag: FloatArray
    bicycle: str
    rider: str
    feedback: str
    convention: SigmaConvention


def state_space_with_sigma_at(
    ps: ParameterSet,
    model: ModelMatrices,
    speed: float,
    feedback: Feedback | None = None,
    *,
    files: bool = False,
    full: ParameterSet | None = None,
) -> StateSpaceWithSigma:
    """A, B and the labelled eigenvalues at ``speed`` (m/s) with their σ from the parameter covariance.

    Args:
        ps: The bicycle's parameter set (without rider; ``model.rider`` is added).
        model: Its canonical matrices (from :func:`compute_model` with the rider and convention).
        speed: m/s, finite and ≥ 0.
        feedback: Steer-torque state feedback (the closed loop), None for the open loop.
        files: Whether ``model.rider`` may name a rider file.
        full: ``ps`` with the rider already added (:func:`with_rider`), when the caller keeps it
            (seating a Yeadon rider takes about a second).

    Raises:
        ModelError: the speed is not a finite number ≥ 0 m/s.
    """
    state = state_space_at(model, speed, feedback)
    full = full if full is not None else with_rider(ps, model.rider, files)
    sig = state_space_sigma(full, state.speed, model.convention, feedback)
    label_speeds = np.linspace(state.speed, state.speed + LABEL_SWEEP_SPAN, LABEL_SWEEP_COUNT)
    eig = eigenvalues_with_sigma(full, label_speeds, model.convention, feedback)
    return StateSpaceWithSigma(
        state,
        sig.a_sigma,
        sig.b_sigma,
        eig.sigma_real[0],
        eig.sigma_imag[0],
        model.bicycle,
        model.rider,
        "" if feedback is None else feedback.name,
        model.convention,
    )
