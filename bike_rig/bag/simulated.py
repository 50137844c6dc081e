"""A simulated session written as the rig would have recorded it, without ROS: for tests,
benchmarks and demonstrations of the bag tools.

:func:`live_results` adds what the live graph publishes from such a stream, computed with the
nodes' own ROS-free functions: the fitter's ``PeriodEstimate`` per trial (on its STOP), the
parameter node's ``BenchmarkParameters`` after each estimate (incomplete until every period
is there), and the model node's ``CanonicalMatrices`` and ``EigenSweep`` for the complete set.

The messages follow the driver's conventions (``bike_rig.nodes.driver``): a latched
``StaticReadings`` first (what the parameter node publishes from the measurement file), then
per trial a START event stamped with the first sample's rig time, ``GyroBatch`` messages of
``samples_per_batch`` samples (the last may be shorter) stamped with their first sample's rig
time (``start + round(index * 1e9 / rate)``) with rates and raw volts, and a STOP event with
the sample count. Trials follow each other with ``pause_s`` between them; each message is
logged ``latency_ns`` after its stamp (STOP after the trial's last sample).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import topics
from ..core.assembly import SessionAssembly, compute_model
from ..core.benchmark import ComMethod
from ..core.measurements import Measurements
from ..core.sim import SimulatedSession
from ..core.sim.plan import PlannedMeasurement
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..messages import (
    fill_benchmark_parameters,
    fill_canonical_matrices,
    fill_eigen_sweep,
    fill_static_readings,
    parameter_set_from_msg,
    set_stamp,
    static_readings_from_msg,
    trial_period_from_msg,
)
from ..nodes.fitter import TrialFit, TrialFitOptions, fill_period_estimate, fit_trial
from .typestore import new_message, rig_typestore
from .writer import BagWriter, Compression, contract_qos

__all__ = ["SimulatedMessage", "live_results", "period_estimate", "simulated_messages", "write_simulated_bag"]

NS = 1_000_000_000
STATIC_TYPE = topics.STATIC_READINGS.type
EVENT_TYPE = topics.TRIAL_EVENTS.type
BATCH_TYPE = topics.GYRO.type


@dataclass(frozen=True)
class SimulatedMessage:
    """One message of a simulated recording: topic, log time (ns) and the message."""

    topic: str
    log_time: int
    message: Any


def _static(session: SimulatedSession) -> Measurements:
    return Measurements(session.bicycle, dict(session.readings), session.label)


def _stamp_of(start_ns: int, index: int, rate: float) -> int:
    return start_ns + round(index * 1e9 / rate)


def simulated_messages(
    session: SimulatedSession,
    start_ns: int = 1_800_000_000 * NS,
    samples_per_batch: int = 50,
    pause_s: float = 10.0,
    latency_ns: int = 300_000,
    frame_id: str = "gyro",
) -> Iterator[SimulatedMessage]:
    """The session's messages in log-time order: static readings, then every trial's START,
    batches and STOP (see the module docstring)."""
    static = fill_static_readings(new_message(STATIC_TYPE), _static(session))
    set_stamp(static, start_ns)
    yield SimulatedMessage(topics.STATIC_READINGS.name, start_ns + latency_ns, static)
    planned: dict[str, PlannedMeasurement] = {m.key: m for m in session.plan}
    t0 = start_ns + int(pause_s * NS)
    for trial in session.trials:
        m = planned[trial.key]
        rate = float(trial.sample_rate)
        n = int(trial.rate.size)
        fields = {
            "trial_id": trial.name, "part": m.part, "pendulum": m.pendulum, "orientation": m.orientation or 0,
            "repeat": trial.trial, "measurement_key": trial.key, "sample_rate_hz": rate,
        }  # fmt: skip
        start = new_message(EVENT_TYPE, kind=0, **fields)
        set_stamp(start, t0)
        start.header.frame_id = frame_id
        yield SimulatedMessage(topics.TRIAL_EVENTS.name, t0 + latency_ns // 2, start)
        for first in range(0, n, samples_per_batch):
            stop_at = min(n, first + samples_per_batch)
            batch = new_message(
                BATCH_TYPE,
                trial_id=trial.name,
                first_index=first,
                sample_rate_hz=rate,
                rates=np.ascontiguousarray(trial.rate[first:stop_at], dtype=np.float64),
                raw_volts=np.ascontiguousarray(trial.volts[first:stop_at], dtype=np.float64),
            )
            stamp = _stamp_of(t0, first, rate)
            set_stamp(batch, stamp)
            batch.header.frame_id = frame_id
            # a batch is published once its last sample is taken
            yield SimulatedMessage(topics.GYRO.name, _stamp_of(t0, stop_at - 1, rate) + latency_ns, batch)
        end = _stamp_of(t0, n, rate)  # just after the last sample, as the driver stamps STOP
        stop = new_message(EVENT_TYPE, kind=1, sample_count=n, **fields)
        set_stamp(stop, end)
        stop.header.frame_id = frame_id
        yield SimulatedMessage(topics.TRIAL_EVENTS.name, end + latency_ns + 1000, stop)
        t0 = end + int(pause_s * NS)


def write_simulated_bag(
    path: str | Path,
    session: SimulatedSession,
    extra: Iterable[SimulatedMessage] = (),
    compression: Compression | str = Compression.ZSTD,
    **options: Any,
) -> Path:
    """Write a simulated session as a bag (every rig topic, with its contract QoS).

    Args:
        path: The bag directory to create.
        session: The session.
        extra: More messages (e.g. live results computed from it), merged in by log time.
        compression: Chunk compression.
        options: Passed to :func:`simulated_messages`.

    Returns:
        The bag's path.
    """
    store = rig_typestore()
    messages = sorted([*simulated_messages(session, **options), *extra], key=lambda m: m.log_time)
    with BagWriter(path, compression=compression, flush_period_s=3600.0) as w:
        for t in topics.TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        types = {t.name: t.type for t in topics.TOPICS}
        for m in messages:
            data = store.serialize_cdr(m.message, types[m.topic])
            w.write(m.topic, m.log_time, bytes(data))
    return Path(path)


def period_estimate(r: TrialFit) -> Any:
    """The ``PeriodEstimate`` the fitter node publishes for a result."""
    return fill_period_estimate(new_message(topics.PERIODS.type), r)


def live_results(
    stream: Iterable[SimulatedMessage],
    fit_options: TrialFitOptions | None = None,
    com_method: ComMethod = ComMethod.CENTROID,
    rider: str = "",
    convention: SigmaConvention = SigmaConvention.CORRELATED,
    speeds: Any = None,
    delay_ns: int = 5_000_000,
) -> list[SimulatedMessage]:
    """What the fitter, parameter and model nodes publish for a recorded input stream.

    Args:
        stream: The static readings, trial events and gyro batches (e.g.
            :func:`simulated_messages`), in log-time order.
        fit_options: The fitter's options (its defaults if None).
        com_method: The parameter node's mass-centre method.
        rider: The model node's rider.
        convention: The model node's σ convention.
        speeds: The model node's sweep speeds, m/s (0 to 10 m/s, 201 speeds if None).
        delay_ns: How long after its input each result is logged.
    """
    options = fit_options or TrialFitOptions()
    sweep_speeds = np.linspace(0.0, 10.0, 201) if speeds is None else np.asarray(speeds, dtype=float)
    batches: dict[str, list[Any]] = {}
    starts: dict[str, Any] = {}
    assembly: SessionAssembly | None = None
    out: list[SimulatedMessage] = []
    for m in stream:
        msg = m.message
        if m.topic == topics.STATIC_READINGS.name:
            assembly = SessionAssembly(static_readings_from_msg(msg), com_method, origin=topics.PERIODS.name)
        elif m.topic == topics.GYRO.name:
            batches.setdefault(str(msg.trial_id), []).append(msg)
        elif m.topic == topics.TRIAL_EVENTS.name and int(msg.kind) == 0:
            starts[str(msg.trial_id)] = msg
        elif m.topic == topics.TRIAL_EVENTS.name:
            tid = str(msg.trial_id)
            estimate = period_estimate(fit_trial(batches.pop(tid, []), starts.pop(tid, None), msg, options))
            t = m.log_time + delay_ns
            out.append(SimulatedMessage(topics.PERIODS.name, t, estimate))
            if assembly is None:
                continue
            assembly.add(trial_period_from_msg(estimate))
            result = assembly.result()
            params = fill_benchmark_parameters(new_message(topics.PARAMETERS.type), result)
            set_stamp(params, t + delay_ns)
            out.append(SimulatedMessage(topics.PARAMETERS.name, t + delay_ns, params))
            if result.complete:
                matrices, stability = compute_model(parameter_set_from_msg(params), sweep_speeds, rider, convention)
                for topic, filled in (
                    (topics.MATRICES, fill_canonical_matrices(new_message(topics.MATRICES.type), matrices)),
                    (topics.EIGEN_SWEEP, fill_eigen_sweep(new_message(topics.EIGEN_SWEEP.type), stability)),
                ):
                    set_stamp(filled, t + delay_ns)
                    out.append(SimulatedMessage(topic.name, t + 2 * delay_ns, filled))
    return out
