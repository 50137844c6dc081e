"""Each node's health as REP-107 statuses (``/diagnostics``), from plain records, without ROS.

One function per node turns a snapshot of its counters (one dataclass each) into its statuses,
one per concern (:mod:`bike_rig.pipeline.diagnostics`); the node fills the snapshot once a second and
:mod:`bike_rig.ros.nodes.diagnostics` publishes the result. The concerns, levels and details are in
``docs/ros-graph.md`` (*Diagnostics*). Times in s, rates in 1/s (Hz), sizes in bytes unless a
key says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .diagnostics import INPUT_LAG, Level, Status, age_level, level_above, level_below

__all__ = [
    "LAG_WARN_S",
    "DriverHealth",
    "FitterHealth",
    "InputLag",
    "ModelHealth",
    "ParameterHealth",
    "RecorderHealth",
    "driver_statuses",
    "fitter_statuses",
    "input_lag_statuses",
    "model_statuses",
    "parameter_statuses",
    "recorder_statuses",
]

#: A recording trial's measured sample rate below this fraction of the expected one is WARN.
RATE_WARN_FRACTION = 0.9
#: A silence this many times the driver's ``silence_warning_s`` is ERROR (WARN from 1 time).
SILENCE_ERROR_FACTOR = 3.0
#: Buffered samples above this fraction of the fitter's budget are WARN.
BUFFER_WARN_FRACTION = 0.8
#: A node this far or farther behind its input (over the lag meter's last 1.5 s) is WARN, s.
LAG_WARN_S = 2.0


@dataclass(frozen=True)
class DriverHealth:
    """The driver's counters at one moment.

    Attributes:
        source: The gyro source's description.
        source_errors: Errors reading the source since the start.
        recording: Ids of the trials recording now.
        expected_rate_hz: Samples per wall second expected while recording (the trial's rate
            times the source's time scale), Hz; NaN when no trial records.
        measured_rate_hz: Samples per wall second over the last seconds, Hz.
        since_sample_s: While a trial records, wall seconds the most silent one has had no
            samples (since its request, START or last samples); else since the last sample
            (inf before the first), s.
        silence_limit_s: The driver's ``silence_warning_s``, s.
        samples_published: Samples published since the start.
        samples_missing: Samples the source skipped (gaps in the indices) or reported but never
            delivered, since the start.
        clipped: Samples at or beyond the gyro's range since the start (0 when no range is set).
        range_rad_s: The gyro's range, rad/s (0: not configured).
        behind_s: How late the recording trials' samples are: wall time since their START less
            the samples received over the expected rate (the most behind trial; 0 when none
            records), s.
    """

    source: str
    source_errors: int
    recording: tuple[str, ...]
    expected_rate_hz: float
    measured_rate_hz: float
    since_sample_s: float
    silence_limit_s: float
    samples_published: int
    samples_missing: int
    clipped: int
    range_rad_s: float
    behind_s: float = 0.0


def driver_statuses(h: DriverHealth, node: str = "driver") -> list[Status]:
    """``source``, ``samples`` (rate, silence, late, missing) and ``gyro range`` (clipping)."""
    src_level = Level.ERROR if h.source_errors else Level.OK
    src_msg = f"{h.source_errors} read error(s)" if h.source_errors else "reading"
    out = [Status.of(node, "source", src_level, src_msg, source=h.source, errors=h.source_errors)]
    details = {
        "recording": ", ".join(h.recording) or "none",
        "sample rate (Hz)": h.measured_rate_hz,
        "expected rate (Hz)": h.expected_rate_hz,
        "since last sample (s)": h.since_sample_s,
        "samples published": h.samples_published,
        "samples missing": h.samples_missing,
        "behind (s)": h.behind_s,
    }
    if not h.recording:
        level, message = Level.OK, "idle: no trial recording"
    else:
        level = age_level(h.since_sample_s, h.silence_limit_s, SILENCE_ERROR_FACTOR * h.silence_limit_s)
        if level is not Level.OK:
            message = f"no samples for {h.since_sample_s:.1f} s"
        elif h.behind_s >= h.silence_limit_s:
            level, message = Level.WARN, f"samples late: {h.behind_s:.1f} s behind the rate"
        elif h.expected_rate_hz > 0 and h.measured_rate_hz < RATE_WARN_FRACTION * h.expected_rate_hz:
            level = Level.WARN
            message = f"sample rate {h.measured_rate_hz:.0f} Hz, expected {h.expected_rate_hz:.0f} Hz"
        else:
            message = f"recording at {h.measured_rate_hz:.0f} Hz"
    if h.samples_missing and level is Level.OK:
        level, message = Level.WARN, f"{h.samples_missing} sample(s) missing"
    out.append(Status.of(node, "samples", level, message, **details))
    if h.range_rad_s <= 0:
        out.append(Status.of(node, "gyro range", Level.OK, "range not configured", clipped=h.clipped))
    else:
        clip_level = Level.WARN if h.clipped else Level.OK
        clip_msg = f"{h.clipped} sample(s) clipped" if h.clipped else "no clipping"
        out.append(
            Status.of(
                node, "gyro range", clip_level, clip_msg, **{"range (rad/s)": h.range_rad_s, "clipped": h.clipped}
            )
        )
    return out


@dataclass(frozen=True)
class FitterHealth:
    """The fitter's counters at one moment.

    Attributes:
        open_trials: Trials being buffered.
        stopped_pending: Of those, trials whose STOP arrived and that wait for missing batches.
        buffered_samples: Samples held in memory.
        sample_budget: Most samples it holds (``max_trial_samples · max_open_trials``).
        rss_bytes: The process's resident memory, bytes (0 when unknown).
        published: Estimates published since the start.
        last_fit_ms: Time the last fit took, ms (NaN before the first).
        foreign_batches: Batches dropped because another process had opened their trial id.
    """

    open_trials: int
    stopped_pending: int
    buffered_samples: int
    sample_budget: int
    rss_bytes: int
    published: int
    last_fit_ms: float
    foreign_batches: int


def fitter_statuses(h: FitterHealth, node: str = "fitter") -> list[Status]:
    """``buffer`` (samples and memory against the budget) and ``fits`` (pending, latency, foreign batches)."""
    fraction = h.buffered_samples / h.sample_budget if h.sample_budget > 0 else 0.0
    buf_level = level_above(fraction, BUFFER_WARN_FRACTION, 1.0)
    buffer = Status.of(
        node,
        "buffer",
        buf_level,
        f"{h.buffered_samples} samples in {h.open_trials} open trial(s)",
        **{
            "open trials": h.open_trials,
            "buffered samples": h.buffered_samples,
            "sample budget": h.sample_budget,
            "memory (MB)": h.rss_bytes / 1e6,
        },
    )
    fit_level = Level.WARN if h.foreign_batches else Level.OK
    message = f"{h.published} estimate(s) published, {h.stopped_pending} fit(s) pending"
    if h.foreign_batches:
        message += f"; {h.foreign_batches} batch(es) of another process dropped"
    fits = Status.of(
        node,
        "fits",
        fit_level,
        message,
        **{
            "fits pending": h.stopped_pending,
            "published": h.published,
            "last fit (ms)": h.last_fit_ms,
            "foreign batches": h.foreign_batches,
        },
    )
    return [buffer, fits]


@dataclass(frozen=True)
class ParameterHealth:
    """The parameter node's state at one moment.

    Attributes:
        bicycle: The bicycle.
        evaluated: Whether a set was computed yet.
        complete: Whether the last set is complete.
        periods: Periods in it.
        periods_required: Periods a complete set needs.
        missing_periods: Period keys still to measure.
        missing_readings: Static readings still to enter.
        error: Why the last computation failed ("" if it did not).
    """

    bicycle: str
    evaluated: bool
    complete: bool
    periods: int
    periods_required: int
    missing_periods: tuple[str, ...]
    missing_readings: tuple[str, ...]
    error: str = ""


def parameter_statuses(h: ParameterHealth, node: str = "parameter") -> list[Status]:
    """``completeness``: OK when complete, WARN while periods or readings are missing, ERROR when it failed."""
    details = {
        "bicycle": h.bicycle,
        "periods": h.periods,
        "periods required": h.periods_required,
        "missing periods": ", ".join(h.missing_periods) or "none",
        "missing readings": ", ".join(h.missing_readings) or "none",
    }
    if h.error:
        level, message = Level.ERROR, f"cannot compute the parameters: {h.error}"
    elif not h.evaluated:
        level, message = Level.WARN, "no parameter set computed yet"
    elif h.complete:
        level, message = Level.OK, f"complete: {h.periods} periods"
    else:
        level = Level.WARN
        message = f"incomplete: {h.periods} of {h.periods_required} periods"
        if h.missing_readings:
            message += f", {len(h.missing_readings)} reading(s) to enter"
    return [Status.of(node, "completeness", level, message, **details)]


@dataclass(frozen=True)
class ModelHealth:
    """The model node's state at one moment.

    Attributes:
        bicycle: The bicycle of the current set ("" before the first).
        models: Models published since the start.
        last_model_ms: Time the last model took, ms (NaN before the first).
        ride_speed: The latest riding speed received, m/s (NaN if none).
        since_speed_s: Seconds since that speed (inf if none), s.
        ride_published: State spaces published on the ride topic.
        ride_compute_ms: Time the last of those took, ms (NaN before the first).
    """

    bicycle: str
    models: int
    last_model_ms: float
    ride_speed: float
    since_speed_s: float
    ride_published: int
    ride_compute_ms: float


def model_statuses(h: ModelHealth, node: str = "model") -> list[Status]:
    """``model`` (WARN while no parameter set arrived) and ``ride`` (the riding speed and its state spaces)."""
    if h.bicycle:
        model = Status.of(
            node,
            "model",
            Level.OK,
            f"{h.bicycle}: {h.models} model(s) published",
            bicycle=h.bicycle,
            models=h.models,
            **{"last model (ms)": h.last_model_ms},
        )
    else:
        model = Status.of(node, "model", Level.WARN, "waiting for a complete parameter set", models=0)
    details = {
        "speed (m/s)": h.ride_speed,
        "since speed (s)": h.since_speed_s,
        "published": h.ride_published,
        "last state space (ms)": h.ride_compute_ms,
    }
    message = "no riding speed received" if math.isnan(h.ride_speed) else f"{h.ride_speed:.2f} m/s"
    return [model, Status.of(node, "ride", Level.OK, message, **details)]


@dataclass(frozen=True)
class RecorderHealth:
    """The recorder's counters at one moment.

    Attributes:
        path: The bag.
        bytes_written: Size of the bag's files on disk, bytes.
        messages: Messages written.
        dropped: Messages received but not recorded (after a write error, or failed).
        write_latency_ms: Longest time one write took over the last period, ms.
        free_bytes: Free space of the bag's file system, bytes.
        min_free_bytes: Below this free space the status is WARN, bytes.
        failed: Why recording stopped ("" while it records).
        paused: Recording is paused (the ``pause`` service).
        dropped_paused: Messages not recorded while paused (knowingly), since the start.
    """

    path: str
    bytes_written: int
    messages: int
    dropped: int
    write_latency_ms: float
    free_bytes: int
    min_free_bytes: int
    failed: str = ""
    paused: bool = False
    dropped_paused: int = 0


def recorder_statuses(h: RecorderHealth, node: str = "recorder") -> list[Status]:
    """``bag`` (written, dropped, latency; WARN while paused, ERROR when it stopped) and ``disk`` (free space)."""
    details = {
        "path": h.path,
        "bytes written": h.bytes_written,
        "messages": h.messages,
        "dropped": h.dropped,
        "write latency (ms)": h.write_latency_ms,
        "paused": h.paused,
        "dropped while paused": h.dropped_paused,
    }
    if h.failed:
        bag = Status.of(node, "bag", Level.ERROR, f"recording stopped: {h.failed}", **details)
    elif h.dropped:
        bag = Status.of(node, "bag", Level.ERROR, f"{h.dropped} message(s) not recorded", **details)
    elif h.paused:
        bag = Status.of(
            node, "bag", Level.WARN, f"paused: {h.dropped_paused} message(s) not recorded so far", **details
        )
    else:
        bag = Status.of(node, "bag", Level.OK, f"{h.messages} messages, {h.bytes_written / 1e6:.1f} MB", **details)
    level = level_below(h.free_bytes, h.min_free_bytes, 0)
    disk = Status.of(
        node,
        "disk",
        level,
        f"{h.free_bytes / 1e9:.2f} GB free" + (" (low)" if level is not Level.OK else ""),
        **{"free (MB)": h.free_bytes / 1e6, "warn below (MB)": h.min_free_bytes / 1e6},
    )
    return [bag, disk]


@dataclass(frozen=True)
class InputLag:
    """How far behind its input a node is (:class:`bike_rig.pipeline.diagnostics.LagMeter`).

    Attributes:
        lag_s: The largest lag (now − source time) of the messages handled over the last 1.5 s, s.
        largest_s: The largest lag since the start, s.
        messages: Messages handled since the start.
    """

    lag_s: float
    largest_s: float
    messages: int


def input_lag_statuses(h: InputLag, node: str) -> list[Status]:
    """``input lag``: OK below :data:`LAG_WARN_S`, WARN from it (``20 s behind its input``)."""
    details = {"lag (s)": h.lag_s, "largest lag (s)": h.largest_s, "messages": h.messages, "warn from (s)": LAG_WARN_S}
    level = level_above(h.lag_s, LAG_WARN_S)
    if level is Level.OK:
        return [Status.of(node, INPUT_LAG, level, f"keeping up: {h.lag_s:.2g} s behind its input", **details)]
    return [Status.of(node, INPUT_LAG, level, f"{h.lag_s:.0f} s behind its input", **details)]
