"""The fitting stage's live bookkeeping: trial events and sample batches in, results out.

:class:`FitterState` buffers a trial's batches and events (which travel on two topics, in no
common order) with bounded memory, per publishing process (the first 12 bytes of the
publisher's GUID): another process's batches of a trial id never enter, evict or duplicate it.
A STOP with samples missing waits while they can still arrive, asks the driver for lost ranges
again (:mod:`bike_rig.pipeline.resend`) and flags ``gap`` only for samples the driver never
had; late batches refit the trial. After a restart the transient-local history is refitted.
The full rules: ``docs/ros-graph.md`` ("Restarts", "Busy machines", "Who may publish").
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from .acquire import SampleBatch, TrialEventKind, TrialEventRecord
from .fit import TrialAccumulator, TrialFit, TrialFitOptions

__all__ = ["FitterState", "Log", "ResendRequest"]

#: Trial ids remembered as finished (late batches of them are ignored, not "unknown").
_DONE_MEMORY = 100_000
#: How long an unanswered resend request waits before it is sent again, s.
RESEND_RETRY_S = 2.0
#: How long a trial waits for the driver to answer its resend requests before it is fitted as
#: it is (the driver stalled or gone), s.
RESEND_GIVE_UP_S = 60.0


@dataclass(frozen=True)
class ResendRequest:
    """Samples of a trial to ask its source for again: ``[first_index, first_index + count)``."""

    source: str
    trial_id: str
    first_index: int
    count: int


class Log(Protocol):
    """The logger the fitter reports to (rclpy's node logger, or :mod:`logging`'s)."""

    def info(self, message: str) -> Any:
        """Report ``message`` at info level."""
        ...

    def warning(self, message: str) -> Any:
        """Report ``message`` at warning level."""
        ...


#: A trial: (its source, its id).
_Key = tuple[str, str]


@dataclass
class _Open:
    """A trial being buffered."""

    trial_id: str
    source: str
    acc: TrialAccumulator
    seen_s: float
    start: TrialEventRecord | None = None
    stop: TrialEventRecord | None = None
    stop_seen_s: float = 0.0
    warned: set[str] = field(default_factory=set)
    #: Order of its START and STOP among the events received (None: not received).
    start_order: int | None = None
    stop_order: int | None = None
    #: When its missing samples were first and last asked for again (None: never).
    first_asked_s: float | None = None
    asked_s: float | None = None


class FitterState:
    """The fitter's bookkeeping, without ROS: events and batches in, results out.

    Args:
        options: Fit options and limits.
        log: Where problems are reported.
        grace_s: How long a STOP waits for missing batches, and batches wait for their START
            (counted from when both topics' publishers were matched, if later, and while the
            source's batches keep arriving from its last one, up to ``history_grace_s`` after
            the STOP), s.
        max_open_trials: Trials buffered at once without a STOP per source (and that many
            trials' worth of samples per source); beyond it the source's trial heard of least
            recently is fitted as it is (flag ``no_stop`` or ``unknown_trial``).
        clock: Monotonic seconds.
        history_grace_s: After the publishers were matched, how long nothing incomplete is given
            up on and no trial is evicted for being open: a (re)started fitter receives the
            transient-local history of both topics, and Fast DDS delivers it to a late reader
            only at the writers' next heartbeat (up to ~3 s), batches and events in no common
            order. Only the sample budget bounds memory meanwhile.
    """

    def __init__(
        self,
        options: TrialFitOptions,
        log: Log,
        grace_s: float = 1.0,
        max_open_trials: int = 4,
        clock: Callable[[], float] = time.monotonic,
        history_grace_s: float = 10.0,
    ):
        """Set up an empty state: no trial open, none fitted, nothing published yet."""
        self.options = options
        self.log = log
        self.grace_s = grace_s
        self.history_grace_s = history_grace_s
        self.max_open_trials = max_open_trials
        self.clock = clock
        self.open: dict[_Key, _Open] = {}
        #: Trials fitted: (source, id) -> rig time of their STOP (None without one), ns.
        self.done: OrderedDict[_Key, int | None] = OrderedDict()
        #: Rig time of the oldest gyro batch received [ns]: the start of the history we have.
        self.horizon_ns: int | None = None
        #: When the publishers of both topics were (last) matched, monotonic s.
        self.matched_at = 0.0
        self.published = 0
        self.suppressed = 0
        self.outside = 0
        #: When each source's last batch was received, monotonic s.
        self.last_batch_s: dict[str, float] = {}
        #: The source whose START opened each trial id first.
        self.opener: OrderedDict[str, str] = OrderedDict()
        #: Batches dropped because another source had opened their trial id.
        self.foreign_batches = 0
        self._foreign_warned: set[_Key] = set()
        #: Whether a resend service answers (set by the node): lost batches are asked for again.
        self.can_resend = False
        self._resend: list[ResendRequest] = []
        self._events = 0
        #: The last few trials published with samples missing (their batches may still come).
        self._gapped: OrderedDict[_Key, _Open] = OrderedDict()
        #: Per source, the latest START order of a trial whose batches have arrived: the
        #: source's batch stream has passed every trial stopped before it.
        self._passed: dict[str, int] = {}

    # ------------------------------------------------------------------ input
    def on_event(self, event: TrialEventRecord, source: str = "") -> list[TrialFit]:
        """A trial event from ``source`` (a trial is the pair source, trial id); returns the results it completes."""
        now = self.clock()
        kind, tid, key = event.kind, event.trial_id, (source, event.trial_id)
        out: list[TrialFit | None] = []
        self._events += 1
        order = self._events
        if kind is TrialEventKind.START:
            return self._on_start(event, source, now, order)
        # STOP or ABORT
        t = self.open.get(key)
        if t is None:
            if key in self.done:
                self.log.warning(f"trial {tid}: STOP of a trial already fitted ignored")
                return []
            self.log.warning(f"trial {tid}: STOP without START")
            t = self.open[key] = _Open(tid, source, TrialAccumulator(self.options), now)
        elif t.stop is not None:
            self.log.warning(f"trial {tid}: second STOP ignored")
            return []
        elif t.start is None:
            self.log.warning(f"trial {tid}: STOP without START")
        t.stop, t.stop_seen_s, t.seen_s, t.stop_order = event, now, now, order
        if t.acc.covers(int(event.sample_count)):
            out.append(self._finish(t))
        return self._evict(out, source)

    def _on_start(self, event: TrialEventRecord, source: str, now: float, order: int) -> list[TrialFit]:
        tid, key = event.trial_id, (source, event.trial_id)
        t = self.open.get(key)
        if t is not None and t.start is not None:
            self.log.warning(f"trial {tid}: second START ignored")
            return []
        if t is None:
            if key in self.done:
                self.log.warning(f"trial {tid} started again: it is fitted again")
                del self.done[key]
            t = self.open[key] = _Open(tid, source, TrialAccumulator(self.options), now)
        t.start, t.seen_s, t.start_order = event, now, order
        if t.acc.batches:
            self._passed[source] = max(self._passed.get(source, 0), order)
        if tid not in self.opener:
            self.opener[tid] = source
            while len(self.opener) > _DONE_MEMORY:
                self.opener.popitem(last=False)
        return self._evict([], source)

    def on_batch(self, batch: SampleBatch, stamp_ns: int | None = None, source: str = "") -> list[TrialFit]:
        """A gyro batch from ``source`` (``stamp_ns``: its header stamp); returns the results it completes."""
        now = self.clock()
        if stamp_ns is not None and (self.horizon_ns is None or stamp_ns < self.horizon_ns):
            self.horizon_ns = stamp_ns
        tid = batch.trial_id
        if not tid:
            self.outside += 1
            if self.outside == 1:
                self.log.warning("gyro batches outside any trial (empty trial_id) are ignored")
            return []
        key = (source, tid)
        self.last_batch_s[source] = now
        if self.opener.get(tid, source) != source:
            self.foreign_batches += 1
            if key not in self._foreign_warned and len(self._foreign_warned) < _DONE_MEMORY:
                self._foreign_warned.add(key)
                self.log.warning(f"trial {tid}: batches from another process than the one that started it: dropped")
            return []
        t = self.open.get(key)
        if t is None:
            if key in self.done:
                stopped_ns = self.done[key]
                if stamp_ns is None or stopped_ns is None or stamp_ns < stopped_ns:
                    return self._late(key, [batch])  # a late batch of a trial already fitted
                del self.done[key]  # a batch after the trial's end: the same trial id run again
            # a batch before its START (the two topics are not ordered against each other),
            # or of an unknown trial: kept for grace_s, reported if no event claims it
            t = self.open[key] = _Open(tid, source, TrialAccumulator(self.options), now)
        t.seen_s = now
        if t.start_order is not None:
            self._passed[source] = max(self._passed.get(source, 0), t.start_order)
        problem = t.acc.add(batch)
        if problem is not None and problem[0] not in t.warned:
            t.warned.add(problem[0])
            self.log.warning(f"trial {tid}: {problem[1]} (reported once per trial)")
        if t.stop is not None and t.acc.covers(int(t.stop.sample_count)):
            return self._evict([self._finish(t)], source)
        return self._evict([], source)

    def poll(self, live: bool = True) -> list[TrialFit]:
        """Results whose wait has ended (call periodically).

        ``live``: both topics have publishers; while not, nothing waiting is given up on.
        """
        if not live:
            return []
        now = self.clock()
        if now - self.matched_at < self.history_grace_s:
            return []  # the transient-local history may still be arriving
        out: list[TrialFit | None] = []
        for t in list(self.open.values()):
            if t.stop is not None:
                if self._stopped_done(t, now):
                    out.append(self._finish(t))
            elif now - max(t.seen_s, self.matched_at) >= self.grace_s and t.start is None:
                out.append(self._finish(t))
        return [r for r in out if r is not None]

    def _stopped_done(self, t: _Open, now: float) -> bool:
        """Whether a stopped trial still missing samples is to be fitted now.

        Its missing batches are lost once the source's stream has passed it, or its batches have
        been silent for ``grace_s``; lost ones are asked for again where a resend service answers
        (only of a trial its source started: the driver knows no other).
        """
        assert t.stop is not None and t.stop_order is not None
        silent = now - max(self.last_batch_s.get(t.source, 0.0), t.stop_seen_s, self.matched_at) >= self.grace_s
        lost = silent or self._passed.get(t.source, 0) > t.stop_order
        if not self.can_resend:
            if lost and t.first_asked_s is not None:
                return True  # (the service went away while it was asked)
            # the old rule: a stream still flowing may hold them, up to history_grace_s after the STOP
            flowing = min(self.last_batch_s.get(t.source, 0.0), t.stop_seen_s + self.history_grace_s)
            return now - max(t.stop_seen_s, self.matched_at, flowing) >= self.grace_s
        if not lost:
            return False
        if t.start is None:
            return True  # (no START from its source: not a trial the driver can be asked about)
        if t.first_asked_s is not None and now - t.first_asked_s >= RESEND_GIVE_UP_S:
            t.acc.gap_cause = f"asked for again, the driver did not answer in {RESEND_GIVE_UP_S:g} s"
            return True
        if t.asked_s is None or now - t.asked_s >= RESEND_RETRY_S:
            self._ask(t, now)
        return False

    def _ask(self, t: _Open, now: float) -> None:
        """Ask the source again for the span of everything ``t`` misses (one request: one answer)."""
        assert t.stop is not None
        gaps = t.acc.missing(int(t.stop.sample_count))
        if not gaps:
            return
        first, end = gaps[0][0], gaps[-1][1]
        self._resend.append(ResendRequest(t.source, t.trial_id, first, end - first))
        if t.first_asked_s is None:
            missing = sum(b - a for a, b in gaps)
            self.log.info(f"trial {t.trial_id}: {missing} samples lost on the way; asked the driver again")
            t.first_asked_s = now
        t.asked_s = now

    def take_resend_requests(self) -> list[ResendRequest]:
        """The resend requests made since the last call (the node sends them to the driver)."""
        out, self._resend = self._resend, []
        return out

    def on_resent(
        self, source: str, trial_id: str, held: bool, complete: bool, batches: list[SampleBatch]
    ) -> list[TrialFit]:
        """The driver's answer to a resend request; returns the results it completes.

        Args:
            source: The source that was asked (the trial's).
            trial_id: The trial.
            held: The driver holds the trial (False: it never had it, or forgot it).
            complete: The answer holds every batch it has of the range (False: ask again).
            batches: Its batches of the range.
        """
        t = self.open.get((source, trial_id))
        if t is None:
            return self._late((source, trial_id), batches)
        if t.stop is None:
            return []
        for batch in batches:
            if batch.trial_id == trial_id and not t.acc.covers_range(batch.first_index, len(batch.rates)):
                t.acc.add(batch)
        n = int(t.stop.sample_count)
        if t.acc.covers(n):
            self.log.info(f"trial {trial_id}: the lost samples came again from the driver")
            return self._evict([self._finish(t)], source)
        if not held:
            t.acc.gap_cause = "lost on the way; the driver no longer holds them"
        elif complete:
            t.acc.gap_cause = "the driver never had them"
        else:
            t.asked_s = None  # (a partial answer: ask again for the rest at the next poll)
            return []
        return self._evict([self._finish(t)], source)

    # ------------------------------------------------------------------ output
    def _evict(self, out: list[TrialFit | None], source: str) -> list[TrialFit]:
        """Bound the memory of ``source``'s trials (the one that just sent something).

        At most ``max_open_trials`` trials without a STOP (stopped ones wait ``grace_s`` at
        most), and at most that many trials' worth of samples; other sources' trials are
        never touched.
        """
        limit = self.max_open_trials
        budget = limit * self.options.max_trial_samples
        in_history = self.clock() - self.matched_at < self.history_grace_s
        while True:
            mine = [t for t in self.open.values() if t.source == source]
            running = [t for t in mine if t.stop is None]
            if len(running) > limit and not in_history:
                victim = min(running, key=lambda t: t.seen_s)
                why = f"more than {limit} trials without STOP"
            elif sum(t.acc.kept for t in mine) > budget:
                victim = min(mine, key=lambda t: t.seen_s)
                why = f"more than {budget} samples buffered"
            else:
                break
            self.log.warning(f"trial {victim.trial_id}: {why}; fitted as it is")
            out.append(self._finish(victim))
        return [r for r in out if r is not None]

    def _finish(self, t: _Open) -> TrialFit | None:
        del self.open[(t.source, t.trial_id)]
        self.done[(t.source, t.trial_id)] = t.stop.stamp_ns if t.stop is not None else None
        while len(self.done) > _DONE_MEMORY:
            self.done.popitem(last=False)
        if t.start is None and self.opener.get(t.trial_id, t.source) != t.source:
            self.log.warning(
                f"trial {t.trial_id}: {t.acc.kept} samples and events from another process than the one that "
                "started it: dropped, not published"
            )
            return None
        if (
            t.start is not None
            and not t.acc.has_first_sample
            and self.horizon_ns is not None
            and t.start.stamp_ns < self.horizon_ns
        ):
            self.suppressed += 1
            self.log.info(
                f"trial {t.trial_id}: began before the oldest gyro batch received (the transient-local history); "
                "not re-published"
            )
            return None
        result = t.acc.finish(t.start, t.stop, trial_id=t.trial_id)
        self.published += 1
        self._report(result)
        if t.stop is not None and not t.acc.covers(int(t.stop.sample_count)):
            self._gapped[(t.source, t.trial_id)] = t  # (its missing batches may still come late)
            while len(self._gapped) > self.max_open_trials:
                self._gapped.popitem(last=False)
        return result

    def _late(self, key: _Key, batches: list[SampleBatch]) -> list[TrialFit]:
        """Batches of a trial already published with samples missing: once it is whole, it is fitted again.

        The new estimate replaces the first (consumers keep the one with more samples); a trial
        published whole ignores late copies.
        """
        t = self._gapped.get(key)
        if t is None or t.stop is None:
            return []
        for batch in batches:
            if not t.acc.covers_range(batch.first_index, len(batch.rates)):
                t.acc.add(batch)
        if not t.acc.covers(int(t.stop.sample_count)):
            return []
        del self._gapped[key]
        t.acc.gap_cause = ""
        result = t.acc.finish(t.start, t.stop, trial_id=t.trial_id)
        self.published += 1
        self.log.info(f"trial {t.trial_id}: its missing samples came late; fitted again")
        self._report(result)
        return [result]

    def _report(self, r: TrialFit) -> None:
        what = f"T = {r.period:.6f} ± {r.period_sigma:.2g} s" if r.valid else "no period"
        line = f"trial {r.trial_id} ({r.measurement_key or '?'}): {what}, {r.n_samples}/{r.n_expected} samples"
        if r.flags:
            self.log.warning(line + "; flags: " + "; ".join(str(f) for f in r.flags))
        else:
            self.log.info(line)
