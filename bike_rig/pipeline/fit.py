"""Fitting, the second stage: one trial's sample batches and events → its period (Eq 23–27).

:class:`TrialAccumulator` assembles a trial from its
:class:`~bike_rig.pipeline.acquire.SampleBatch` records with bounded memory and fits it with
:func:`bike_rig.core.period.fit_period`; :func:`fit_trial` does both at once. The fitter node
and the offline runner both call this code, so a replayed bag gives bit-identical results.
A trial's result is one record, :class:`TrialFit` (identity, reception, and the core's
:class:`~bike_rig.core.period.PeriodFit`), the same type when read back from a message.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.period import (
    TRIAL_FLAG_CODES,
    FitOptions,
    Flag,
    FlagCode,
    PeriodFit,
    WindowKind,
    WindowPolicy,
    fit_period,
)
from .acquire import SampleBatch, SampleBlock, TrialEventKind, TrialEventRecord
from .errors import FlagCodeError

__all__ = [
    "TrialAccumulator",
    "TrialFit",
    "TrialFitOptions",
    "fit_trial",
]

FloatArray = NDArray[np.float64]

#: Gap ranges listed in a flag's reason.
_SHOWN_GAPS = 5


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
        """Check the limits.

        Raises:
            ValueError: ``max_trial_samples`` or ``max_batch_samples`` is below 1.
        """
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
            # (only when set: the estimates recorded before the option keep their exact JSON)
            **({"small_swing_period": True} if self.fit.small_swing_period else {}),
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
            small_swing_period=bool(data.get("small_swing_period", False)),
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


def _make_flags(trial_id: str, codes: Sequence[str], reasons: Sequence[str]) -> tuple[Flag, ...]:
    """Flags from their codes and reasons (a missing reason is "").

    Raises:
        FlagCodeError: A code is not a :class:`~bike_rig.core.period.FlagCode`.
    """
    padded = list(reasons) + [""] * max(0, len(codes) - len(reasons))
    out = []
    for code, reason in zip(codes, padded):
        try:
            out.append(Flag(FlagCode(code), str(reason)))
        except ValueError:
            known = ", ".join(c.value for c in FlagCode)
            raise FlagCodeError(f"trial '{trial_id}': unknown quality flag code '{code}' (known: {known})") from None
    return tuple(out)


@dataclass(frozen=True)
class TrialFit:
    """One trial's result: what it measured, how its samples arrived, and the fit of Eq 23.

    Attributes:
        trial_id: The trial.
        measurement_key: The period it measures ("" when unknown).
        fit: The core's fit (period, σ, ζ, ω, r², flags of the fit itself...).
        trial_flags: Flags of the trial's reception (``gap``, ``aborted``...), before the fit's.
        n_samples: Samples used (kept, in order, without overlaps).
        n_expected: Samples the driver announced (STOP's ``sample_count``; 0 without STOP).
        window: The fit window as trial sample indices ``(start, stop)``, stop exclusive.
        fit_options_json: :meth:`TrialFitOptions.to_json` of the options used.
        stamp_ns: Rig time of the STOP event (else START, else 0), ns.
        sample_rate_hz: The rate the fit used, Hz (NaN when unknown).
        samples: The samples fitted (the kept batches in index order, without overlaps; rad/s
            for the rig), or None (a record read from a message).
        sample_times: Their times when they are not contiguous (sample index / rate, s: the
            time axis the fit used), else None (the fit's axis is then position / rate).
    """

    trial_id: str
    measurement_key: str
    fit: PeriodFit
    trial_flags: tuple[Flag, ...] = ()
    n_samples: int = 0
    n_expected: int = 0
    window: tuple[int, int] = (0, 0)
    fit_options_json: str = ""
    stamp_ns: int = 0
    sample_rate_hz: float = math.nan
    samples: FloatArray | None = field(default=None, compare=False, repr=False)
    sample_times: FloatArray | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_period(
        cls,
        trial_id: str,
        measurement_key: str,
        period: float,
        period_sigma: float,
        valid: bool,
        flags: Sequence[str] = (),
        flag_reasons: Sequence[str] = (),
        *,
        zeta: float = math.nan,
        omega: float = math.nan,
        r2: float = math.nan,
        residual_rms: float = math.nan,
        n_samples: int = 0,
        n_expected: int = 0,
        window: tuple[int, int] = (0, 0),
        fit_options_json: str = "",
        stamp_ns: int = 0,
    ) -> TrialFit:
        """A result known by its published fields only (a ``PeriodEstimate``, a test's trial).

        The fit's A, B, C and cycles are NaN; trial-level flag codes go to ``trial_flags``,
        the others to the fit.

        Args:
            trial_id: The trial.
            measurement_key: The period it measures.
            period: T, s.
            period_sigma: σ_T, s.
            valid: A period was obtained.
            flags: Flag codes.
            flag_reasons: One reason per flag.
            zeta: ζ.
            omega: ω, rad/s.
            r2: r².
            residual_rms: rad/s.
            n_samples: Samples used.
            n_expected: Samples announced.
            window: Fit window, trial sample indices.
            fit_options_json: The options used.
            stamp_ns: Rig time, ns.

        Raises:
            FlagCodeError: A flag code is unknown.
        """
        all_flags = _make_flags(trial_id, flags, flag_reasons)
        w = (int(window[0]), int(window[1]))
        nan = math.nan
        fit = PeriodFit(
            period=float(period),
            period_sigma=float(period_sigma),
            zeta=float(zeta),
            omega=float(omega),
            A=nan,
            B=nan,
            C=nan,
            r2=float(r2),
            residual_rms=float(residual_rms),
            n_cycles=nan,
            n_samples=int(n_samples),
            window=w,
            valid=bool(valid),
            flags=tuple(f for f in all_flags if f.code not in TRIAL_FLAG_CODES),
        )
        return cls(
            trial_id=trial_id,
            measurement_key=measurement_key,
            fit=fit,
            trial_flags=tuple(f for f in all_flags if f.code in TRIAL_FLAG_CODES),
            n_samples=int(n_samples),
            n_expected=int(n_expected),
            window=w,
            fit_options_json=fit_options_json,
            stamp_ns=int(stamp_ns),
        )

    @property
    def period(self) -> float:
        """T, s (NaN without a period)."""
        return self.fit.period

    @property
    def period_sigma(self) -> float:
        """σ_T, s."""
        return self.fit.period_sigma

    @property
    def valid(self) -> bool:
        """A period was obtained."""
        return self.fit.valid

    @property
    def flags(self) -> tuple[Flag, ...]:
        """Every flag: the trial's, then the fit's."""
        return self.trial_flags + self.fit.flags

    @property
    def flag_codes(self) -> tuple[str, ...]:
        """The flags' codes, e.g. ``("gap", "beating")``."""
        return tuple(f.code.value for f in self.flags)

    @property
    def flag_reasons(self) -> tuple[str, ...]:
        """One reason per flag."""
        return tuple(f.reason for f in self.flags)

    @property
    def usable(self) -> bool:
        """Valid, unflagged, with a finite positive period and σ: it enters the combination."""
        f = self.fit
        return (
            f.valid
            and not self.flags
            and math.isfinite(f.period)
            and f.period > 0.0
            and math.isfinite(f.period_sigma)
            and f.period_sigma > 0.0
        )


def _ranges(ranges: list[tuple[int, int]]) -> str:
    shown = ", ".join(f"[{a}, {b})" for a, b in ranges[:_SHOWN_GAPS])
    return shown + (f" and {len(ranges) - _SHOWN_GAPS} more" if len(ranges) > _SHOWN_GAPS else "")


class TrialAccumulator:
    """One trial's batches, with bounded memory.

    Rules, in receiving order: a batch over ``max_batch_samples`` is rejected
    (``oversized_batch``); a repeated ``first_index`` is a duplicate, ignored; samples at index
    ``max_trial_samples`` or beyond are dropped (``truncated``). Kept batches are put in index
    order: overlapping samples are dropped (``overlap``), missing indices in
    ``[0, sample_count)`` flagged (``gap``), extra ones too (``sample_count``). The fit uses the
    batches' rate, or ``times = index / rate`` when indices are not consecutive
    (``rate_mismatch`` when batches or START disagree). Trial flags come before the fit's own;
    also ``no_start``, ``no_stop``, ``unknown_trial``, ``aborted``.

    Args:
        options: The limits (and the fit's options, used by :meth:`finish`).
    """

    def __init__(self, options: TrialFitOptions):
        """Start an empty trial."""
        self.options = options
        self._parts: dict[int, FloatArray] = {}
        self._rates: dict[int, float] = {}
        self.kept = 0
        self.batches = 0
        self.duplicates = 0
        self.oversized: list[tuple[int, int]] = []
        self.dropped = 0
        #: Why samples are missing, when the receiver knows (said in the ``gap`` flag).
        self.gap_cause = ""

    def add(self, batch: SampleBatch) -> tuple[str, str] | None:
        """Take one batch.

        Returns:
            What was wrong with it, as (kind, message) for the log, or None.
        """
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
        problem = None
        if keep < n:
            self.dropped += n - keep
            problem = "truncated", f"{n - keep} samples from index {first + keep} dropped (max_trial_samples {limit_t})"
        if keep == 0:
            return problem
        rates = np.asarray(batch.rates, dtype=np.float64)
        kept = rates[:keep] if keep < n else rates
        self._parts[first] = kept
        self._rates[first] = float(batch.sample_rate_hz)
        self.kept += keep
        bad = int(np.count_nonzero(~np.isfinite(kept)))
        if bad:
            problem = "non_finite", f"{bad} NaN/infinite samples in the batch at index {first}"
        return problem

    def add_block(self, block: SampleBlock) -> bool:
        """Take a whole trial's batches at once, exactly as :meth:`add` on each of them would.

        Only into an empty accumulator, and only when every batch starts where the previous
        one ended, all at one finite rate, none oversized or beyond the trial limit (then no
        batch is rejected, cut or a duplicate, and the kept samples are the block's).

        Returns:
            Whether it took them (False: nothing was taken; add the batches one by one).
        """
        n = np.diff(block.bounds)
        first = block.first_index
        if self.batches or not len(n) or int(n.min()) < 1 or int(n.max()) > self.options.max_batch_samples:
            return False
        start = int(first[0])
        total = int(block.bounds[-1] - block.bounds[0])
        if start < 0 or start + total > self.options.max_trial_samples:
            return False
        rate = float(block.sample_rate_hz[0])
        if not (np.all(first[1:] == first[:-1] + n[:-1]) and np.all(block.sample_rate_hz == rate)):
            return False
        samples = block.rates[int(block.bounds[0]) : int(block.bounds[-1])]
        self.batches = len(n)
        self._parts[start] = samples
        self._rates[start] = rate
        self.kept = total
        return True

    def missing(self, n_expected: int) -> list[tuple[int, int]]:
        """The index ranges ``[a, b)`` within ``[0, n_expected)`` not accounted for (see :meth:`covers`)."""
        spans = [(a, a + r.size) for a, r in self._parts.items()]
        spans += [(a, a + n) for a, n in self.oversized]
        spans.append((self.options.max_trial_samples, max(n_expected, self.options.max_trial_samples)))
        out: list[tuple[int, int]] = []
        end = 0
        for a, b in sorted(spans):
            if a > end and end < n_expected:
                out.append((end, min(a, n_expected)))
            end = max(end, b)
        if end < n_expected:
            out.append((end, n_expected))
        return out

    def covers_range(self, first: int, n: int) -> bool:
        """Whether every index of ``[first, first + n)`` was already kept or rejected."""
        return not any(a < first + n and b > first for a, b in self.missing(first + n))

    def covers(self, n_expected: int) -> bool:
        """Whether every index in ``[0, n_expected)`` is accounted for.

        An index is accounted for when it was kept, was in a rejected batch, or lies beyond
        the trial limit (so waiting longer cannot change the result).
        """
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

    def _event_flags(self, start: TrialEventRecord | None, stop: TrialEventRecord | None) -> list[Flag]:
        """Flags of the trial's events and of the batches rejected or cut on arrival."""
        options = self.options
        flags: list[Flag] = []
        if start is None and stop is None:
            reason = f"{self.batches} gyro batches of a trial never announced (no START, no STOP)"
            flags.append(Flag(FlagCode.UNKNOWN_TRIAL, reason))
        elif start is None:
            flags.append(Flag(FlagCode.NO_START, "STOP without a START event: what the trial measured is unknown"))
        elif stop is None:
            flags.append(Flag(FlagCode.NO_STOP, "the trial never stopped: fitted as far as it was received"))
        if stop is not None and stop.kind is TrialEventKind.ABORT:
            flags.append(Flag(FlagCode.ABORTED, "the trial was aborted"))
        if self.oversized:
            first, n = self.oversized[0]
            flags.append(
                Flag(
                    FlagCode.OVERSIZED_BATCH,
                    f"{len(self.oversized)} batch(es) larger than max_batch_samples "
                    f"{options.max_batch_samples} rejected (first: {n} samples at index {first})",
                )
            )
        if self.dropped:
            flags.append(
                Flag(
                    FlagCode.TRUNCATED,
                    f"longer than max_trial_samples {options.max_trial_samples}: {self.dropped} samples dropped",
                )
            )
        return flags

    def _in_order(self, flags: list[Flag]) -> tuple[list[FloatArray], list[int], int]:
        """The kept parts in ``first_index`` order without overlaps: (chunks, their first indices, end)."""
        chunks: list[FloatArray] = []
        starts: list[int] = []
        end = 0
        overlapped = 0
        for a in sorted(self._parts):
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
            flags.append(Flag(FlagCode.OVERLAP, f"{overlapped} samples of batches overlapping earlier ones dropped"))
        return chunks, starts, end

    def _gap_flag(self, chunks: list[FloatArray], starts: list[int], end: int, n_expected: int) -> Flag | None:
        """Missing samples within ``[0, max(sample_count, last + 1))``, beyond the trial limit excepted."""
        horizon = min(max(n_expected, end), self.options.max_trial_samples)
        gaps: list[tuple[int, int]] = []
        at = 0
        for a, r in zip(starts, chunks):
            if a > at:
                gaps.append((at, min(a, horizon)))
            at = a + r.size
        if at < horizon:
            gaps.append((at, horizon))
        gaps = [(a, b) for a, b in gaps if b > a]
        if not gaps:
            return None
        missing = sum(b - a for a, b in gaps)
        cause = f" ({self.gap_cause})" if self.gap_cause else ""
        return Flag(FlagCode.GAP, f"{missing} samples missing in {len(gaps)} gap(s): {_ranges(gaps)}{cause}")

    def _rate(self, start: TrialEventRecord | None, flags: list[Flag]) -> float:
        """The batches' sample rate (the START event's without batches), Hz; flags disagreement."""
        rates = [self._rates[a] for a in sorted(self._parts)]
        rate = rates[0] if rates else (float(start.sample_rate_hz) if start is not None else math.nan)
        if any(r != rate for r in rates) or (start is not None and rates and float(start.sample_rate_hz) != rate):
            seen = sorted({*rates, *([float(start.sample_rate_hz)] if start is not None else [])})
            flags.append(
                Flag(
                    FlagCode.RATE_MISMATCH,
                    f"sample rates disagree ({', '.join(f'{r:g}' for r in seen)} Hz); fitted at {rate:g} Hz",
                )
            )
        return rate

    def finish(
        self, start: TrialEventRecord | None, stop: TrialEventRecord | None, trial_id: str | None = None
    ) -> TrialFit:
        """Assemble the kept samples and fit them.

        Args:
            start: The trial's START event, or None.
            stop: Its STOP or ABORT event, or None.
            trial_id: The trial's id when neither event is known.
        """
        options = self.options
        known = start or stop
        tid = known.trial_id if known is not None else (trial_id or "")
        key = start.measurement_key if start is not None else (stop.measurement_key if stop is not None else "")
        n_expected = int(stop.sample_count) if stop is not None else 0
        flags = self._event_flags(start, stop)
        chunks, starts, end = self._in_order(flags)
        # (one part, as a whole trial read from a bag is: its samples as they are, not a copy)
        samples = chunks[0] if len(chunks) == 1 else (np.concatenate(chunks) if chunks else np.empty(0))
        n = int(samples.size)
        contiguous = all(starts[i] + chunks[i].size == starts[i + 1] for i in range(len(chunks) - 1))
        gap = self._gap_flag(chunks, starts, end, n_expected)
        if gap is not None:
            flags.append(gap)
        if stop is not None and end > n_expected:
            reason = f"samples up to index {end} received, the driver announced {n_expected}"
            flags.append(Flag(FlagCode.SAMPLE_COUNT, reason))
        rate = self._rate(start, flags)

        fo = options.fit
        kwargs: dict[str, Any] = {
            "window": fo.window,
            "min_cycles": fo.min_cycles,
            "min_r2": fo.min_r2,
            "max_modulation": fo.max_modulation,
            "max_drift": fo.max_drift,
            "small_swing_period": fo.small_swing_period,
        }
        times: FloatArray | None = None
        index: NDArray[np.intp] | None = None
        if not (math.isfinite(rate) and rate > 0):
            flags.append(Flag(FlagCode.BAD_RATE, f"no usable sample rate ({rate!r} Hz): nothing was fitted"))
            fit = PeriodFit.invalid((), fo.window, n_samples=n)
        elif contiguous:
            fit = fit_period(samples, sample_rate_hz=rate, **kwargs)
        else:
            index = np.concatenate([np.arange(a, a + r.size) for a, r in zip(starts, chunks)])
            times = index / rate
            fit = fit_period(samples, times=times, **kwargs)

        # the window in trial sample indices
        w0, w1 = fit.window
        if n == 0:
            window = (0, 0)
        elif index is None:
            window = (starts[0] + w0, starts[0] + max(w0, w1))
        else:
            first_index = int(index[w0]) if w0 < n else int(index[-1]) + 1
            window = (first_index, int(index[w1 - 1]) + 1 if w1 > w0 else first_index)

        return TrialFit(
            trial_id=tid,
            measurement_key=key,
            fit=fit,
            trial_flags=tuple(flags),
            n_samples=n,
            n_expected=n_expected,
            window=(int(window[0]), int(window[1])),
            fit_options_json=options.to_json(),
            stamp_ns=(stop.stamp_ns if stop is not None else 0) or (start.stamp_ns if start is not None else 0),
            sample_rate_hz=rate,
            samples=samples,
            sample_times=times,
        )


def fit_trial(
    batches: Iterable[SampleBatch],
    start: TrialEventRecord | None,
    stop: TrialEventRecord | None,
    options: TrialFitOptions | None = None,
) -> TrialFit:
    """Assemble one trial's batches (in the order received) and fit its period.

    Exactly what the fitter node publishes for the trial.

    Args:
        batches: The trial's batches, in receiving order.
        start: Its START event, or None.
        stop: Its STOP (or ABORT) event, or None.
        options: Fit options and limits (a PeriodEstimate's ``fit_options_json`` through
            :meth:`TrialFitOptions.from_json`); the defaults when None.
    """
    acc = TrialAccumulator(options or TrialFitOptions())
    if isinstance(batches, SampleBlock) and acc.add_block(batches):
        return acc.finish(start, stop, trial_id=batches.trial_id)
    tid = None
    for b in batches:
        tid = tid or b.trial_id
        acc.add(b)
    return acc.finish(start, stop, trial_id=tid)
