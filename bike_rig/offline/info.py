"""A summary of a recorded session (``bike-rig bag info``).

The bicycle, every trial with its measurement key, samples and validity, every topic with its
type and message count, the duration, and the live results the graph published.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..bag.reader import TopicInfo
from .session import RecordedSession, RecordedTrial, read_session

__all__ = ["BagSummary", "LiveResults", "TopicSummary", "TrialSummary", "summarize", "summarize_session"]


@dataclass(frozen=True)
class TrialSummary:
    """One trial of a session.

    Attributes:
        trial_id: Its id.
        measurement_key: The period it measures, e.g. ``TtB2`` ("" if unknown).
        part: Part hung (rear_wheel, frame...; "" if unknown).
        pendulum: ``compound`` or ``torsional`` ("" if unknown).
        orientation: Hanging orientation (0 when not applicable).
        repeat: Trial number of its measurement.
        state: ``complete``, ``aborted``, ``open``, ``no start`` or ``unannounced``.
        start_ns: Rig time of its START event (0 if none), ns since the epoch.
        sample_rate_hz: Hz.
        samples: Samples recorded.
        announced: Samples the driver announced on STOP (None without STOP).
        batches: Gyro batches recorded (duplicates included).
        duplicates: Batches recorded twice.
        estimated: A period estimate was published for it.
        valid: Its last estimate's validity (None without estimate).
        usable: Valid and unflagged: it enters the combination (None without estimate).
        period: Its last estimate's period, s (NaN without).
        period_sigma: Its σ, s (NaN without).
        flags: Its flag codes.
    """

    trial_id: str
    measurement_key: str
    part: str
    pendulum: str
    orientation: int
    repeat: int
    state: str
    start_ns: int
    sample_rate_hz: float
    samples: int
    announced: int | None
    batches: int
    duplicates: int
    estimated: bool
    valid: bool | None
    usable: bool | None
    period: float
    period_sigma: float
    flags: tuple[str, ...]

    @property
    def duration_s(self) -> float:
        """Samples recorded / sample rate, s (NaN if the rate is unknown)."""
        rate = self.sample_rate_hz
        return self.samples / rate if rate > 0 else math.nan


@dataclass(frozen=True)
class TopicSummary:
    """One topic: name, type and message count."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class LiveResults:
    """What the live graph published last.

    Attributes:
        parameter_sets: BenchmarkParameters messages recorded.
        complete: The last set is complete.
        missing: Keys the last set still missed.
        com_method: Its mass-centre method ("" without a set).
        weave_speed: The last sweep's weave speed, m/s (None when absent or not recorded).
        capsize_speed: Its capsize speed, m/s (None likewise).
        rider: The rider of the last sweep ("" for none).
    """

    parameter_sets: int
    complete: bool
    missing: tuple[str, ...]
    com_method: str
    weave_speed: float | None
    capsize_speed: float | None
    rider: str


@dataclass(frozen=True)
class BagSummary:
    """A session's summary.

    Attributes:
        path: The bag, as given.
        bicycle: The bicycle's name ("" if the bag does not say).
        start_ns: Log time of the first message, ns since the epoch.
        end_ns: Log time of the last message, ns since the epoch.
        message_count: Messages in the bag.
        files: Storage files with their sizes, bytes.
        topics: Every topic.
        trials: Every trial, in the order first heard of.
        static_readings: Number of static readings recorded (None without the message).
        stray_batches: Gyro batches outside any trial.
        live: What the graph published.
    """

    path: str
    bicycle: str
    start_ns: int
    end_ns: int
    message_count: int
    files: tuple[tuple[str, int], ...]
    topics: tuple[TopicSummary, ...]
    trials: tuple[TrialSummary, ...]
    static_readings: int | None
    stray_batches: int
    live: LiveResults

    @property
    def duration_s(self) -> float:
        """From the first to the last message, s."""
        return (self.end_ns - self.start_ns) / 1e9

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON (NaN becomes None)."""
        data = asdict(self)
        data["duration_s"] = self.duration_s
        for t, trial in zip(data["trials"], self.trials):
            t["duration_s"] = trial.duration_s
        return _no_nan(data)


def _no_nan(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _no_nan(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_no_nan(v) for v in value]
    return value


def _trial(t: RecordedTrial) -> TrialSummary:
    ev, est = t.event, t.estimate
    valid = None if est is None else bool(est.valid)
    flags = () if est is None else tuple(str(f) for f in est.flags)
    usable = None
    if est is not None:
        p, s = float(est.period), float(est.period_sigma)
        usable = bool(valid and not flags and math.isfinite(p) and p > 0 and math.isfinite(s) and s > 0)
    start_ns = 0 if t.start is None else t.start.stamp_ns
    return TrialSummary(
        trial_id=t.trial_id,
        measurement_key=t.measurement_key,
        part="" if ev is None else str(ev.part),
        pendulum="" if ev is None else str(ev.pendulum),
        orientation=0 if ev is None else int(ev.orientation),
        repeat=0 if ev is None else int(ev.repeat),
        state=t.state,
        start_ns=start_ns,
        sample_rate_hz=t.sample_rate_hz,
        samples=t.samples,
        announced=t.announced,
        batches=len(t.batches),
        duplicates=t.duplicates,
        estimated=est is not None,
        valid=valid,
        usable=usable,
        period=math.nan if est is None else float(est.period),
        period_sigma=math.nan if est is None else float(est.period_sigma),
        flags=flags,
    )


def _live(session: RecordedSession) -> LiveResults:
    ps, sweep = session.final_parameters, session.final_eigen_sweep
    weave = capsize = None
    if sweep is not None:
        weave = float(sweep.weave_speed) if sweep.has_weave else None
        capsize = float(sweep.capsize_speed) if sweep.has_capsize else None
    return LiveResults(
        parameter_sets=len(session.parameters),
        complete=bool(ps is not None and ps.complete),
        missing=() if ps is None else tuple(str(k) for k in ps.missing),
        com_method="" if ps is None else str(ps.com_method),
        weave_speed=weave,
        capsize_speed=capsize,
        rider="" if sweep is None else str(sweep.rider),
    )


def _topics(infos: dict[str, TopicInfo]) -> tuple[TopicSummary, ...]:
    return tuple(TopicSummary(t.name, t.msgtype, t.count) for t in sorted(infos.values(), key=lambda t: t.name))


def summarize_session(session: RecordedSession) -> BagSummary:
    """The summary of a session already read."""
    files = []
    for f in session.storage_files:
        try:
            files.append((f.name, f.stat().st_size))
        except OSError:
            files.append((f.name, -1))
    static = session.static_readings
    return BagSummary(
        path=session.path,
        bicycle=session.bicycle,
        start_ns=session.start_time,
        end_ns=session.end_time,
        message_count=session.message_count,
        files=tuple(files),
        topics=_topics(session.topics),
        trials=tuple(_trial(t) for t in session.trials.values()),
        static_readings=None if static is None else len(static.keys),
        stray_batches=session.stray_batches,
        live=_live(session),
    )


def summarize(path: str | Path) -> BagSummary:
    """Read a bag and summarise its session.

    Raises:
        BagError: not a bag, unreadable, or without the rig's topics.
    """
    return summarize_session(read_session(path))
