"""The fitting stage's live bookkeeping: trial events and sample batches in, results out.

Batches that arrive before their START are kept (a trial's batches and events travel on two
topics); a STOP waits up to ``grace_s`` for missing batches; at most ``max_open_trials`` trials
are buffered. After a restart the fitter receives the transient-local history of both topics:
the trial in progress and every earlier trial whose batches are all still in the history are
fitted again (same values, consumers dedupe by trial_id); a trial that began before the oldest
batch in the history is not re-published.

Every event and batch comes with its **source**: the DDS participant that published it (the
first 12 bytes of the publisher's GUID, shared by all publishers of one driver process). A
trial is the pair (source, trial id): batches and events of the same id from another process
(a second driver, a rogue publisher on the domain) never enter, evict, cut short or duplicate
it, and the limits on open trials and buffered samples hold per source, so junk from one
process can only evict that process's own trials. A trial id belongs to the source whose START
opened it first: another source's batches of that id are dropped as they come (counted, one
warning per source and trial), and what another source sent of it before the START (the two
topics are not ordered) is dropped, not published, when it would end without a START of its
own: no estimate ever carries a real trial's id for another process's samples.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from .acquire import SampleBatch, TrialEventKind, TrialEventRecord
from .fit import TrialAccumulator, TrialFit, TrialFitOptions

__all__ = ["FitterState", "Log"]

#: Trial ids remembered as finished (late batches of them are ignored, not "unknown").
_DONE_MEMORY = 100_000


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

    # ------------------------------------------------------------------ input
    def on_event(self, event: TrialEventRecord, source: str = "") -> list[TrialFit]:
        """A trial event from ``source`` (see the module docstring); returns the results it completes."""
        now = self.clock()
        kind, tid, key = event.kind, event.trial_id, (source, event.trial_id)
        out: list[TrialFit | None] = []
        if kind is TrialEventKind.START:
            t = self.open.get(key)
            if t is not None and t.start is not None:
                self.log.warning(f"trial {tid}: second START ignored")
                return []
            if t is None:
                if key in self.done:
                    self.log.warning(f"trial {tid} started again: it is fitted again")
                    del self.done[key]
                t = self.open[key] = _Open(tid, source, TrialAccumulator(self.options), now)
            t.start, t.seen_s = event, now
            if tid not in self.opener:
                self.opener[tid] = source
                while len(self.opener) > _DONE_MEMORY:
                    self.opener.popitem(last=False)
            return self._evict(out, source)
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
        t.stop, t.stop_seen_s, t.seen_s = event, now, now
        if t.acc.covers(int(event.sample_count)):
            out.append(self._finish(t))
        return self._evict(out, source)

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
                    return []  # a late batch of a trial already fitted
                del self.done[key]  # a batch after the trial's end: the same trial id run again
            # a batch before its START (the two topics are not ordered against each other),
            # or of an unknown trial: kept for grace_s, reported if no event claims it
            t = self.open[key] = _Open(tid, source, TrialAccumulator(self.options), now)
        t.seen_s = now
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
                # while the source's batches still arrive (the fitter behind a burst: a resumed
                # session's recorded trials, a loaded machine), the missing ones may be queued
                # behind them: wait grace_s after the source's last batch, at most
                # history_grace_s after the STOP
                flowing = min(self.last_batch_s.get(t.source, 0.0), t.stop_seen_s + self.history_grace_s)
                since = max(t.stop_seen_s, self.matched_at, flowing)
            elif t.start is None:
                since = max(t.seen_s, self.matched_at)
            else:
                continue
            if now - since >= self.grace_s:
                out.append(self._finish(t))
        return [r for r in out if r is not None]

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
        return result

    def _report(self, r: TrialFit) -> None:
        what = f"T = {r.period:.6f} ± {r.period_sigma:.2g} s" if r.valid else "no period"
        line = f"trial {r.trial_id} ({r.measurement_key or '?'}): {what}, {r.n_samples}/{r.n_expected} samples"
        if r.flags:
            self.log.warning(line + "; flags: " + "; ".join(str(f) for f in r.flags))
        else:
            self.log.info(line)
