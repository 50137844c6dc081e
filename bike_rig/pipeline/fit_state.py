"""The fitting stage's live bookkeeping: trial events and sample batches in, results out.

Batches that arrive before their START are kept (a trial's batches and events travel on two
topics); a STOP waits up to ``grace_s`` for missing batches; at most ``max_open_trials`` trials
are buffered. After a restart the fitter receives the transient-local history of both topics:
the trial in progress and every earlier trial whose batches are all still in the history are
fitted again (same values, consumers dedupe by trial_id); a trial that began before the oldest
batch in the history is not re-published.
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


@dataclass
class _Open:
    """A trial being buffered."""

    trial_id: str
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
            (counted from when both topics' publishers were matched, if later), s.
        max_open_trials: Trials buffered at once without a STOP (and that many trials' worth of
            samples in all); beyond it the one heard of least recently is fitted as it is (flag
            ``no_stop`` or ``unknown_trial``).
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
        self.open: dict[str, _Open] = {}
        #: Trials fitted: id -> rig time of their STOP (None without one), ns.
        self.done: OrderedDict[str, int | None] = OrderedDict()
        #: Rig time of the oldest gyro batch received [ns]: the start of the history we have.
        self.horizon_ns: int | None = None
        #: When the publishers of both topics were (last) matched, monotonic s.
        self.matched_at = 0.0
        self.published = 0
        self.suppressed = 0
        self.outside = 0

    # ------------------------------------------------------------------ input
    def on_event(self, event: TrialEventRecord) -> list[TrialFit]:
        """A trial event; returns the results it completes."""
        now = self.clock()
        kind, tid = event.kind, event.trial_id
        out: list[TrialFit | None] = []
        if kind is TrialEventKind.START:
            t = self.open.get(tid)
            if t is not None and t.start is not None:
                self.log.warning(f"trial {tid}: second START ignored")
                return []
            if t is None:
                if tid in self.done:
                    self.log.warning(f"trial {tid} started again: it is fitted again")
                    del self.done[tid]
                t = self.open[tid] = _Open(tid, TrialAccumulator(self.options), now)
            t.start, t.seen_s = event, now
            return self._evict(out)
        # STOP or ABORT
        t = self.open.get(tid)
        if t is None:
            if tid in self.done:
                self.log.warning(f"trial {tid}: STOP of a trial already fitted ignored")
                return []
            self.log.warning(f"trial {tid}: STOP without START")
            t = self.open[tid] = _Open(tid, TrialAccumulator(self.options), now)
        elif t.stop is not None:
            self.log.warning(f"trial {tid}: second STOP ignored")
            return []
        elif t.start is None:
            self.log.warning(f"trial {tid}: STOP without START")
        t.stop, t.stop_seen_s, t.seen_s = event, now, now
        if t.acc.covers(int(event.sample_count)):
            out.append(self._finish(t))
        return self._evict(out)

    def on_batch(self, batch: SampleBatch, stamp_ns: int | None = None) -> list[TrialFit]:
        """A gyro batch (``stamp_ns``: its header stamp); returns the results it completes."""
        now = self.clock()
        if stamp_ns is not None and (self.horizon_ns is None or stamp_ns < self.horizon_ns):
            self.horizon_ns = stamp_ns
        tid = batch.trial_id
        if not tid:
            self.outside += 1
            if self.outside == 1:
                self.log.warning("gyro batches outside any trial (empty trial_id) are ignored")
            return []
        t = self.open.get(tid)
        if t is None:
            if tid in self.done:
                stopped_ns = self.done[tid]
                if stamp_ns is None or stopped_ns is None or stamp_ns < stopped_ns:
                    return []  # a late batch of a trial already fitted
                del self.done[tid]  # a batch after the trial's end: the same trial id run again
            # a batch before its START (the two topics are not ordered against each other),
            # or of an unknown trial: kept for grace_s, reported if no event claims it
            t = self.open[tid] = _Open(tid, TrialAccumulator(self.options), now)
        t.seen_s = now
        problem = t.acc.add(batch)
        if problem is not None and problem[0] not in t.warned:
            t.warned.add(problem[0])
            self.log.warning(f"trial {tid}: {problem[1]} (reported once per trial)")
        if t.stop is not None and t.acc.covers(int(t.stop.sample_count)):
            return self._evict([self._finish(t)])
        return self._evict([])

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
                since = max(t.stop_seen_s, self.matched_at)
            elif t.start is None:
                since = max(t.seen_s, self.matched_at)
            else:
                continue
            if now - since >= self.grace_s:
                out.append(self._finish(t))
        return [r for r in out if r is not None]

    # ------------------------------------------------------------------ output
    def _evict(self, out: list[TrialFit | None]) -> list[TrialFit]:
        """Bound the memory.

        At most ``max_open_trials`` trials without a STOP (stopped ones wait ``grace_s`` at
        most), and at most that many trials' worth of samples in all.
        """
        limit = self.max_open_trials
        budget = limit * self.options.max_trial_samples
        in_history = self.clock() - self.matched_at < self.history_grace_s
        while True:
            running = [t for t in self.open.values() if t.stop is None]
            if len(running) > limit and not in_history:
                victim = min(running, key=lambda t: t.seen_s)
                why = f"more than {limit} trials without STOP"
            elif sum(t.acc.kept for t in self.open.values()) > budget:
                victim = min(self.open.values(), key=lambda t: t.seen_s)
                why = f"more than {budget} samples buffered"
            else:
                break
            self.log.warning(f"trial {victim.trial_id}: {why}; fitted as it is")
            out.append(self._finish(victim))
        return [r for r in out if r is not None]

    def _finish(self, t: _Open) -> TrialFit | None:
        del self.open[t.trial_id]
        self.done[t.trial_id] = t.stop.stamp_ns if t.stop is not None else None
        while len(self.done) > _DONE_MEMORY:
            self.done.popitem(last=False)
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
