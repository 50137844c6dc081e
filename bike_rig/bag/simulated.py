"""A simulated session written as the rig would have recorded it, without ROS (tests, benchmarks, demos).

The messages follow the driver's conventions: a latched ``StaticReadings`` first, then per trial
a START stamped with its first sample's rig time, ``GyroBatch`` messages of
``samples_per_batch`` samples stamped ``start + round(index * 1e9 / rate)``, and a STOP with the
sample count; ``pause_s`` between trials, each message logged ``latency_ns`` after its stamp.
:func:`live_results` adds what the live graph publishes, computed with the nodes' own ROS-free
functions: a ``PeriodEstimate`` and its ``FitDetails`` per STOP, ``BenchmarkParameters`` after
each, and the model's ``CanonicalMatrices`` and ``EigenSweep`` for the complete set.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config import topics
from ..core.benchmark import ComMethod
from ..core.measurements import Measurements
from ..core.sim import SimulatedSession
from ..core.sim.plan import PlannedMeasurement
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..messages import (
    fill_benchmark_parameters,
    fill_canonical_matrices,
    fill_eigen_sweep,
    fill_fit_details,
    fill_gyro_batch,
    fill_period_estimate,
    fill_static_readings,
    fill_trial_event,
    sample_batch_from_msg,
    set_stamp,
    static_readings_from_msg,
    trial_event_from_msg,
)
from ..pipeline.acquire import NS_PER_S, SampleBatch, TrialEventKind, TrialEventRecord, sample_stamp_ns
from ..pipeline.fit import TrialFit, TrialFitOptions, fit_trial
from ..pipeline.fit_details import FitDetails
from ..pipeline.offline import DEFAULT_SPEEDS, GraphSettings, OfflineGraph, TrialInput
from .typestore import new_message, rig_typestore
from .writer import BagWriter, Compression, contract_qos

__all__ = [
    "RECORDED_TOPICS",
    "SimulatedMessage",
    "fit_details",
    "live_results",
    "period_estimate",
    "simulated_messages",
    "write_simulated_bag",
]

STATIC_TYPE = topics.STATIC_READINGS.type
EVENT_TYPE = topics.TRIAL_EVENTS.type
BATCH_TYPE = topics.GYRO.type
#: The topics a simulated bag holds: the rig's, and the fitter's details.
RECORDED_TOPICS = (*topics.TOPICS, topics.FIT_DETAILS)


@dataclass(frozen=True)
class SimulatedMessage:
    """One message of a simulated recording: topic, log time (ns) and the message."""

    topic: str
    log_time: int
    message: Any


def _static(session: SimulatedSession) -> Measurements:
    return Measurements(session.bicycle, dict(session.readings), session.label)


def _event_message(event: TrialEventRecord) -> Any:
    return fill_trial_event(new_message(EVENT_TYPE), event)


def simulated_messages(
    session: SimulatedSession,
    start_ns: int = 1_800_000_000 * NS_PER_S,
    samples_per_batch: int = 50,
    pause_s: float = 10.0,
    latency_ns: int = 300_000,
    frame_id: str = "gyro",
) -> Iterator[SimulatedMessage]:
    """The session's messages in log-time order (see the module docstring).

    First the static readings, then every trial's START, batches and STOP.
    """
    static = fill_static_readings(new_message(STATIC_TYPE), _static(session))
    set_stamp(static, start_ns)
    yield SimulatedMessage(topics.STATIC_READINGS.name, start_ns + latency_ns, static)
    planned: dict[str, PlannedMeasurement] = {m.key: m for m in session.plan}
    t0 = start_ns + int(pause_s * NS_PER_S)
    for trial in session.trials:
        m = planned[trial.key]
        rate = float(trial.sample_rate)
        n = int(trial.rate.size)
        start = TrialEventRecord(
            TrialEventKind.START,
            trial.name,
            trial.key,
            m.part,
            m.pendulum,
            m.orientation or 0,
            trial.trial,
            rate,
            stamp_ns=t0,
            frame_id=frame_id,
        )
        yield SimulatedMessage(topics.TRIAL_EVENTS.name, t0 + latency_ns // 2, _event_message(start))
        for first in range(0, n, samples_per_batch):
            stop_at = min(n, first + samples_per_batch)
            batch = SampleBatch(
                trial.name,
                first,
                rate,
                rates=np.ascontiguousarray(trial.rate[first:stop_at], dtype=np.float64),
                raw_volts=np.ascontiguousarray(trial.volts[first:stop_at], dtype=np.float64),
                stamp_ns=sample_stamp_ns(t0, first, rate),
                frame_id=frame_id,
            )
            # a batch is published once its last sample is taken
            log_time = sample_stamp_ns(t0, stop_at - 1, rate) + latency_ns
            yield SimulatedMessage(topics.GYRO.name, log_time, fill_gyro_batch(new_message(BATCH_TYPE), batch))
        end = sample_stamp_ns(t0, n, rate)  # just after the last sample, as the driver stamps STOP
        stop = replace(start, kind=TrialEventKind.STOP, sample_count=n, stamp_ns=end)
        yield SimulatedMessage(topics.TRIAL_EVENTS.name, end + latency_ns + 1000, _event_message(stop))
        t0 = end + int(pause_s * NS_PER_S)


def write_simulated_bag(
    path: str | Path,
    session: SimulatedSession,
    extra: Iterable[SimulatedMessage] = (),
    compression: Compression | str = Compression.ZSTD,
    chunk_size: int = 1 << 20,
    **options: Any,
) -> Path:
    """Write a simulated session as a bag (every rig topic, with its contract QoS).

    Args:
        path: The bag directory to create.
        session: The session.
        extra: More messages (e.g. live results computed from it), merged in by log time.
        compression: Chunk compression.
        chunk_size: Largest chunk, bytes (uncompressed).
        options: Passed to :func:`simulated_messages`.

    Returns:
        The bag's path.
    """
    store = rig_typestore()
    messages = sorted([*simulated_messages(session, **options), *extra], key=lambda m: m.log_time)
    with BagWriter(path, compression=compression, flush_period_s=3600.0, chunk_size=chunk_size) as w:
        for t in RECORDED_TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        types = {t.name: t.type for t in RECORDED_TOPICS}
        for m in messages:
            data = store.serialize_cdr(m.message, types[m.topic])
            w.write(m.topic, m.log_time, bytes(data))
    return Path(path)


def period_estimate(r: TrialFit) -> Any:
    """The ``PeriodEstimate`` the fitter node publishes for a result."""
    return fill_period_estimate(new_message(topics.PERIODS.type), r)


def fit_details(r: TrialFit) -> Any:
    """The ``FitDetails`` the fitter node publishes with a result's estimate."""
    return fill_fit_details(new_message(topics.FIT_DETAILS.type), FitDetails.of(r))


def _published(topic: topics.Topic, record: Any, fill: Any, stamp_ns: int, log_time: int) -> SimulatedMessage:
    msg = fill(new_message(topic.type), record)
    set_stamp(msg, stamp_ns)
    return SimulatedMessage(topic.name, log_time, msg)


def live_results(
    stream: Iterable[SimulatedMessage],
    fit_options: TrialFitOptions | None = None,
    com_method: ComMethod = ComMethod.CENTROID,
    rider: str = "",
    convention: SigmaConvention = SigmaConvention.CORRELATED,
    speeds: Any = None,
    delay_ns: int = 5_000_000,
) -> list[SimulatedMessage]:
    """What the fitter (estimates and their details), parameter and model nodes publish for an input stream.

    The stream's messages become records and go trial by trial through the offline runner
    (:meth:`bike_rig.pipeline.offline.OfflineGraph.step`).

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
    settings = GraphSettings(
        fit_options=fit_options or TrialFitOptions(),
        com_method=com_method,
        rider=rider,
        convention=convention,
        speeds=DEFAULT_SPEEDS.copy() if speeds is None else np.asarray(speeds, dtype=float),
    )
    batches: dict[str, list[SampleBatch]] = {}
    starts: dict[str, TrialEventRecord] = {}
    graph: OfflineGraph | None = None
    out: list[SimulatedMessage] = []
    for m in stream:
        if m.topic == topics.STATIC_READINGS.name:
            graph = OfflineGraph(static_readings_from_msg(m.message), settings, origin=topics.PERIODS.name)
        elif m.topic == topics.GYRO.name:
            batch = sample_batch_from_msg(m.message)
            batches.setdefault(batch.trial_id, []).append(batch)
        elif m.topic == topics.TRIAL_EVENTS.name:
            event = trial_event_from_msg(m.message)
            if event.kind is TrialEventKind.START:
                starts[event.trial_id] = event
                continue
            tid = event.trial_id
            trial = TrialInput(tid, starts.pop(tid, None), event, batches.pop(tid, []))
            t = m.log_time + delay_ns
            if graph is None:
                fitted = fit_trial(trial.batches, trial.start, trial.stop, settings.fit_options)
                out.append(SimulatedMessage(topics.PERIODS.name, t, period_estimate(fitted)))
                out.append(SimulatedMessage(topics.FIT_DETAILS.name, t, fit_details(fitted)))
                continue
            step = graph.step(trial)
            out.append(SimulatedMessage(topics.PERIODS.name, t, period_estimate(step.trial)))
            out.append(SimulatedMessage(topics.FIT_DETAILS.name, t, fit_details(step.trial)))
            stamp = t + delay_ns
            out.append(_published(topics.PARAMETERS, step.session, fill_benchmark_parameters, stamp, stamp))
            if step.matrices is not None and step.stability is not None:
                out.append(_published(topics.MATRICES, step.matrices, fill_canonical_matrices, stamp, stamp + delay_ns))
                out.append(_published(topics.EIGEN_SWEEP, step.stability, fill_eigen_sweep, stamp, stamp + delay_ns))
    return out
