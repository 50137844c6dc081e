"""A recorded session's timeline: what happened when, on one clock, each thing once.

One time base, :data:`TIME_BASE`: seconds on the rig's clock from the first trial's START
(the computer-clock stamps of the parameter, model and readings messages cannot be set beside
the trials'). A trial event is at its own stamp; a parameter set at the STOP of the newest
trial it includes ("as of"); the model with its parameter set; static readings and entered
readings with the newest set published before them (``None`` before any). Each thing once:
a trial's first START and first STOP or ABORT; re-published sets and models collapse into one
entry for the incomplete and one for the complete, with count and first and last times.
No rclpy: messages are rosbags' dataclasses.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .session import RecordedSession

__all__ = ["TIME_BASE", "Timeline", "TimelineEntry", "session_timeline"]

#: The timeline's time base, as the report states it.
TIME_BASE = "s since the first trial's start, rig clock"
_NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class TimelineEntry:
    """Something that happened in a recorded session, once.

    Attributes:
        time_s: When, in :data:`TIME_BASE` (s); for a repeated publication its first time.
            None: before any trial's result (no rig time).
        what: What happened, e.g. ``trial frame_o1_t2 (TtB1) started``.
        count: How many times it was published (1 for a trial event).
        last_s: For a repeated publication, its last time (s, :data:`TIME_BASE`); else None.
    """

    time_s: float | None
    what: str
    count: int = 1
    last_s: float | None = None


@dataclass(frozen=True)
class Timeline:
    """A session's timeline.

    Attributes:
        origin_ns: The rig-clock stamp of the first trial's START (else of the first trial
            event), ns; None when the bag holds no trial event.
        entries: In time order (entries without a time first).
    """

    origin_ns: int | None
    entries: tuple[TimelineEntry, ...]

    def seconds(self, stamp_ns: int | None) -> float | None:
        """A rig-clock stamp (ns) in :data:`TIME_BASE` (s); None for no stamp or no origin."""
        if stamp_ns is None or stamp_ns <= 0 or self.origin_ns is None:
            return None
        return (stamp_ns - self.origin_ns) / _NS_PER_S


def _stamp(msg: Any) -> int:
    """A message's header stamp, ns since the epoch."""
    return int(msg.header.stamp.sec) * _NS_PER_S + int(msg.header.stamp.nanosec)


def _origin(session: RecordedSession) -> int | None:
    starts = [t.start.stamp_ns for t in session.trials.values() if t.start is not None and t.start.stamp_ns > 0]
    if starts:
        return min(starts)
    events = [t.stop.stamp_ns for t in session.trials.values() if t.stop is not None and t.stop.stamp_ns > 0]
    return min(events) if events else None


def _trial_entries(session: RecordedSession, seconds: Any) -> list[TimelineEntry]:
    """Each trial's START and STOP/ABORT, once (with how often its period was published if not once)."""
    out: list[TimelineEntry] = []
    any_estimates = any(t.estimates for t in session.trials.values())
    for t in session.trials.values():
        name = f"trial {t.trial_id} ({t.measurement_key})"
        if t.start is not None:
            out.append(TimelineEntry(seconds(t.start.stamp_ns), f"{name} started"))
        if t.stop is not None:
            what = f"{name} {'aborted' if t.state == 'aborted' else 'stopped'}"
            n = len(t.estimates)
            if any_estimates and n != 1:
                what += "; no period published" if n == 0 else f"; its period published {n}×"
            out.append(TimelineEntry(seconds(t.stop.stamp_ns), what))
    return out


def _newest_trial_s(msg: Any, stops: dict[str, float | None]) -> float | None:
    """The rig time (s) of the newest trial a parameter set includes, None if it includes none."""
    times = [stops.get(str(entry).partition(":")[2]) for entry in msg.trial_ids]
    known = [s for s in times if s is not None]
    return max(known) if known else None


def _collapsed(what: str, times: Sequence[float | None], detail: str = "") -> TimelineEntry:
    """One entry for ``len(times)`` publications of one thing at these times (s or None)."""
    known = [s for s in times if s is not None]
    first = None if len(known) < len(times) else min(known)
    last = max(known) if known else None
    tail = f" {detail}" if detail else ""
    if len(times) == 1:
        return TimelineEntry(first, what + tail)
    return TimelineEntry(first, f"{what} {len(times)}×{tail}", len(times), last)


def _parameter_entries(session: RecordedSession, stops: dict[str, float | None]) -> list[TimelineEntry]:
    """The parameter sets, one entry for the incomplete ones and one for the complete ones."""
    out: list[TimelineEntry] = []
    for complete in (False, True):
        sets = [m for m in session.parameters if bool(m.complete) is complete]
        if not sets:
            continue
        last = sets[-1]
        periods = f"{len(last.period_keys)} periods from {len(last.trial_ids)} trials"
        if complete:
            what, detail = "complete parameter set published", f"(the last: {periods})"
        else:
            what, detail = "incomplete parameter set published", f"(the last: {periods}, {len(last.missing)} missing)"
        out.append(_collapsed(what, [_newest_trial_s(m, stops) for m in sets], detail))
    return out


def _as_of(stamp_ns: int, sets: Sequence[tuple[int, float | None]]) -> float | None:
    """The rig time of the newest parameter set published at or before ``stamp_ns`` (computer's clock)."""
    before = [s for ns, s in sets if ns <= stamp_ns]
    return before[-1] if before else None


def _model_entries(session: RecordedSession, sets: Sequence[tuple[int, float | None]]) -> list[TimelineEntry]:
    """The model's publications (matrices and eigenvalue sweeps, one pair per parameter set), once."""
    if not session.matrices:
        return []
    by_stamp = dict(sets)
    times = [by_stamp[ns] if (ns := _stamp(m)) in by_stamp else _as_of(ns, sets) for m in session.matrices]
    return [_collapsed("model (matrices, eigenvalues, critical speeds) published", times)]


def _readings_entries(session: RecordedSession, sets: Sequence[tuple[int, float | None]]) -> list[TimelineEntry]:
    msg = session.static_readings
    if msg is None:
        return []
    return [TimelineEntry(_as_of(_stamp(msg), sets), f"static readings published ({len(msg.keys)} readings)")]


def _entry_entries(session: RecordedSession, sets: Sequence[tuple[int, float | None]]) -> list[TimelineEntry]:
    """The readings entered during the session, in order, each once; a newer entry of a key is a correction."""
    counts: dict[tuple[int, str, float, float], int] = {}
    notes: dict[tuple[int, str, float, float], str] = {}
    for msg in sorted(session.reading_entries, key=_stamp):
        ident = (_stamp(msg), str(msg.key), float(msg.value), float(msg.sigma))
        counts[ident] = counts.get(ident, 0) + 1  # the same entry recorded again counts once
        notes.setdefault(ident, str(msg.note))
    out: list[TimelineEntry] = []
    latest: dict[str, str] = {}
    for (ns, key, value, sigma), n in counts.items():
        shown = f"{value:.6g} ± {sigma:.2g}"
        was = latest.get(key)
        what = f"reading {key} = {shown} entered" if was is None else f"reading {key} corrected to {shown} (was {was})"
        what += f": {notes[ns, key, value, sigma]}" if notes[ns, key, value, sigma] else ""
        what += f" (recorded {n}×)" if n > 1 else ""
        latest[key] = shown
        at = _as_of(ns, sets)
        out.append(TimelineEntry(at, what, n, at) if n > 1 else TimelineEntry(at, what))
    return out


def session_timeline(session: RecordedSession) -> Timeline:
    """The timeline of a recorded session (see the module docstring).

    Args:
        session: The session (:func:`bike_rig.offline.session.read_session`).

    Returns:
        Its timeline; entries without a rig time ("before any trial's result") come first, and
        entries at the same time keep the order trial events, readings, entered readings,
        parameters, model.
    """
    origin = _origin(session)
    timeline = Timeline(origin, ())
    seconds = timeline.seconds
    stops = {tid: seconds(t.stop.stamp_ns) if t.stop is not None else None for tid, t in session.trials.items()}
    sets = [(_stamp(m), _newest_trial_s(m, stops)) for m in session.parameters]
    entries = [
        *_trial_entries(session, seconds),
        *_readings_entries(session, sets),
        *_entry_entries(session, sets),
        *_parameter_entries(session, stops),
        *_model_entries(session, sets),
    ]
    order = sorted(range(len(entries)), key=lambda i: (entries[i].time_s is not None, entries[i].time_s or 0.0, i))
    return Timeline(origin, tuple(entries[i] for i in order))
