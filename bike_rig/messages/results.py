"""Converters of the result messages.

``StaticReadings``, ``BenchmarkParameters``, ``CanonicalMatrices``, ``EigenSweep`` and the
``StateSpace`` service response.

Layouts (see ``bike_rig_msgs/msg``):

* matrices are 2 × 2, row-major ``[11, 12, 21, 22]`` (roll, steer);
* ``BenchmarkParameters.covariance`` is n × n row-major in ``names`` order;
  ``BenchmarkParameters.trial_ids`` lists the trials behind the periods as
  ``"<period key>:<trial id>"`` (every trial used, in ``period_keys`` order, sorted by trial id
  within a key), which is unambiguous whatever a trial id contains;
* ``EigenSweep.eigenvalues_real/imag`` are n_speeds × 4 row-major, columns as ``mode_labels``;
  an absent critical speed is NaN with ``has_* = false``.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.benchmark import ParameterSet
from ..core.measurements import Measurements, Origin, Reading
from ..core.symbols import PARAMETER_NAMES
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..core.uncertainty.speed_sigma import SpeedWithSigma
from ..core.uncertainty.uncertain import UncertainVector
from ..core.whipple import EigenvalueSweep, WhippleMatrices
from ..pipeline.assemble import KeyPeriod, SessionParameters
from ..pipeline.model import ModelMatrices, StabilitySweep, StateSpaceAt
from .fields import Message, MessageError, check_length, fill_fields, floats, record_fields, set_floats, strings

__all__ = [
    "fill_benchmark_parameters",
    "fill_canonical_matrices",
    "fill_eigen_sweep",
    "fill_state_space_error",
    "fill_state_space_response",
    "fill_static_readings",
    "model_matrices_from_msg",
    "session_parameters_from_msg",
    "stability_sweep_from_msg",
    "state_space_from_response",
    "static_readings_from_msg",
]

_MATRICES = ("M", "C1", "K0", "K2")
_MATRIX_FIELDS = ("m", "c1", "k0", "k2")


# --------------------------------------------------------------------------------------------
# StaticReadings
# --------------------------------------------------------------------------------------------


def static_readings_from_msg(msg: Message) -> Measurements:
    """A ``StaticReadings`` as :class:`Measurements` (readings in the message's key order).

    Each reading's origin names the message's ``source`` and the key.

    Raises:
        MessageError: keys, values and sigmas differ in length.
    """
    keys, values, sigmas = strings(msg.keys), floats(msg.values), floats(msg.sigmas)
    check_length("StaticReadings.values", values.size, len(keys))
    check_length("StaticReadings.sigmas", sigmas.size, len(keys))
    source = str(msg.source) or "<static readings message>"
    readings = {k: Reading(float(v), float(s), Origin(source, k)) for k, v, s in zip(keys, values, sigmas)}
    return Measurements(str(msg.bicycle), readings, source)


def fill_static_readings(msg: Message, static: Measurements, document: str = "") -> Message:
    """Write static readings into a ``StaticReadings`` (``source`` is ``static.path``).

    Args:
        msg: The message to fill.
        static: The readings, in their order.
        document: The whole source file's text.
    """
    msg.bicycle = static.bicycle
    msg.keys = list(static.readings)
    set_floats(msg, "values", [r.value for r in static.readings.values()])
    set_floats(msg, "sigmas", [r.sigma for r in static.readings.values()])
    msg.source = static.path
    msg.document = document
    return msg


# --------------------------------------------------------------------------------------------
# BenchmarkParameters
# --------------------------------------------------------------------------------------------


def fill_benchmark_parameters(msg: Message, session: SessionParameters) -> Message:
    """Write a session's state into a ``BenchmarkParameters``.

    Complete: names, values, sigmas and the covariance of the 26 parameters. Incomplete: those
    are empty and ``missing`` lists the keys still to measure. The provenance (periods
    combined so far and their trials) is written in both cases.
    """
    fill_fields(msg, session)
    ps = session.parameters
    if ps is not None:
        pv = ps.parameters
        msg.names = list(pv.names)
        set_floats(msg, "values", pv.values)
        set_floats(msg, "sigmas", pv.sigmas)
        set_floats(msg, "covariance", pv.covariance)
    else:
        msg.names = []
        for name in ("values", "sigmas", "covariance"):
            set_floats(msg, name, [])
    msg.complete = session.complete
    msg.period_keys = [p.key for p in session.periods]
    set_floats(msg, "period_values", [p.value for p in session.periods])
    set_floats(msg, "period_sigmas", [p.sigma for p in session.periods])
    msg.trial_ids = [f"{p.key}:{t}" for p in session.periods for t in p.trial_ids]
    return msg


def _parameter_set(msg: Message, source: str) -> ParameterSet:
    """The parameter set of a complete ``BenchmarkParameters``, in PARAMETER_NAMES order.

    Args:
        msg: The message.
        source: Recorded as the set's source.

    Raises:
        MessageError: its names, values or covariance do not
            describe the 26 benchmark parameters.
    """
    names = strings(msg.names)
    values = floats(msg.values)
    n = len(names)
    check_length("BenchmarkParameters.values", values.size, n)
    cov_flat = floats(msg.covariance)
    check_length("BenchmarkParameters.covariance", cov_flat.size, n * n)
    if sorted(names) != sorted(PARAMETER_NAMES):
        unknown = sorted(set(names) ^ set(PARAMETER_NAMES))
        raise MessageError(f"BenchmarkParameters.names: not the 26 benchmark parameters (differ in {unknown})")
    cov = cov_flat.reshape(n, n)
    order = [names.index(k) for k in PARAMETER_NAMES]
    if order != list(range(n)):
        values = values[order]
        cov = cov[np.ix_(order, order)]
    return ParameterSet(str(msg.bicycle), UncertainVector(PARAMETER_NAMES, values, cov), source)


def _key_periods(msg: Message) -> tuple[KeyPeriod, ...]:
    keys = strings(msg.period_keys)
    values, sigmas = floats(msg.period_values), floats(msg.period_sigmas)
    check_length("BenchmarkParameters.period_values", values.size, len(keys))
    check_length("BenchmarkParameters.period_sigmas", sigmas.size, len(keys))
    trials: dict[str, list[str]] = {k: [] for k in keys}
    for entry in strings(msg.trial_ids):
        key, sep, trial = entry.partition(":")
        if not sep or key not in trials:
            raise MessageError(f"BenchmarkParameters.trial_ids: '{entry}' is not '<period key>:<trial id>'")
        trials[key].append(trial)
    return tuple(KeyPeriod(k, float(v), float(s), tuple(trials[k])) for k, v, s in zip(keys, values, sigmas))


def session_parameters_from_msg(msg: Message, source: str = "<BenchmarkParameters message>") -> SessionParameters:
    """A ``BenchmarkParameters`` as :class:`SessionParameters` (the parameter set when complete).

    Raises:
        MessageError: inconsistent fields.
    """
    parameters = _parameter_set(msg, source) if msg.complete else None
    return SessionParameters(**record_fields(SessionParameters, msg), periods=_key_periods(msg), parameters=parameters)


# --------------------------------------------------------------------------------------------
# CanonicalMatrices
# --------------------------------------------------------------------------------------------


def fill_canonical_matrices(msg: Message, model: ModelMatrices) -> Message:
    """Write canonical matrices with σ into a ``CanonicalMatrices``."""
    fill_fields(msg, model)
    for attr, field in zip(_MATRICES, _MATRIX_FIELDS):
        set_floats(msg, field, np.asarray(getattr(model.matrices, attr), dtype=float))
        set_floats(msg, f"{field}_sigma", np.asarray(getattr(model.sigma, attr), dtype=float))
    msg.sigma_convention = model.convention.value
    return msg


def _matrices(msg: Message, suffix: str) -> WhippleMatrices:
    mats = []
    for field in _MATRIX_FIELDS:
        data = floats(getattr(msg, field + suffix))
        check_length(f"CanonicalMatrices.{field}{suffix}", data.size, 4)
        mats.append(data.reshape(2, 2))
    return WhippleMatrices(M=mats[0], C1=mats[1], K0=mats[2], K2=mats[3])


def model_matrices_from_msg(msg: Message) -> ModelMatrices:
    """A ``CanonicalMatrices`` as :class:`ModelMatrices`.

    Raises:
        MessageError: an unknown σ convention or a matrix without 4 entries.
    """
    try:
        convention = SigmaConvention(str(msg.sigma_convention))
    except ValueError:
        raise MessageError(f"CanonicalMatrices.sigma_convention: unknown '{msg.sigma_convention}'") from None
    return ModelMatrices(
        **record_fields(ModelMatrices, msg),
        matrices=_matrices(msg, ""),
        sigma=_matrices(msg, "_sigma"),
        convention=convention,
    )


# --------------------------------------------------------------------------------------------
# EigenSweep
# --------------------------------------------------------------------------------------------


def _set_speed(msg: Message, name: str, speed: SpeedWithSigma | None) -> None:
    setattr(msg, f"has_{name}", speed is not None)
    setattr(msg, f"{name}_speed", math.nan if speed is None else float(speed.speed))
    setattr(msg, f"{name}_speed_sigma", math.nan if speed is None else float(speed.sigma))


def _get_speed(msg: Message, name: str) -> SpeedWithSigma | None:
    if not getattr(msg, f"has_{name}"):
        return None
    return SpeedWithSigma(float(getattr(msg, f"{name}_speed")), float(getattr(msg, f"{name}_speed_sigma")))


def fill_eigen_sweep(msg: Message, stability: StabilitySweep) -> Message:
    """Write an eigenvalue sweep and the critical speeds into an ``EigenSweep``."""
    fill_fields(msg, stability)
    sweep = stability.sweep
    set_floats(msg, "speeds", sweep.speeds)
    set_floats(msg, "eigenvalues_real", np.ascontiguousarray(sweep.eigenvalues.real))
    set_floats(msg, "eigenvalues_imag", np.ascontiguousarray(sweep.eigenvalues.imag))
    msg.mode_labels = list(sweep.labels)
    _set_speed(msg, "weave", stability.weave)
    _set_speed(msg, "capsize", stability.capsize)
    return msg


def stability_sweep_from_msg(msg: Message) -> StabilitySweep:
    """An ``EigenSweep`` as :class:`StabilitySweep`.

    Raises:
        MessageError: eigenvalue arrays that are not n_speeds × n_labels.
    """
    speeds = floats(msg.speeds)
    labels = strings(msg.mode_labels)
    re, im = floats(msg.eigenvalues_real), floats(msg.eigenvalues_imag)
    check_length("EigenSweep.eigenvalues_real", re.size, speeds.size * len(labels))
    check_length("EigenSweep.eigenvalues_imag", im.size, speeds.size * len(labels))
    values = (re + 1j * im).reshape(speeds.size, len(labels))
    sweep = EigenvalueSweep(speeds=speeds, eigenvalues=values, labels=labels)
    return StabilitySweep(
        **record_fields(StabilitySweep, msg),
        sweep=sweep,
        weave=_get_speed(msg, "weave"),
        capsize=_get_speed(msg, "capsize"),
    )


# --------------------------------------------------------------------------------------------
# StateSpace service response
# --------------------------------------------------------------------------------------------


def fill_state_space_response(response: Message, state: StateSpaceAt, message: str = "") -> Message:
    """Write A, B and the eigenvalues into a ``StateSpace`` response with ``ok = true``."""
    response.ok = True
    response.message = message
    set_floats(response, "a", state.a)
    set_floats(response, "b", state.b)
    set_floats(response, "eigenvalues_real", state.eigenvalues.real)
    set_floats(response, "eigenvalues_imag", state.eigenvalues.imag)
    response.mode_labels = list(state.labels)
    return response


def fill_state_space_error(response: Message, message: str) -> Message:
    """A ``StateSpace`` response with ``ok = false``, the reason, and NaN numbers."""
    response.ok = False
    response.message = message
    for name, n in (("a", 16), ("b", 8), ("eigenvalues_real", 4), ("eigenvalues_imag", 4)):
        set_floats(response, name, np.full(n, math.nan))
    response.mode_labels = [""] * 4
    return response


def state_space_from_response(response: Message, speed: float) -> StateSpaceAt:
    """A successful ``StateSpace`` response (for the request's ``speed``, m/s) as :class:`StateSpaceAt`.

    Raises:
        MessageError: the response says ``ok = false`` (its message is the reason).
    """
    if not response.ok:
        raise MessageError(f"state space at {speed} m/s not available: {response.message}")
    a, b = floats(response.a), floats(response.b)
    check_length("StateSpace.a", a.size, 16)
    check_length("StateSpace.b", b.size, 8)
    eig = floats(response.eigenvalues_real) + 1j * floats(response.eigenvalues_imag)
    return StateSpaceAt(float(speed), a.reshape(4, 4), b.reshape(4, 2), eig, strings(response.mode_labels))
