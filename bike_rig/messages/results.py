"""Conversions between the core's records and bike_rig_msgs message fields, without ROS.

Every function works on *any* object with the message's attributes: rclpy messages, the
dataclasses rosbags deserialises a recording into, or plain stand-ins. ``*_from_msg`` reads
one and returns core records; ``fill_*`` writes core records into a given message object and
returns it (the header is only touched where a record carries a time stamp). Float arrays are
written in the container the object already holds (numpy array, ``array.array`` or list), so
rclpy's field checks and rosbags' serialiser both accept them.

Layouts (see ``bike_rig_msgs/msg``):

* matrices are 2 × 2, row-major ``[11, 12, 21, 22]`` (roll, steer);
* ``BenchmarkParameters.covariance`` is n × n row-major in ``names`` order;
  ``BenchmarkParameters.trial_ids`` lists the trials behind the periods as
  ``"<period key>:<trial id>"`` (every trial used, in ``period_keys`` order, sorted by trial id
  within a key), which is unambiguous whatever a trial id contains;
* ``EigenSweep.eigenvalues_real/imag`` are n_speeds × 4 row-major, columns as ``mode_labels``;
  an absent critical speed is NaN with ``has_* = false``.

The live nodes and the offline replay both use these functions, so a recording converts to
exactly the records the nodes computed with.
"""

from __future__ import annotations

import array
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .core.assembly import (
    KeyPeriod,
    ModelMatrices,
    SessionParameters,
    StabilitySweep,
    StateSpaceAt,
    TrialPeriod,
)
from .core.benchmark import ComMethod, ParameterSet
from .core.errors import BikeRigError
from .core.measurements import Measurements, Origin, Reading
from .core.symbols import PARAMETER_NAMES
from .core.uncertainty.matrix_sigma import SigmaConvention
from .core.uncertainty.speed_sigma import SpeedWithSigma
from .core.uncertainty.uncertain import UncertainVector
from .core.whipple import EigenvalueSweep, WhippleMatrices

__all__ = [
    "MessageError",
    "fill_benchmark_parameters",
    "fill_canonical_matrices",
    "fill_eigen_sweep",
    "fill_period_estimate",
    "fill_state_space_error",
    "fill_state_space_response",
    "fill_static_readings",
    "model_matrices_from_msg",
    "parameter_set_from_msg",
    "session_parameters_from_msg",
    "set_stamp",
    "stability_sweep_from_msg",
    "stamp_ns",
    "state_space_from_response",
    "static_readings_from_msg",
    "trial_period_from_msg",
]

FloatArray = NDArray[np.float64]
_MATRICES = ("M", "C1", "K0", "K2")
_MATRIX_FIELDS = ("m", "c1", "k0", "k2")


class MessageError(BikeRigError):
    """A message whose fields do not describe a valid record (wrong lengths, unknown names)."""


# --------------------------------------------------------------------------------------------
# field helpers
# --------------------------------------------------------------------------------------------


def _floats(values: Any) -> FloatArray:
    """A float message field (list, ``array.array`` or numpy array) as a 1-D float64 array."""
    return np.array(values, dtype=np.float64).reshape(-1)


def _strings(values: Iterable[Any]) -> tuple[str, ...]:
    return tuple(str(v) for v in values)


def _set_floats(msg: Any, name: str, values: ArrayLike) -> None:
    """Write floats in the container type the field already holds."""
    data = np.asarray(values, dtype=np.float64).reshape(-1)
    current = getattr(msg, name)
    if isinstance(current, np.ndarray):
        setattr(msg, name, data.copy())
    elif isinstance(current, array.array):
        setattr(msg, name, array.array("d", data.tobytes()))
    else:
        setattr(msg, name, [float(x) for x in data])


def stamp_ns(header: Any) -> int:
    """A ``std_msgs/Header`` stamp as integer nanoseconds since the epoch."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def set_stamp(msg: Any, ns: int) -> None:
    """Set ``msg.header.stamp`` from integer nanoseconds since the epoch."""
    msg.header.stamp.sec = int(ns // 1_000_000_000)
    msg.header.stamp.nanosec = int(ns % 1_000_000_000)


def _check_length(what: str, n: int, expected: int) -> None:
    if n != expected:
        raise MessageError(f"{what}: {n} entries, expected {expected}")


# --------------------------------------------------------------------------------------------
# PeriodEstimate
# --------------------------------------------------------------------------------------------


def trial_period_from_msg(msg: Any) -> TrialPeriod:
    """A ``PeriodEstimate`` as a :class:`TrialPeriod` (every field; the stamp in ns)."""
    return TrialPeriod(
        trial_id=str(msg.trial_id),
        measurement_key=str(msg.measurement_key),
        period=float(msg.period),
        period_sigma=float(msg.period_sigma),
        valid=bool(msg.valid),
        flags=_strings(msg.flags),
        flag_reasons=_strings(msg.flag_reasons),
        zeta=float(msg.zeta),
        omega=float(msg.omega),
        r2=float(msg.r2),
        residual_rms=float(msg.residual_rms),
        n_samples=int(msg.n_samples),
        n_expected=int(msg.n_expected),
        window=(int(msg.window_start), int(msg.window_stop)),
        fit_options_json=str(msg.fit_options_json),
        stamp_ns=stamp_ns(msg.header),
    )


def fill_period_estimate(msg: Any, trial: TrialPeriod) -> Any:
    """Write a :class:`TrialPeriod` into a ``PeriodEstimate`` (header stamp included)."""
    set_stamp(msg, trial.stamp_ns)
    msg.trial_id = trial.trial_id
    msg.measurement_key = trial.measurement_key
    msg.period = float(trial.period)
    msg.period_sigma = float(trial.period_sigma)
    msg.zeta = float(trial.zeta)
    msg.omega = float(trial.omega)
    msg.r2 = float(trial.r2)
    msg.residual_rms = float(trial.residual_rms)
    msg.n_samples = int(trial.n_samples)
    msg.n_expected = int(trial.n_expected)
    msg.window_start, msg.window_stop = (int(x) for x in trial.window)
    msg.valid = bool(trial.valid)
    msg.flags = list(trial.flags)
    msg.flag_reasons = list(trial.flag_reasons)
    msg.fit_options_json = trial.fit_options_json
    return msg


# --------------------------------------------------------------------------------------------
# StaticReadings
# --------------------------------------------------------------------------------------------


def static_readings_from_msg(msg: Any) -> Measurements:
    """A ``StaticReadings`` as :class:`Measurements` (readings in the message's key order).

    Each reading's origin names the message's ``source`` and the key.

    Raises:
        MessageError: keys, values and sigmas differ in length.
    """
    keys, values, sigmas = _strings(msg.keys), _floats(msg.values), _floats(msg.sigmas)
    _check_length("StaticReadings.values", values.size, len(keys))
    _check_length("StaticReadings.sigmas", sigmas.size, len(keys))
    source = str(msg.source) or "<static readings message>"
    readings = {k: Reading(float(v), float(s), Origin(source, k)) for k, v, s in zip(keys, values, sigmas)}
    return Measurements(str(msg.bicycle), readings, source)


def fill_static_readings(msg: Any, static: Measurements, document: str = "") -> Any:
    """Write static readings into a ``StaticReadings`` (``source`` is ``static.path``).

    Args:
        msg: The message to fill.
        static: The readings, in their order.
        document: The whole source file's text.
    """
    msg.bicycle = static.bicycle
    msg.keys = list(static.readings)
    _set_floats(msg, "values", [r.value for r in static.readings.values()])
    _set_floats(msg, "sigmas", [r.sigma for r in static.readings.values()])
    msg.source = static.path
    msg.document = document
    return msg


# --------------------------------------------------------------------------------------------
# BenchmarkParameters
# --------------------------------------------------------------------------------------------


def fill_benchmark_parameters(msg: Any, session: SessionParameters) -> Any:
    """Write a session's state into a ``BenchmarkParameters``.

    Complete: names, values, sigmas and the covariance of the 26 parameters. Incomplete: those
    are empty and ``missing`` lists the keys still to measure. The provenance (periods
    combined so far and their trials) is written in both cases.
    """
    msg.bicycle = session.bicycle
    ps = session.parameters
    if ps is not None:
        pv = ps.parameters
        msg.names = list(pv.names)
        _set_floats(msg, "values", pv.values)
        _set_floats(msg, "sigmas", pv.sigmas)
        _set_floats(msg, "covariance", pv.covariance)
    else:
        msg.names = []
        for name in ("values", "sigmas", "covariance"):
            _set_floats(msg, name, [])
    msg.complete = session.complete
    msg.missing = list(session.missing)
    msg.period_keys = [p.key for p in session.periods]
    _set_floats(msg, "period_values", [p.value for p in session.periods])
    _set_floats(msg, "period_sigmas", [p.sigma for p in session.periods])
    msg.trial_ids = [f"{p.key}:{t}" for p in session.periods for t in p.trial_ids]
    msg.com_method = session.com_method.value
    return msg


def parameter_set_from_msg(msg: Any, source: str = "<BenchmarkParameters message>") -> ParameterSet:
    """The parameter set of a complete ``BenchmarkParameters``, in PARAMETER_NAMES order.

    Args:
        msg: The message.
        source: Recorded as the set's source.

    Raises:
        MessageError: the set is incomplete, or its names, values or covariance do not
            describe the 26 benchmark parameters.
    """
    if not msg.complete:
        raise MessageError("the parameter set is incomplete (missing: " + ", ".join(_strings(msg.missing)) + ")")
    names = _strings(msg.names)
    values = _floats(msg.values)
    n = len(names)
    _check_length("BenchmarkParameters.values", values.size, n)
    cov_flat = _floats(msg.covariance)
    _check_length("BenchmarkParameters.covariance", cov_flat.size, n * n)
    if sorted(names) != sorted(PARAMETER_NAMES):
        unknown = sorted(set(names) ^ set(PARAMETER_NAMES))
        raise MessageError(f"BenchmarkParameters.names: not the 26 benchmark parameters (differ in {unknown})")
    cov = cov_flat.reshape(n, n)
    order = [names.index(k) for k in PARAMETER_NAMES]
    if order != list(range(n)):
        values = values[order]
        cov = cov[np.ix_(order, order)]
    return ParameterSet(str(msg.bicycle), UncertainVector(PARAMETER_NAMES, values, cov), source)


def _key_periods(msg: Any) -> tuple[KeyPeriod, ...]:
    keys = _strings(msg.period_keys)
    values, sigmas = _floats(msg.period_values), _floats(msg.period_sigmas)
    _check_length("BenchmarkParameters.period_values", values.size, len(keys))
    _check_length("BenchmarkParameters.period_sigmas", sigmas.size, len(keys))
    trials: dict[str, list[str]] = {k: [] for k in keys}
    for entry in _strings(msg.trial_ids):
        key, sep, trial = entry.partition(":")
        if not sep or key not in trials:
            raise MessageError(f"BenchmarkParameters.trial_ids: '{entry}' is not '<period key>:<trial id>'")
        trials[key].append(trial)
    return tuple(KeyPeriod(k, float(v), float(s), tuple(trials[k])) for k, v, s in zip(keys, values, sigmas))


def session_parameters_from_msg(msg: Any, source: str = "<BenchmarkParameters message>") -> SessionParameters:
    """A ``BenchmarkParameters`` as :class:`SessionParameters` (the parameter set when complete).

    Raises:
        MessageError: inconsistent fields.
    """
    try:
        method = ComMethod(str(msg.com_method))
    except ValueError:
        raise MessageError(f"BenchmarkParameters.com_method: unknown method '{msg.com_method}'") from None
    parameters = parameter_set_from_msg(msg, source) if msg.complete else None
    return SessionParameters(str(msg.bicycle), method, _key_periods(msg), _strings(msg.missing), parameters)


# --------------------------------------------------------------------------------------------
# CanonicalMatrices
# --------------------------------------------------------------------------------------------


def fill_canonical_matrices(msg: Any, model: ModelMatrices) -> Any:
    """Write canonical matrices with σ into a ``CanonicalMatrices``."""
    msg.bicycle = model.bicycle
    msg.rider = model.rider
    msg.g = float(model.g)
    for attr, field in zip(_MATRICES, _MATRIX_FIELDS):
        _set_floats(msg, field, np.asarray(getattr(model.matrices, attr), dtype=float))
        _set_floats(msg, f"{field}_sigma", np.asarray(getattr(model.sigma, attr), dtype=float))
    msg.sigma_convention = model.convention.value
    return msg


def _matrices(msg: Any, suffix: str) -> WhippleMatrices:
    mats = []
    for field in _MATRIX_FIELDS:
        data = _floats(getattr(msg, field + suffix))
        _check_length(f"CanonicalMatrices.{field}{suffix}", data.size, 4)
        mats.append(data.reshape(2, 2))
    return WhippleMatrices(M=mats[0], C1=mats[1], K0=mats[2], K2=mats[3])


def model_matrices_from_msg(msg: Any) -> ModelMatrices:
    """A ``CanonicalMatrices`` as :class:`ModelMatrices`.

    Raises:
        MessageError: an unknown σ convention or a matrix without 4 entries.
    """
    try:
        convention = SigmaConvention(str(msg.sigma_convention))
    except ValueError:
        raise MessageError(f"CanonicalMatrices.sigma_convention: unknown '{msg.sigma_convention}'") from None
    return ModelMatrices(
        str(msg.bicycle), str(msg.rider), float(msg.g), _matrices(msg, ""), _matrices(msg, "_sigma"), convention
    )


# --------------------------------------------------------------------------------------------
# EigenSweep
# --------------------------------------------------------------------------------------------


def _set_speed(msg: Any, name: str, speed: SpeedWithSigma | None) -> None:
    setattr(msg, f"has_{name}", speed is not None)
    setattr(msg, f"{name}_speed", math.nan if speed is None else float(speed.speed))
    setattr(msg, f"{name}_speed_sigma", math.nan if speed is None else float(speed.sigma))


def _get_speed(msg: Any, name: str) -> SpeedWithSigma | None:
    if not getattr(msg, f"has_{name}"):
        return None
    return SpeedWithSigma(float(getattr(msg, f"{name}_speed")), float(getattr(msg, f"{name}_speed_sigma")))


def fill_eigen_sweep(msg: Any, stability: StabilitySweep) -> Any:
    """Write an eigenvalue sweep and the critical speeds into an ``EigenSweep``."""
    msg.bicycle = stability.bicycle
    msg.rider = stability.rider
    sweep = stability.sweep
    _set_floats(msg, "speeds", sweep.speeds)
    _set_floats(msg, "eigenvalues_real", np.ascontiguousarray(sweep.eigenvalues.real))
    _set_floats(msg, "eigenvalues_imag", np.ascontiguousarray(sweep.eigenvalues.imag))
    msg.mode_labels = list(sweep.labels)
    _set_speed(msg, "weave", stability.weave)
    _set_speed(msg, "capsize", stability.capsize)
    return msg


def stability_sweep_from_msg(msg: Any) -> StabilitySweep:
    """An ``EigenSweep`` as :class:`StabilitySweep`.

    Raises:
        MessageError: eigenvalue arrays that are not n_speeds × n_labels.
    """
    speeds = _floats(msg.speeds)
    labels = _strings(msg.mode_labels)
    re, im = _floats(msg.eigenvalues_real), _floats(msg.eigenvalues_imag)
    _check_length("EigenSweep.eigenvalues_real", re.size, speeds.size * len(labels))
    _check_length("EigenSweep.eigenvalues_imag", im.size, speeds.size * len(labels))
    values = (re + 1j * im).reshape(speeds.size, len(labels))
    sweep = EigenvalueSweep(speeds=speeds, eigenvalues=values, labels=labels)
    return StabilitySweep(str(msg.bicycle), str(msg.rider), sweep, _get_speed(msg, "weave"), _get_speed(msg, "capsize"))


# --------------------------------------------------------------------------------------------
# StateSpace service response
# --------------------------------------------------------------------------------------------


def fill_state_space_response(response: Any, state: StateSpaceAt, message: str = "") -> Any:
    """Write A, B and the eigenvalues into a ``StateSpace`` response with ``ok = true``."""
    response.ok = True
    response.message = message
    _set_floats(response, "a", state.a)
    _set_floats(response, "b", state.b)
    _set_floats(response, "eigenvalues_real", state.eigenvalues.real)
    _set_floats(response, "eigenvalues_imag", state.eigenvalues.imag)
    response.mode_labels = list(state.labels)
    return response


def fill_state_space_error(response: Any, message: str) -> Any:
    """A ``StateSpace`` response with ``ok = false``, the reason, and NaN numbers."""
    response.ok = False
    response.message = message
    for name, n in (("a", 16), ("b", 8), ("eigenvalues_real", 4), ("eigenvalues_imag", 4)):
        _set_floats(response, name, np.full(n, math.nan))
    response.mode_labels = [""] * 4
    return response


def state_space_from_response(response: Any, speed: float) -> StateSpaceAt:
    """A successful ``StateSpace`` response (for the request's ``speed``, m/s) as :class:`StateSpaceAt`.

    Raises:
        MessageError: the response says ``ok = false`` (its message is the reason).
    """
    if not response.ok:
        raise MessageError(f"state space at {speed} m/s not available: {response.message}")
    a, b = _floats(response.a), _floats(response.b)
    _check_length("StateSpace.a", a.size, 16)
    _check_length("StateSpace.b", b.size, 8)
    eig = _floats(response.eigenvalues_real) + 1j * _floats(response.eigenvalues_imag)
    return StateSpaceAt(float(speed), a.reshape(4, 4), b.reshape(4, 2), eig, _strings(response.mode_labels))

