"""The fitter node: buffers each trial's gyro batches between its START and STOP events, fits
the period (paper Eq 23–27) on STOP and publishes a ``PeriodEstimate`` — valid or not, with
its flags and their reasons.

The assembly of a trial and its fit are ROS-free and live at the top of this module, so that
the offline replay runs exactly the same code and gets bit-identical results::

    from bike_rig.nodes.fitter import TrialFitOptions, fit_trial
    result = fit_trial(batches, start_event, stop_event, TrialFitOptions.from_json(estimate.fit_options_json))

``batches`` are GyroBatch messages (rclpy's or rosbags'; anything with ``trial_id``,
``first_index``, ``sample_rate_hz`` and ``rates``) in the order they were received; the events
are TrialEvent messages (None when missing). Nothing here imports rclpy until the node is
built (:class:`FitterNode`), so the replay needs no ROS runtime.

Assembly rules (:class:`TrialAccumulator`), applied in receiving order:

* a batch with more than ``max_batch_samples`` samples is rejected (flag ``oversized_batch``);
* a batch with the ``first_index`` of one already kept is a duplicate and is ignored;
* samples at index ``max_trial_samples`` or beyond (or beyond that many kept samples) are
  dropped (flag ``truncated``): a trial's memory is bounded;
* the kept batches are put in ``first_index`` order; samples that overlap an earlier batch are
  dropped (flag ``overlap``); missing indices in ``[0, sample_count)`` are flagged (``gap``),
  more samples than announced too (``sample_count``);
* the fit: ``fit_period(samples, sample_rate_hz=rate)`` when the indices are consecutive, else
  ``fit_period(samples, times=index / rate)``, ``rate`` the batches' ``sample_rate_hz``
  (flag ``rate_mismatch`` when they, or the START event, disagree).

Trial-level flags come first, then the fit's own (:class:`~bike_rig.core.period.FlagCode`:
``non_finite`` for NaN samples, ``too_few_cycles``...). Also: ``no_start`` (a STOP without a
START), ``no_stop`` (a trial evicted before its STOP), ``unknown_trial`` (batches of a trial
never announced), ``aborted`` (stopped by ABORT).

Live bookkeeping (:class:`FitterState`): batches that arrive before their START are kept (a
trial's batches and events travel on two topics); a STOP waits up to ``grace_s`` for missing
batches; at most ``max_open_trials`` trials are buffered. After a restart the fitter receives
the transient-local history of both topics: the trial in progress and every earlier trial whose
batches are all still in the history are fitted again (same values, consumers dedupe by
trial_id); a trial that began before the oldest batch in the history is not re-published.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..core.period import FitOptions, PeriodFit, WindowKind, WindowPolicy, fit_period

if TYPE_CHECKING:
    from rclpy.node import Node

__all__ = [
    "FitterNode",
    "fill_period_estimate",
    "FitterState",
    "GyroBatchLike",
    "TrialAccumulator",
    "TrialEventLike",
    "TrialFit",
    "TrialFitOptions",
    "fit_trial",
    "main",
]

FloatArray = NDArray[np.float64]

#: TrialEvent kinds (bike_rig_msgs/msg/TrialEvent).
START, STOP, ABORT = 0, 1, 2
#: Trial ids remembered as finished (late batches of them are ignored, not "unknown").
_DONE_MEMORY = 100_000
#: Gap ranges listed in a flag's reason.
_SHOWN_GAPS = 5


class GyroBatchLike(Protocol):
    """What the fit reads of a ``bike_rig_msgs/msg/GyroBatch`` (rclpy or rosbags message)."""

    @property
    def trial_id(self) -> str: ...
    @property
    def first_index(self) -> int: ...
    @property
    def sample_rate_hz(self) -> float: ...
    @property
    def rates(self) -> Any: ...


class TrialEventLike(Protocol):
    """What the fit reads of a ``bike_rig_msgs/msg/TrialEvent``."""

    @property
    def kind(self) -> int: ...
    @property
    def trial_id(self) -> str: ...
    @property
    def measurement_key(self) -> str: ...
    @property
    def sample_rate_hz(self) -> float: ...
    @property
    def sample_count(self) -> int: ...
    @property
    def header(self) -> Any: ...


@dataclass(frozen=True)
class TrialFitOptions:
    """Everything that decides a trial's result: the fit's options and the assembly limits.

    Attributes:
        fit: :func:`~bike_rig.core.period.fit_period`'s options.
        max_trial_samples: Samples kept per trial; more are dropped and flagged ``truncated``.
        max_batch_samples: A larger batch is rejected and flagged ``oversized_batch``.
    """

    fit: FitOptions = field(default_factory=FitOptions)
    max_trial_samples: int = 1_000_000
    max_batch_samples: int = 10_000

    def __post_init__(self) -> None:
        if self.max_trial_samples < 1 or self.max_batch_samples < 1:
            raise ValueError("max_trial_samples and max_batch_samples must be >= 1")

    def to_dict(self) -> dict[str, Any]:
        """The options as plain data (the ``fit_options_json`` of a PeriodEstimate)."""
        w = self.fit.window
        return {
            "window": {
                "kind": w.kind.value,
                "lead_in_s": w.lead_in_s,
                "start_s": w.start_s,
                "stop_s": w.stop_s,
                "fraction": w.fraction,
                "whole_cycles": w.whole_cycles,
            },
            "min_cycles": self.fit.min_cycles,
            "min_r2": self.fit.min_r2,
            "max_modulation": self.fit.max_modulation,
            "max_drift": self.fit.max_drift,
            "max_trial_samples": self.max_trial_samples,
            "max_batch_samples": self.max_batch_samples,
        }

    def to_json(self) -> str:
        """:meth:`to_dict` as compact JSON with sorted keys (floats round-trip exactly)."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrialFitOptions:
        """The inverse of :meth:`to_dict` (missing keys take their defaults).

        Raises:
            ValueError: A malformed value.
        """
        d = cls()
        w = data.get("window", {})
        window = WindowPolicy(
            kind=WindowKind(w.get("kind", d.fit.window.kind.value)),
            lead_in_s=float(w.get("lead_in_s", d.fit.window.lead_in_s)),
            start_s=float(w.get("start_s", d.fit.window.start_s)),
            stop_s=None if w.get("stop_s") is None else float(w["stop_s"]),
            fraction=float(w.get("fraction", d.fit.window.fraction)),
            whole_cycles=bool(w.get("whole_cycles", d.fit.window.whole_cycles)),
        )
        fit = FitOptions(
            window=window,
            min_cycles=float(data.get("min_cycles", d.fit.min_cycles)),
            min_r2=float(data.get("min_r2", d.fit.min_r2)),
            max_modulation=float(data.get("max_modulation", d.fit.max_modulation)),
            max_drift=float(data.get("max_drift", d.fit.max_drift)),
        )
        return cls(
            fit,
            int(data.get("max_trial_samples", d.max_trial_samples)),
            int(data.get("max_batch_samples", d.max_batch_samples)),
        )

    @classmethod
    def from_json(cls, text: str) -> TrialFitOptions:
        """The inverse of :meth:`to_json`."""
        return cls.from_dict(json.loads(text))


@dataclass(frozen=True)
class TrialFit:
    """A trial's result: the fields of a ``PeriodEstimate`` and the fit behind them.

    Attributes:
        trial_id: The trial.
        measurement_key: The period it measures ("" when unknown).
        period: T, s (NaN without a period).
        period_sigma: σ_T, s.
        zeta: ζ.
        omega: ω, rad/s.
        r2: r².
        residual_rms: rad/s.
        n_samples: Samples used (kept, in order, without overlaps).
        n_expected: Samples the driver announced (STOP's ``sample_count``; 0 without STOP).
        window_start: First sample index of the fit window.
        window_stop: One past its last sample index.
        valid: A period was obtained.
        flags: Flag codes, trial-level first.
        flag_reasons: One reason per flag.
        fit_options_json: :meth:`TrialFitOptions.to_json`.
        stamp_ns: Rig time of the STOP event (else START, else 0), ns.
        sample_rate_hz: The rate the fit used, Hz.
        fit: The core's full result.
        samples: The samples fitted: the kept batches in index order, without overlaps.
        sample_times: Their times when they are not contiguous (sample index / rate, s: the
            time axis the fit used), else None (the fit's axis is then position / rate).
    """

    trial_id: str
    measurement_key: str
    period: float
    period_sigma: float
    zeta: float
    omega: float
    r2: float
    residual_rms: float
    n_samples: int
    n_expected: int
    window_start: int
    window_stop: int
    valid: bool
    flags: tuple[str, ...]
    flag_reasons: tuple[str, ...]
    fit_options_json: str
    stamp_ns: int
    sample_rate_hz: float
    fit: PeriodFit
    samples: FloatArray | None = None
    sample_times: FloatArray | None = None


def _stamp_ns(event: TrialEventLike | None) -> int:
    if event is None:
        return 0
    stamp = event.header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _ranges(ranges: list[tuple[int, int]]) -> str:
    shown = ", ".join(f"[{a}, {b})" for a, b in ranges[:_SHOWN_GAPS])
    return shown + (f" and {len(ranges) - _SHOWN_GAPS} more" if len(ranges) > _SHOWN_GAPS else "")


class TrialAccumulator:
    """One trial's batches, with bounded memory (the assembly rules of the module docstring).

    Args:
        options: The limits (and the fit's options, used by :meth:`finish`).
    """

    def __init__(self, options: TrialFitOptions):
        self.options = options
        self._parts: dict[int, FloatArray] = {}
        self._rates: dict[int, float] = {}
        self.kept = 0
        self.batches = 0
        self.duplicates = 0
        self.oversized: list[tuple[int, int]] = []
        self.dropped = 0
        self.non_finite = 0

    def add(self, batch: GyroBatchLike) -> tuple[str, str] | None:
        """Take one batch; returns what was wrong with it, as (kind, message) for the log, or
        None."""
        self.batches += 1
        first = int(batch.first_index)
        n = len(batch.rates)
        limit_b, limit_t = self.options.max_batch_samples, self.options.max_trial_samples
        if n > limit_b:
            self.oversized.append((first, n))
            return "oversized", f"batch of {n} samples at index {first} rejected (max_batch_samples {limit_b})"
        if first in self._parts:
            self.duplicates += 1
            return "duplicate", f"duplicate batch at index {first} ignored"
        room = min(limit_t - first, limit_t - self.kept)
        keep = max(0, min(n, room))
        rates = np.array(batch.rates, dtype=np.float64)
        problem = None
        if keep < n:
            self.dropped += n - keep
            problem = "truncated", f"{n - keep} samples from index {first + keep} dropped (max_trial_samples {limit_t})"
        if keep == 0:
            return problem
        kept = rates[:keep] if keep < n else rates
        self._parts[first] = kept
        self._rates[first] = float(batch.sample_rate_hz)
        self.kept += keep
        bad = int(np.count_nonzero(~np.isfinite(kept)))
        if bad:
            self.non_finite += bad
            problem = "non_finite", f"{bad} NaN/infinite samples in the batch at index {first}"
        return problem

    def covers(self, n_expected: int) -> bool:
        """Whether every index in ``[0, n_expected)`` is accounted for: kept, in a rejected
        batch, or beyond the trial limit (so waiting longer cannot change the result)."""
        spans = [(a, a + r.size) for a, r in self._parts.items()]
        spans += [(a, a + n) for a, n in self.oversized]
        spans.append((self.options.max_trial_samples, max(n_expected, self.options.max_trial_samples)))
        end = 0
        for a, b in sorted(spans):
            if a > end:
                break
            end = max(end, b)
        return end >= n_expected

    @property
    def has_first_sample(self) -> bool:
        """Whether the sample at index 0 was kept."""
        return 0 in self._parts

    def finish(
        self, start: TrialEventLike | None, stop: TrialEventLike | None, trial_id: str | None = None
    ) -> TrialFit:
        """Assemble the kept samples and fit them.

        Args:
            start: The trial's START event, or None.
            stop: Its STOP or ABORT event, or None.
            trial_id: The trial's id when neither event is known.
        """
        options = self.options
        flags: list[tuple[str, str]] = []
        known = start or stop
        tid = known.trial_id if known is not None else (trial_id or "")
        key = start.measurement_key if start is not None else (stop.measurement_key if stop is not None else "")
        n_expected = int(stop.sample_count) if stop is not None else 0
        if start is None and stop is None:
            reason = f"{self.batches} gyro batches of a trial never announced (no START, no STOP)"
            flags.append(("unknown_trial", reason))
        elif start is None:
            flags.append(("no_start", "STOP without a START event: what the trial measured is unknown"))
        elif stop is None:
            flags.append(("no_stop", "the trial never stopped: fitted as far as it was received"))
        if stop is not None and int(stop.kind) == ABORT:
            flags.append(("aborted", "the trial was aborted"))
        if self.oversized:
            first, n = self.oversized[0]
            flags.append((
                "oversized_batch",
                f"{len(self.oversized)} batch(es) larger than max_batch_samples {options.max_batch_samples} rejected "
                f"(first: {n} samples at index {first})",
            ))  # fmt: skip
        if self.dropped:
            flags.append((
                "truncated",
                f"longer than max_trial_samples {options.max_trial_samples}: {self.dropped} samples dropped",
            ))  # fmt: skip

        # assemble in first_index order, without overlaps
        order = sorted(self._parts)
        chunks: list[FloatArray] = []
        starts: list[int] = []
        end = 0
        overlapped = 0
        for a in order:
            r = self._parts[a]
            if chunks and a < end:
                skip = min(r.size, end - a)
                overlapped += skip
                r, a = r[skip:], a + skip
                if r.size == 0:
                    continue
            chunks.append(r)
            starts.append(a)
            end = a + r.size
        if overlapped:
            flags.append(("overlap", f"{overlapped} samples of batches overlapping earlier ones dropped"))
        samples = np.concatenate(chunks) if chunks else np.empty(0)
        n = int(samples.size)
        contiguous = all(starts[i] + chunks[i].size == starts[i + 1] for i in range(len(chunks) - 1))

        # missing samples within [0, max(sample_count, last + 1)), beyond the trial limit excepted
        horizon = min(max(n_expected, end), options.max_trial_samples)
        gaps: list[tuple[int, int]] = []
        at = 0
        for a, r in zip(starts, chunks):
            if a > at:
                gaps.append((at, min(a, horizon)))
            at = a + r.size
        if at < horizon:
            gaps.append((at, horizon))
        gaps = [(a, b) for a, b in gaps if b > a]
        if gaps:
            missing = sum(b - a for a, b in gaps)
            flags.append(("gap", f"{missing} samples missing in {len(gaps)} gap(s): {_ranges(gaps)}"))
        if stop is not None and end > n_expected:
            flags.append(("sample_count", f"samples up to index {end} received, the driver announced {n_expected}"))

        # the rate
        rates = [self._rates[a] for a in order]
        rate = rates[0] if rates else (float(start.sample_rate_hz) if start is not None else math.nan)
        if any(r != rate for r in rates) or (start is not None and rates and float(start.sample_rate_hz) != rate):
            seen = sorted({*rates, *([float(start.sample_rate_hz)] if start is not None else [])})
            flags.append(("rate_mismatch", f"sample rates disagree ({', '.join(f'{r:g}' for r in seen)} Hz); "
                          f"fitted at {rate:g} Hz"))  # fmt: skip

        kwargs: dict[str, Any] = {
            "window": options.fit.window,
            "min_cycles": options.fit.min_cycles,
            "min_r2": options.fit.min_r2,
            "max_modulation": options.fit.max_modulation,
            "max_drift": options.fit.max_drift,
        }
        times: FloatArray | None = None
        if not (math.isfinite(rate) and rate > 0):
            flags.append(("bad_rate", f"no usable sample rate ({rate!r} Hz): nothing was fitted"))
            fit = PeriodFit.invalid((), options.fit.window, n_samples=n)
        elif contiguous:
            fit = fit_period(samples, sample_rate_hz=rate, **kwargs)
        else:
            index = np.concatenate([np.arange(a, a + r.size) for a, r in zip(starts, chunks)])
            times = index / rate
            fit = fit_period(samples, times=times, **kwargs)

        # the window in sample indices
        w0, w1 = fit.window
        if n == 0:
            window = (0, 0)
        elif contiguous:
            window = (starts[0] + w0, starts[0] + max(w0, w1))
        else:
            index = np.concatenate([np.arange(a, a + r.size) for a, r in zip(starts, chunks)])
            first_index = int(index[w0]) if w0 < n else int(index[-1]) + 1
            window = (first_index, int(index[w1 - 1]) + 1 if w1 > w0 else first_index)

        flags += [(f.code.value, f.reason) for f in fit.flags]
        return TrialFit(
            trial_id=tid,
            measurement_key=key,
            period=fit.period,
            period_sigma=fit.period_sigma,
            zeta=fit.zeta,
            omega=fit.omega,
            r2=fit.r2,
            residual_rms=fit.residual_rms,
            n_samples=n,
            n_expected=n_expected,
            window_start=int(window[0]),
            window_stop=int(window[1]),
            valid=fit.valid,
            flags=tuple(code for code, _ in flags),
            flag_reasons=tuple(reason for _, reason in flags),
            fit_options_json=options.to_json(),
            stamp_ns=_stamp_ns(stop) or _stamp_ns(start),
            sample_rate_hz=rate,
            fit=fit,
            samples=samples,
            sample_times=times,
        )


def fit_trial(
    batches: Iterable[GyroBatchLike],
    start: TrialEventLike | None,
    stop: TrialEventLike | None,
    options: TrialFitOptions | None = None,
) -> TrialFit:
    """Assemble one trial's batches (in the order received) and fit its period — exactly what
    the fitter node publishes, for the offline replay.

    Args:
        batches: The trial's GyroBatch messages, in receiving order.
        start: Its START event, or None.
        stop: Its STOP (or ABORT) event, or None.
        options: Fit options and limits (a PeriodEstimate's ``fit_options_json`` through
            :meth:`TrialFitOptions.from_json`); the defaults when None.
    """
    acc = TrialAccumulator(options or TrialFitOptions())
    tid = None
    for b in batches:
        tid = tid or b.trial_id
        acc.add(b)
    return acc.finish(start, stop, trial_id=tid)


class Log(Protocol):
    """The logger the fitter reports to (rclpy's node logger, or :mod:`logging`'s)."""

    def info(self, message: str) -> Any: ...
    def warning(self, message: str) -> Any: ...


@dataclass
class _Open:
    """A trial being buffered."""

    trial_id: str
    acc: TrialAccumulator
    seen_s: float
    start: TrialEventLike | None = None
    stop: TrialEventLike | None = None
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
    def on_event(self, event: TrialEventLike) -> list[TrialFit]:
        """A trial event; returns the results it completes."""
        now = self.clock()
        kind, tid = int(event.kind), event.trial_id
        out: list[TrialFit | None] = []
        if kind == START:
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
        if kind in (STOP, ABORT):
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
        self.log.warning(f"trial {tid}: trial event of unknown kind {kind} ignored")
        return []

    def on_batch(self, batch: GyroBatchLike, stamp_ns: int | None = None) -> list[TrialFit]:
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
        """Results whose wait has ended (call periodically). ``live``: both topics have
        publishers; while not, nothing waiting is given up on."""
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
        """Bound the memory: at most ``max_open_trials`` trials without a STOP (stopped ones
        wait ``grace_s`` at most), and at most that many trials' worth of samples in all."""
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
        self.done[t.trial_id] = _stamp_ns(t.stop) if t.stop is not None else None
        while len(self.done) > _DONE_MEMORY:
            self.done.popitem(last=False)
        if (
            t.start is not None
            and not t.acc.has_first_sample
            and self.horizon_ns is not None
            and _stamp_ns(t.start) < self.horizon_ns
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
            self.log.warning(line + "; flags: " + "; ".join(f"{c}: {why}" for c, why in zip(r.flags, r.flag_reasons)))
        else:
            self.log.info(line)


def fill_period_estimate(msg: Any, r: TrialFit) -> Any:
    """Fill a ``PeriodEstimate`` message (rclpy or rosbags) with a result, and return it: what
    the fitter node publishes, and what a simulated recording holds."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(r.stamp_ns, 1_000_000_000)
    msg.trial_id = r.trial_id
    msg.measurement_key = r.measurement_key
    msg.period = r.period
    msg.period_sigma = r.period_sigma
    msg.zeta = r.zeta
    msg.omega = r.omega
    msg.r2 = r.r2
    msg.residual_rms = r.residual_rms
    msg.n_samples = r.n_samples
    msg.n_expected = r.n_expected
    msg.window_start = r.window_start
    msg.window_stop = r.window_stop
    msg.valid = r.valid
    msg.flags = list(r.flags)
    msg.flag_reasons = list(r.flag_reasons)
    msg.fit_options_json = r.fit_options_json
    return msg


# ---------------------------------------------------------------------- the ROS node


class FitterNode:
    """The ROS adapter: parameters in, messages to :class:`FitterState`, estimates out.

    Subscribes (reliable, transient-local as in :mod:`bike_rig.topics`) to the gyro batches and
    trial events; publishes ``PeriodEstimate`` on the periods topic. Every callback catches
    everything: a bad message is logged and the node keeps running. ``self.node`` is the
    rclpy node (named ``fitter``).
    """

    def __init__(self) -> None:
        from rclpy.node import Node

        from ..topics import GYRO, PERIODS, TRIAL_EVENTS
        from .qos import profile

        # (bike_rig_msgs ships no type information: imported by name)
        msgs: Any = importlib.import_module("bike_rig_msgs.msg")
        GyroBatch, PeriodEstimate, TrialEvent = msgs.GyroBatch, msgs.PeriodEstimate, msgs.TrialEvent

        self.node: Node = Node("fitter")
        self._estimate_type = PeriodEstimate
        options, grace, max_open, history_grace = self._parameters()
        self.state = FitterState(options, self.node.get_logger(), grace, max_open, history_grace_s=history_grace)
        # (events first: when both are ready, the executor takes them in creation order)
        self.events_sub = self.node.create_subscription(TrialEvent, TRIAL_EVENTS.name, self._on_event,
                                                        profile(TRIAL_EVENTS))  # fmt: skip
        self.gyro_sub = self.node.create_subscription(GyroBatch, GYRO.name, self._on_batch, profile(GYRO))
        self.periods_pub = self.node.create_publisher(PeriodEstimate, PERIODS.name, profile(PERIODS))
        self._live = False
        self.timer = self.node.create_timer(0.05, self._on_timer)
        self.node.get_logger().info(f"fitting trials with {options.to_json()}")

    def _parameters(self) -> tuple[TrialFitOptions, float, int, float]:
        rcl: Any = importlib.import_module("rcl_interfaces.msg")
        FloatingPointRange, IntegerRange, ParameterDescriptor = (
            rcl.FloatingPointRange, rcl.IntegerRange, rcl.ParameterDescriptor
        )
        from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException

        from ..sources.errors import SourceConfigError

        d = TrialFitOptions()
        w = d.fit.window
        big = float(sys.float_info.max)
        specs: list[tuple[str, Any, str, tuple[float, float] | None]] = [
            ("max_trial_samples", d.max_trial_samples, "samples kept per trial; more are dropped, flagged", (1, 2**40)),
            ("max_batch_samples", d.max_batch_samples, "a larger gyro batch is rejected and flagged", (1, 2**31)),
            ("max_open_trials", 4, "trials buffered at once (started but not stopped)", (1, 1000)),
            ("grace_s", 1.0, "how long a STOP waits for missing batches, and batches for their START, s", (0.0, 60.0)),
            (
                "history_grace_s",
                10.0,
                "after matching, how long the transient-local history may take to arrive (nothing incomplete is "
                "fitted meanwhile), s",
                (0.0, 600.0),
            ),
            ("window", w.kind.value, "fit window policy: lead_in, span or envelope", None),
            ("lead_in_s", w.lead_in_s, "lead_in window: seconds dropped at the start", (0.0, big)),
            ("span_start_s", w.start_s, "span window: first time kept, s from the first sample", (0.0, big)),
            ("span_stop_s", 0.0, "span window: end, s from the first sample (0: to the end)", (0.0, big)),
            ("envelope_fraction", w.fraction, "envelope window: stop below this fraction of the peak", (1e-9, 1.0)),
            ("whole_cycles", w.whole_cycles, "shorten the window to whole cycles", None),
            ("min_cycles", d.fit.min_cycles, "flag a window with fewer cycles", (0.0, big)),
            ("min_r2", d.fit.min_r2, "flag a fit with a lower r²", (-big, 1.0)),
            ("max_modulation", d.fit.max_modulation, "flag beating above this relative modulation", (0.0, big)),
            ("max_drift", d.fit.max_drift, "flag an offset drift above this fraction of the oscillation", (0.0, big)),
        ]
        values: dict[str, Any] = {}
        for name, default, text, bounds in specs:
            desc = ParameterDescriptor(description=text, read_only=True)
            if bounds is not None and isinstance(default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(bounds[0]), to_value=float(bounds[1]))]
            elif bounds is not None and isinstance(default, int) and not isinstance(default, bool):
                desc.integer_range = [IntegerRange(from_value=int(bounds[0]), to_value=int(bounds[1]), step=1)]
            if name == "window":
                desc.additional_constraints = "one of: lead_in, span, envelope"
            try:
                values[name] = self.node.declare_parameter(name, default, desc).value
            except InvalidParameterTypeException:
                kind = type(default).__name__.replace("float", "double (e.g. 1.0)").replace("str", "string")
                raise SourceConfigError("fitter", name, f"expected a {kind}", where="") from None
            except InvalidParameterValueException:
                low, high = bounds or (math.nan, math.nan)
                shown = (f"{int(low)}, {int(high)}" if isinstance(default, int) else f"{low:g}, {high:g}")
                raise SourceConfigError("fitter", name, f"must be within [{shown}]", where="") from None
        kinds = tuple(k.value for k in WindowKind)
        if values["window"] not in kinds:
            raise SourceConfigError("fitter", "window", f"expected one of {', '.join(kinds)}", values["window"],
                                    where="")  # fmt: skip
        try:
            kind = WindowKind(values["window"])
            window = WindowPolicy(
                kind=kind,
                lead_in_s=values["lead_in_s"],
                start_s=values["span_start_s"],
                stop_s=values["span_stop_s"] or None,
                fraction=values["envelope_fraction"],
                whole_cycles=values["whole_cycles"],
            )
            options = TrialFitOptions(
                FitOptions(window, values["min_cycles"], values["min_r2"], values["max_modulation"],
                           values["max_drift"]),
                values["max_trial_samples"],
                values["max_batch_samples"],
            )  # fmt: skip
        except ValueError as exc:
            raise SourceConfigError("fitter", "window", str(exc), values["window"], where="") from None
        return options, float(values["grace_s"]), int(values["max_open_trials"]), float(values["history_grace_s"])

    # ------------------------------------------------------------------ callbacks (never raise)
    def _on_batch(self, msg: Any) -> None:
        try:
            stamp = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
            self._publish(self.state.on_batch(msg, stamp))
        except Exception as exc:  # a callback must never raise: log and keep serving
            self.node.get_logger().error(f"gyro batch of trial {getattr(msg, 'trial_id', '?')!r} failed: {exc!r}")

    def _on_event(self, msg: Any) -> None:
        try:
            self._publish(self.state.on_event(msg))
        except Exception as exc:
            self.node.get_logger().error(f"trial event of trial {getattr(msg, 'trial_id', '?')!r} failed: {exc!r}")

    def _on_timer(self) -> None:
        try:
            live = self.gyro_sub.get_publisher_count() > 0 and self.events_sub.get_publisher_count() > 0
            if live and not self._live:
                self.state.matched_at = self.state.clock()
            self._live = live
            self._publish(self.state.poll(live))
        except Exception as exc:
            self.node.get_logger().error(f"fitter timer failed: {exc!r}")

    def _publish(self, results: list[TrialFit]) -> None:
        for r in results:
            self.periods_pub.publish(self.estimate(r))

    def estimate(self, r: TrialFit) -> Any:
        """The PeriodEstimate message of a result."""
        return fill_period_estimate(self._estimate_type(), r)


def main(args: list[str] | None = None) -> int:
    """Run the fitter node (``--ros-args --params-file config/fitter.yaml`` and ``-p`` work)."""
    from .runner import run_node

    return run_node(lambda: FitterNode().node, args, name="fitter")


if __name__ == "__main__":
    sys.exit(main())
