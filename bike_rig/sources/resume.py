"""A source that first streams an interrupted session's recorded trials, then the live gyro's.

The driver's ``resume`` parameter (``bike-rig session --resume``) names the interrupted
session's bag. :class:`ResumedSource` yields its trials first (one a poll, in START order, with
their recorded stamps and ids; one left open closed with ABORT after its last sample), so the
fitter refits them, the new bag holds the whole session and a console sees them. They are paced
at ``time_scale`` rig seconds per wall second (``resume_time_scale``): unpaced, a session's
batches would queue behind their STOPs past the fitter's ``grace_s``. The live source is then
told the recorded ids (:meth:`~bike_rig.sources.base.GyroSource.continue_after`) and continues
after them.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..bag.errors import BagError
from ..offline.resume import started_trials
from ..offline.session import RecordedTrial, read_session
from ..pipeline.acquire import TrialEventKind, sample_stamp_ns
from .base import GyroSource, SampleBlock, SourceEvent, TrialInfo, TrialRequest, TrialStarted, TrialStopped
from .errors import SourceConfigError

__all__ = ["DEFAULT_RESUME_TIME_SCALE", "ResumedSource", "recorded_trials"]

#: How fast the recorded trials are streamed again, rig seconds per wall second: as fast as the
#: live graph follows a simulated session (the tests' sessions run at 150) with room to spare;
#: the fitter gives a stopped trial only ``grace_s`` for batches still queued behind others.
DEFAULT_RESUME_TIME_SCALE = 100.0


def _trial_events(trial: RecordedTrial) -> list[SourceEvent]:
    """One recorded trial as source events: START, its samples in index order, STOP or ABORT.

    Batches recorded twice count once; the STOP keeps the sample count the driver announced
    (so a recording that lost samples still shows the loss); a trial without STOP is closed
    with ABORT after its last recorded sample.
    """
    start = trial.start
    assert start is not None
    info = TrialInfo(
        start.trial_id,
        start.part,
        start.pendulum,
        start.orientation,
        start.repeat,
        start.measurement_key,
        start.sample_rate_hz,
        start.note,
    )
    events: list[SourceEvent] = [TrialStarted(info, start.stamp_ns)]
    seen: set[int] = set()
    end = 0
    for batch in sorted(trial.batches, key=lambda b: int(b.first_index)):
        first = int(batch.first_index)
        if first in seen:
            continue
        seen.add(first)
        volts = np.asarray(batch.raw_volts, dtype=np.float64)
        rates = np.asarray(batch.rates, dtype=np.float64)
        events.append(SampleBlock(trial.trial_id, first, rates, volts if volts.size == rates.size else None))
        end = max(end, first + rates.size)
    stop = trial.stop
    if stop is None:
        rate = start.sample_rate_hz
        stamp = sample_stamp_ns(start.stamp_ns, end, rate) if rate > 0 else start.stamp_ns
        events.append(TrialStopped(trial.trial_id, end, stamp, aborted=True))
    else:
        aborted = stop.kind is TrialEventKind.ABORT
        events.append(TrialStopped(trial.trial_id, int(stop.sample_count), stop.stamp_ns, aborted=aborted))
    return events


def recorded_trials(bag: str) -> list[list[SourceEvent]]:
    """Every trial of ``bag`` that has a START, in order of START, as source events (one list each).

    Raises:
        SourceConfigError: The bag cannot be read.
    """
    try:
        session = read_session(bag)
    except BagError as exc:
        raise SourceConfigError("resume", "resume", str(exc), bag) from None
    return [_trial_events(t) for t in started_trials(session)]


def _paced(trials: list[list[SourceEvent]], time_scale: float) -> list[tuple[float, SourceEvent]]:
    """Each recorded event with when it is due, s of wall time from the first poll.

    Back to back: a block is due once the samples before it have taken their rig time divided
    by ``time_scale`` (a trial's STOP after its last block), the pauses between trials skipped.
    """
    out: list[tuple[float, SourceEvent]] = []
    t = 0.0
    for events in trials:
        first = events[0]
        rate = first.info.sample_rate_hz if isinstance(first, TrialStarted) else math.nan
        per_sample = 1.0 / (rate * time_scale) if rate > 0 else 0.0
        for ev in events:
            out.append((t, ev))
            if isinstance(ev, SampleBlock):
                t += ev.rates.size * per_sample
    return out


class ResumedSource(GyroSource):
    """The recorded trials of ``bag``, then ``live`` (see the module docstring).

    Args:
        bag: The interrupted session's bag.
        live: The source the session continues with; it must record trials on request.
        time_scale: How fast the recorded trials are streamed: rig seconds per wall second.
        monotonic: The wall clock, s.

    Raises:
        SourceConfigError: The bag cannot be read, or ``live`` walks its own plan.
    """

    supports_requests = True

    def __init__(
        self,
        bag: str,
        live: GyroSource,
        time_scale: float = DEFAULT_RESUME_TIME_SCALE,
        monotonic: Callable[[], float] = time.monotonic,
    ):
        """Read the bag's trials now; tell ``live`` which ids and rig times are taken."""
        if not live.supports_requests:
            raise SourceConfigError(
                live.name,
                "resume",
                "a session resumes only with a source that records trials on request (sim in operator mode, can, daq)",
                bag,
            )
        self.live = live
        self.bag = bag
        self.time_scale = time_scale
        self._monotonic = monotonic
        trials = recorded_trials(bag)
        self.recorded_trials = len(trials)
        self._pending = deque(_paced(trials, time_scale))
        self._t0: float | None = None
        ids = [t[0].info.trial_id for t in trials if isinstance(t[0], TrialStarted)]
        last = max((ev.stamp_ns for t in trials for ev in t if isinstance(ev, (TrialStarted, TrialStopped))), default=0)
        live.continue_after(ids, last)

    @property
    def name(self) -> str:  # type: ignore[override]  # the backend the session continues with
        """The live source's name."""
        return self.live.name

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> ResumedSource:
        """Not built from parameters: the driver wraps its source (``resume``)."""
        raise SourceConfigError("resume", "source", "not a backend: give the driver's 'resume' parameter", "")

    def describe(self) -> str:
        """The live source, after the recorded trials."""
        return f"{self.live.describe()}, after the {self.recorded_trials} recorded trials of {self.bag} (resumed)"

    def notices(self) -> list[tuple[bool, str]]:
        """The live source's."""
        return self.live.notices()

    def silence_hint(self) -> str:
        """The live source's."""
        return self.live.silence_hint()

    @property
    def replaying(self) -> bool:
        """Recorded events are still to come."""
        return bool(self._pending)

    def poll(self) -> list[SourceEvent]:
        """The recorded events due by now (paced, see the module docstring), then the live source's."""
        if not self._pending:
            return self.live.poll()
        now = self._monotonic()
        if self._t0 is None:
            self._t0 = now
        due: list[SourceEvent] = []
        while self._pending and self._pending[0][0] <= now - self._t0:
            due.append(self._pending.popleft()[1])
        return due

    def start_trial(self, request: TrialRequest) -> TrialInfo:
        """The live source's (its START follows the recorded trials)."""
        return self.live.start_trial(request)

    def stop_trial(self, trial_id: str = "", abort: bool = False) -> TrialStopped:
        """The live source's."""
        return self.live.stop_trial(trial_id, abort)

    def close(self) -> None:
        """Close the live source."""
        self.live.close()
