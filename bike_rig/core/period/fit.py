"""Fit of the paper's decaying oscillation (Eq 23) to one trial, with an honest σ of the period.

Stages
------
1. **Clean-up** (:mod:`~bike_rig.core.period.clean`). Non-finite samples (and samples with
   non-finite timestamps) are left out and flagged. Bad data never raise: they give a result
   with ``valid=False`` and a flag saying why. The fit itself works on block means scaled to
   about ±1, so any finite input works.
2. **Window** (:mod:`~bike_rig.core.period.window`): the policy's samples.
3. **Initial guess** (:mod:`~bike_rig.core.period.spectrum`): the highest peak of the
   spectrum; a peak that does not stand out of its surroundings means there is no oscillation.
   Unless the policy says otherwise, the window is then cut at its end to a whole number of
   cycles of the guessed period.
4. **Variable projection** on means of blocks of about 1/16 cycle. The mean over a block of k
   evenly spaced samples of ``exp(s t)`` (``s = −ζω + iω sqrt(1 − ζ²)``) is exactly
   ``g_k(s) exp(s t̄)``, ``g_k(s) = sinh(k s Δt/2) / (k sinh(s Δt/2))``, so the block means
   follow Eq 23 with the same ζ, ω, A, B, C: the fit of the block means *is* a least-squares fit
   of Eq 23 to the samples, restricted to the block averages (it gives up the signal inside the
   blocks, ~1 % of the oscillation's information) at a small fraction of the cost. For fixed
   (ζω, ω sqrt(1 − ζ²)) Eq 23 is linear in A, B, C, which are solved for; Levenberg–Marquardt
   (:mod:`~bike_rig.core.period.lm`) fits the two nonlinear parameters with the analytic
   (Kaufman) Jacobian of the projected residual, until neither moves by 1e-3 of its σ.
5. **Uneven timestamps** (``times`` with jitter or gaps, or samples left out): the block means
   are then only nearly exact, and Gauss–Newton steps on every sample, with the analytic
   Jacobian of all five parameters, finish the fit.
6. **Residuals** of every sample give r², the residual RMS and the sample-level flags
   (:mod:`~bike_rig.core.period.quality`).
7. **Was an oscillation found?** The record's spectral peak at the fitted frequency must stand
   out of the residuals' noise floor with a false-alarm probability of at most 1e-4
   (:mod:`~bike_rig.core.period.detection`), and swing by more than half an ADC step; else
   ``valid=False`` with ``no_oscillation``: a period means an oscillation was found.

A 30 s trial at 1 kHz takes about 1 ms (``bench/bench_period.py``): a few passes over the
samples, everything else on a few hundred block means.

σ of the period
---------------
The paper's Eq 27 assumes independent residuals; a rate gyro's drifting bias and quantisation
make them serially correlated, so ``period_sigma`` is a drift-robust sandwich (batch-means)
estimate, with Eq 27's reported as ``period_sigma_white``: see :mod:`~bike_rig.core.period.sigma`.
The solvers of stages 4 and 5 are in :mod:`~bike_rig.core.period.solver`.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .clean import Invalid, clean_samples
from .damping_fit import fit_damping, with_small_swing_period
from .detection import detect
from .ends import with_end_check
from .oscillation import TWO_PI, damped_cosine, damped_cosine_even, zeta_omega
from .quality import (
    clipping_flag,
    drift_flag,
    held_flag,
    modulation_index,
    noise_and_quantum,
    steady_phase,
    two_mode_flag,
)
from .result import Flag, FlagCode, PeriodFit
from .sigma import BlockDesign, period_sigma
from .small_swing import with_small_swing_systematic
from .solver import FitFailed, Solution, gauss_newton, varpro
from .spectrum import block_sums, block_times, peak_of_blocks, spectrum_block
from .stationarity import PhaseResidual, with_stationarity
from .window import DEFAULT_WINDOW, WindowPolicy, first_at_or_after, select_window, select_window_even

__all__ = ["FitOptions", "fit_period"]

FloatArray = NDArray[np.float64]

#: Block means per cycle in the variable-projection stage.
BLOCKS_PER_CYCLE = 16
#: Spectral prominence below which a record holds no oscillation (noise stays below ~20).
MIN_PROMINENCE = 40.0
#: A trial with fewer cycles than this has no period (a flag below ``min_cycles``).
MIN_VALID_CYCLES = 2.0
#: Cycle counts are compared with this slack (the window is cut to whole cycles of the guess).
CYCLE_TOLERANCE = 0.05
#: Fewest samples in the window.
MIN_SAMPLES = 16
#: An oscillation must swing by more than this many ADC steps (the smallest step of the samples).
MIN_STEPS = 0.5
#: A relative σ of the period above this means the oscillation is not determined.
MAX_RELATIVE_SIGMA = 0.05


@dataclass(frozen=True)
class FitOptions:
    """Options of :func:`fit_period` (its keyword arguments).

    Attributes:
        window: The window policy (default: whole record minus a 1 s lead-in, whole cycles).
        min_cycles: Fewer cycles than this in the window are flagged (fewer than 2: invalid).
        min_r2: An r² below this is flagged.
        max_modulation: A smooth envelope/phase modulation above this fraction of the
            amplitude (and above its noise) is flagged as beating.
        max_drift: A residual drift, peak to peak, above this fraction of the oscillation's
            peak to peak is flagged.
        small_swing_period: When the period follows the swing (:mod:`.damping`), report that of
            a vanishing swing as ``period`` (else the mean period over the window, as Eq 23's).
        min_valid_cycles: Fewer cycles than this have no period (default 2; a ride's short segment: 1).
    """

    window: WindowPolicy = DEFAULT_WINDOW
    min_cycles: float = 4.0
    min_r2: float = 0.9
    max_modulation: float = 0.02
    max_drift: float = 0.5
    small_swing_period: bool = False
    min_valid_cycles: float = MIN_VALID_CYCLES


def fit_period(
    samples: ArrayLike,
    sample_rate_hz: float | None = None,
    times: ArrayLike | None = None,
    *,
    window: WindowPolicy = DEFAULT_WINDOW,
    min_cycles: float = 4.0,
    min_r2: float = 0.9,
    max_modulation: float = 0.02,
    max_drift: float = 0.5,
    small_swing_period: bool = False,
    min_valid_cycles: float = MIN_VALID_CYCLES,
) -> PeriodFit:
    """Fit Eq 23 to one trial and return its period with an honest σ and quality flags.

    Args:
        samples: The rate gyro's samples, 1-D (rad/s or volts: any unit, A/B/C keep it).
        sample_rate_hz: Constant sample rate [Hz]; sample k is at ``k / sample_rate_hz``.
        times: Or the time of every sample [s], increasing (jitter and gaps are fine).
        window: Which samples to use (:class:`~bike_rig.core.period.window.WindowPolicy`).
        min_cycles: Flag a window with fewer cycles (fewer than 2 is invalid).
        min_r2: Flag a fit with a lower r².
        max_modulation: Flag beating above this relative envelope/phase modulation.
        max_drift: Flag an offset drift above this fraction of the oscillation.
        small_swing_period: Report the period of a vanishing swing (:class:`FitOptions`).
        min_valid_cycles: Fewer cycles than this have no period (:class:`FitOptions`).

    Returns:
        The fit. Bad data (empty, constant, noise, NaN, too short...) give ``valid=False`` and
        flags with the reason; they never raise.

    Raises:
        ValueError: Not exactly one of ``sample_rate_hz`` and ``times`` given, or a rate that
            is not a positive number (a programming mistake, not bad data).
    """
    if (sample_rate_hz is None) == (times is None):
        raise ValueError("fit_period needs exactly one of sample_rate_hz and times")
    rate = None
    if sample_rate_hz is not None:
        rate = float(sample_rate_hz)
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"sample_rate_hz must be a positive number, got {sample_rate_hz!r}")
    options = FitOptions(window, min_cycles, min_r2, max_modulation, max_drift, small_swing_period, min_valid_cycles)
    fitter = _Fitter(options)
    with np.errstate(all="ignore"):
        fit = fitter.run(samples, rate, times)
    if not (small_swing_period and fit.valid and math.isfinite(fit.small_swing_period)):
        return fit
    keep = replace(options, small_swing_period=False)

    def refit(policy: WindowPolicy) -> PeriodFit:
        with np.errstate(all="ignore"):
            return _Fitter(replace(keep, window=policy)).run(samples, rate, times)

    return with_small_swing_systematic(fit, fitter.span, refit)


@dataclass
class _Window:
    """The window's samples as the fit sees them (cut to whole cycles in place).

    Attributes:
        ys: The samples, in the fitter's ``units``.
        tw: Their times [s] from the first finite sample, or None when evenly spaced.
        even: The even sample interval [s], or None.
        start: Position of the first sample in the cleaned series.
        first: Time of the first sample [s].
        last: Time of the last sample [s].
    """

    ys: FloatArray
    tw: FloatArray | None
    even: float | None
    start: int
    first: float
    last: float

    @property
    def n(self) -> int:
        """Samples in the window."""
        return int(self.ys.size)

    @property
    def step(self) -> float:
        """The (mean) sample interval [s]."""
        return self.even if self.even is not None else (self.last - self.first) / (self.n - 1)


class _Fitter:
    """One fit: holds the options, the flags and notes gathered on the way."""

    def __init__(self, options: FitOptions):
        self.options = options
        self.flags: list[Flag] = []
        self.notes: list[str] = []
        self.window: tuple[int, int] = (0, 0)
        self.index: NDArray[np.intp] | None = None  # positions of the finite samples (None: all)
        self.n_used = 0
        self.t0 = 0.0  # time of the first finite sample, on the caller's axis [s]
        self.extremes = (-1.0, 1.0)  # the window's smallest and largest scaled samples
        self.span = (0.0, 0.0)  # the fitted window, (start, stop) [s from the first finite sample]

    def run(self, samples: ArrayLike, rate: float | None, times: ArrayLike | None) -> PeriodFit:
        """The fit of one trial; bad data give an invalid result (never raise)."""
        try:
            return self._run(samples, rate, times)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            # degenerate data (e.g. times spanning 1e300 s) that slipped past the checks
            failure = Invalid(Flag(FlagCode.FIT_FAILED, f"numerical failure on these data ({exc})"))
            return self._invalid(failure)
        except Invalid as exc:
            return self._invalid(exc)

    def _invalid(self, exc: Invalid) -> PeriodFit:
        return PeriodFit.invalid(
            tuple(self.flags) + exc.flags,
            self.options.window,
            window=self.window,
            n_samples=self.n_used,
            notes=tuple(self.notes),
        )

    # ------------------------------------------------------------------ driver
    def _run(self, samples: ArrayLike, rate: float | None, times: ArrayLike | None) -> PeriodFit:
        win = self._select(samples, rate, times)
        # block sums, for the spectrum and (grouped) for the fit
        k_spec = spectrum_block(win.n, win.step)
        sums, sizes = block_sums(win.ys, k_spec)
        omega0 = self._guess(win, sums, sizes, k_spec)
        if self.options.window.whole_cycles:
            self._cut_to_whole_cycles(win, omega0)
        tb, yb, counts, k = self._blocks(win, sums, k_spec, omega0)
        center = 0.5 * (win.first + win.last)
        duration = win.n * win.step
        try:
            sol = varpro(tb - center, yb, counts, win.step, omega0, duration, win.even is not None)
            if win.tw is not None and win.even is None:
                sol = gauss_newton(win.tw - center, win.ys, sol, duration, self.units)
        except FitFailed as exc:
            raise Invalid(Flag(FlagCode.FIT_FAILED, str(exc))) from None
        blocks = BlockDesign(tb, yb, counts, k, win.first, center, win.step, win.even is not None)
        return self._result(win, blocks, sol)

    def _select(self, samples: ArrayLike, rate: float | None, times: ArrayLike | None) -> _Window:
        """The policy's window of the cleaned samples, scaled (:meth:`_scale`)."""
        dropped: list[tuple[Flag, float]] = []
        t, y, index, even, self.t0 = clean_samples(samples, rate, times, self.flags, self.notes, dropped)
        self.index = index
        if even is not None:  # samples k · even [s]: their times are never materialised
            start, stop = select_window_even(even, y, self.options.window)
        else:
            assert t is not None
            start, stop = select_window(t, y, self.options.window)
        self._set_window(start, stop)
        if stop - start < MIN_SAMPLES:
            raise Invalid(
                Flag(FlagCode.EMPTY, f"{stop - start} samples in the window ({self.options.window.describe()})")
            )
        tw = None if t is None else t[start:stop]
        if tw is None:
            assert even is not None
            first, last = start * even, (stop - 1) * even
        else:
            first, last = float(tw[0]), float(tw[-1])
        for flag, end in dropped:
            if end <= first:  # (the lead-in's: nothing the fit uses)
                self.flags[:] = [f for f in self.flags if f is not flag]
                self.notes.append(f"{flag.reason}; before the window ({first:.3g} s on): no effect on the period")
        return _Window(self._scale(y[start:stop]), tw, even, start, first, last)

    def _scale(self, yw: FloatArray) -> FloatArray:
        """The window's samples for the fit; sets ``scale``, ``offset``, ``units`` and ``extremes``.

        The fit works on the block means scaled to about ±1 (any finite input); the samples
        themselves are only scaled when squares of them could overflow.
        """
        lo, hi = float(np.min(yw)), float(np.max(yw))
        if hi == lo:
            raise Invalid(Flag(FlagCode.CONSTANT, f"all {yw.size} samples in the window equal {lo:.6g}"))
        offset = 0.5 * lo + 0.5 * hi
        scale = 0.5 * hi - 0.5 * lo
        if not scale > np.finfo(float).tiny:
            raise Invalid(Flag(FlagCode.CONSTANT, f"the samples vary by only {2 * scale:.3g}"))
        self.scale, self.offset = scale, offset
        if max(abs(lo), abs(hi)) < 1e150 and scale > 1e-150:
            ys, self.units = yw, (scale, offset)  # samples in their own units
            self.extremes = (lo, hi)
        else:
            ys = yw / scale - offset / scale
            self.units = (1.0, 0.0)
            self.extremes = (lo / scale - offset / scale, hi / scale - offset / scale)  # as ys holds them
        return ys

    def _guess(self, win: _Window, sums: FloatArray, sizes: FloatArray, k_spec: int) -> float:
        """The spectrum's peak frequency [rad/s], or an invalid result (no oscillation, too short)."""
        spec_times = block_times(win.tw, k_spec, sizes, win.even, win.first)
        peak = peak_of_blocks(spec_times, sums / sizes, win.last - win.first, even=win.even is not None)
        if peak is None or not peak.prominence >= MIN_PROMINENCE:
            what = "none" if peak is None else f"the highest has prominence {peak.prominence:.1f} < {MIN_PROMINENCE:g}"
            raise Invalid(Flag(FlagCode.NO_OSCILLATION, f"no oscillation stands out of the noise ({what})"))
        guess_cycles = (win.n * win.step) * peak.omega / TWO_PI
        if guess_cycles < self.options.min_valid_cycles - CYCLE_TOLERANCE:
            raise Invalid(self._too_few(guess_cycles, TWO_PI / peak.omega))
        return peak.omega

    def _cut_to_whole_cycles(self, win: _Window, omega0: float) -> None:
        """Cut the window at its end to whole cycles of the guessed frequency ``omega0`` [rad/s]."""
        n, step, first, even = win.n, win.step, win.first, win.even
        guess_cycles = (n * step) * omega0 / TWO_PI
        # (a window within 5 % of a cycle of the next whole number is kept whole)
        whole = math.floor(guess_cycles + CYCLE_TOLERANCE)
        end = first + (whole * TWO_PI / omega0 - 0.5 * step)
        if win.tw is None:
            assert even is not None
            keep = first_at_or_after(end, even, win.start + n) - win.start
        else:
            keep = int(np.searchsorted(win.tw, end))
        keep = max(0, min(n, keep))
        if keep < n:
            stop = win.start + keep
            self._set_window(win.start, stop)
            if keep < MIN_SAMPLES:
                raise Invalid(Flag(FlagCode.EMPTY, f"{keep} samples in {whole} whole cycles"))
            win.ys = win.ys[:keep]
            if win.tw is not None:
                win.tw = win.tw[:keep]
            win.last = (stop - 1) * even if even is not None else float(win.tw[-1])  # type: ignore[index]

    def _blocks(
        self, win: _Window, sums: FloatArray, k_spec: int, omega0: float
    ) -> tuple[FloatArray, FloatArray, FloatArray, int]:
        """Block means of about 1/BLOCKS_PER_CYCLE cycle, scaled to about ±1: (times, means, sizes, k).

        With even samples the blocks are whole groups of the spectrum's blocks (``sums`` of
        ``k_spec`` samples each).
        """
        n, step, even, first = win.n, win.step, win.even, win.first
        k = max(1, int(round(TWO_PI / omega0 / BLOCKS_PER_CYCLE / step)))
        group = k // k_spec
        if group >= 1 and even is not None:
            k = group * k_spec
            full = n // k  # blocks of k samples, then one shorter block
            grouped = np.add.reduceat(sums[: full * group], np.arange(0, full * group, group)) if full else sums[:0]
            if n > full * k:
                grouped = np.append(grouped, np.sum(win.ys[full * k : n]))
            counts = np.full(grouped.size, float(k))
            counts[-1] = n - k * (grouped.size - 1)
            tb = block_times(None, k, counts, even, first)
            yb = grouped / counts
        else:
            sums_k, counts = block_sums(win.ys, k)
            tb = block_times(win.tw, k, counts, even, first)
            yb = sums_k / counts
        units_scale, units_offset = self.units
        yb = (yb - units_offset) / units_scale  # about ±1
        return tb, yb, counts, k

    def _set_window(self, start: int, stop: int) -> None:
        """Record the window as indices into the input samples."""
        index = self.index
        self.n_used = max(0, stop - start)
        if index is None:
            self.window = (start, max(start, stop))
        elif stop <= start:
            at = int(index[start]) if start < index.size else int(index[-1]) + 1
            self.window = (at, at)
        else:
            self.window = (int(index[start]), int(index[stop - 1]) + 1)

    def _time_of(self, t: FloatArray | None, first: float, step: float) -> Callable[[int], float]:
        """Time [s, the caller's axis] of the window's sample i."""
        if t is None:
            return lambda i: self.t0 + first + i * step
        return lambda i: self.t0 + float(t[i])

    @staticmethod
    def _tau_of(win: _Window, blocks: BlockDesign) -> FloatArray:
        """Every sample's time from the window centre [s]."""
        if win.tw is None:
            return (win.first - blocks.center) + win.step * np.arange(win.n, dtype=float)
        return win.tw - blocks.center

    def _sst(self, y: FloatArray, mean: float) -> float:
        """Σ (y − ȳ)² of the scaled samples, given their mean; ``y`` in ``self.units``."""
        c, o = self.units
        if abs(o) < 1e5 * c:  # Σ y² − n ȳ² in y's units: no harmful cancellation
            return (float(np.einsum("i,i->", y, y)) - y.size * (o + c * mean) ** 2) / c**2
        centred = y - (o + c * mean)
        return float(np.einsum("i,i->", centred, centred)) / c**2

    def _sample_units(self) -> tuple[float, float]:
        """(scale, offset) from the units of the full-data arrays to the samples' units."""
        units_scale, units_offset = self.units
        factor = self.scale / units_scale
        return factor, self.offset - units_offset * factor

    def _too_few(self, n_cycles: float, period: float) -> Flag:
        why = f"{n_cycles:.2f} cycles of {period:.4g} s in window, at least {self.options.min_valid_cycles:g} needed"
        return Flag(FlagCode.TOO_FEW_CYCLES, f"{why}: record longer (or shorten the lead-in)")

    # ------------------------------------------------------------------ statistics and flags
    def _residuals(self, win: _Window, blocks: BlockDesign, sol: Solution) -> tuple[FloatArray, float, float]:
        """The residual of every sample (in the units of the samples), SSE and SST (scaled units)."""
        y, n, step, first, center = win.ys, win.n, win.step, win.first, blocks.center
        s = complex(-sol.alpha, sol.omega_d)
        units_scale, units_offset = self.units
        if blocks.uniform or win.tw is None:
            r = damped_cosine_even(
                first - center, step, n, s, -units_scale * sol.K, -(units_offset + units_scale * sol.A)
            )
        else:
            r = damped_cosine(win.tw - center, s, -units_scale * sol.K)
            r -= units_offset + units_scale * sol.A
        r += y
        # (long dot products stay out of BLAS: its thread pool stalls for ms on a busy machine)
        sse = float(np.einsum("i,i->", r, r)) / units_scale**2  # in the scaled units
        if not math.isfinite(sse):
            raise Invalid(Flag(FlagCode.FIT_FAILED, "the fitted curve overflows"))
        sst = self._sst(y, float(np.dot(blocks.yb, blocks.counts)) / n)
        return r, sse, sst

    def _detect(self, win: _Window, r: FloatArray, sol: Solution) -> tuple[float, float]:
        """An invalid result unless the fit found an oscillation; else the residuals' (noise, quantum).

        It must stand out of the residuals' noise floor (:mod:`~bike_rig.core.period.detection`,
        on block means of the window's samples and residuals ``r``, as the initial guess) and
        swing by more than half an ADC step: the quantisation of a slow drift is a sawtooth of
        at most 1/π step whose period is the time the drift takes to cross a step.
        """
        k_spec = spectrum_block(win.n, win.step)
        sums, sizes = block_sums(win.ys, k_spec)
        residual_sums, _ = block_sums(r, k_spec)
        tb = block_times(win.tw, k_spec, sizes, win.even, win.first)
        duration = win.last - win.first
        found = detect(tb, sums / sizes, residual_sums / sizes, duration, sol.omega_d, win.even is not None)
        if not found.found:
            raise Invalid(Flag(FlagCode.NO_OSCILLATION, f"no oscillation stands out of the noise: {found.describe()}"))
        noise, quantum = noise_and_quantum(win.ys, r)  # (in the units of the samples)
        largest = abs(sol.K) * self.units[0] * math.exp(abs(sol.alpha) * 0.5 * duration)  # amplitude, window's ends
        if largest <= MIN_STEPS * quantum:
            factor, _ = self._sample_units()
            raise Invalid(
                Flag(
                    FlagCode.NO_OSCILLATION,
                    f"the fitted {TWO_PI / sol.omega_d:.4g} s swings by at most {largest * factor:.3g}, "
                    f"not more than half the samples' step {quantum * factor:.3g}: the staircase of a "
                    "quantised drift, not an oscillation",
                )
            )
        return noise, quantum

    def _flags(
        self,
        win: _Window,
        r: FloatArray,
        n_cycles: float,
        r2: float,
        beating: Flag | None,
        drift: float,
        noise_quantum: tuple[float, float],
    ) -> list[Flag]:
        """The flags gathered so far and the fit's own quality flags (noise, quantum: the residuals')."""
        y = win.ys
        new: list[Flag | None] = []
        if n_cycles < self.options.min_cycles - CYCLE_TOLERANCE:
            new.append(
                Flag(
                    FlagCode.TOO_FEW_CYCLES,
                    f"{n_cycles:.1f} cycles in the window (at least {self.options.min_cycles:g} wanted): record longer",
                )
            )
        if not r2 >= self.options.min_r2:
            new.append(
                Flag(FlagCode.POOR_FIT, f"r² = {r2:.3f} < {self.options.min_r2:g}: Eq 23 does not describe the record")
            )
        noise, quantum = noise_quantum  # (in the units of y)
        new += [
            beating,
            clipping_flag(y, r, noise, quantum, self.extremes, self._sample_units()),
            held_flag(y, r, noise, quantum, self.extremes, self._time_of(win.tw, win.first, win.step)),
            drift_flag(drift, self.options.max_drift),
        ]
        return list(self.flags) + [f for f in new if f is not None]

    def _result(self, win: _Window, blocks: BlockDesign, sol: Solution) -> PeriodFit:
        """The statistics and flags of the fit."""
        n, first = win.n, win.first
        self.span = (first, win.last + win.step)
        alpha, omega_d, A, K = sol.alpha, sol.omega_d, sol.A, sol.K
        s = complex(-alpha, omega_d)
        n_cycles = (n * win.step) * omega_d / TWO_PI
        if n_cycles < self.options.min_valid_cycles - CYCLE_TOLERANCE:
            raise Invalid(self._too_few(n_cycles, TWO_PI / omega_d))
        r, sse, sst = self._residuals(win, blocks, sol)
        noise_quantum = self._detect(win, r, sol)
        r2 = 1.0 - sse / sst if sst > 0 else math.nan
        s2 = sse / max(1, n - 5)  # Eq 26
        try:
            stats = period_sigma(sol, blocks, r, s2, n_cycles, self.units[0])
        except FitFailed as exc:
            raise Invalid(Flag(FlagCode.FIT_FAILED, str(exc))) from None
        if stats.white_fallback:
            self.notes.append("too few cycles for the drift-robust σ: σ from Eq 27 (white residuals)")
        period = TWO_PI / omega_d  # Eq 25
        zeta, omega = zeta_omega(alpha, omega_d)

        # beating and drift statistics, per cycle
        score, per_cycle, power = stats.score, stats.per_cycle, stats.power
        cycle_amplitude = abs(K) * np.sqrt(power / per_cycle)
        # per cycle: the residual's least-squares complex amplitude at the fitted frequency
        deviation = (score[2] - 1j * score[1]) * (2.0 / K) * (cycle_amplitude / power)
        modulation = modulation_index(deviation, cycle_amplitude)
        steady = modulation_index(steady_phase(deviation), cycle_amplitude)
        drift = float(np.ptp(score[0] / per_cycle)) / (2.0 * abs(K)) if abs(K) > 0 else math.nan
        beating = two_mode_flag(modulation, steady, self.options.max_modulation)
        flags = self._flags(win, r, n_cycles, r2, beating, drift, noise_quantum)
        if not (sigma := stats.sigma) < MAX_RELATIVE_SIGMA * period:
            raise Invalid(
                *flags[len(self.flags) :],
                Flag(FlagCode.NO_OSCILLATION, f"the period is not determined: {period:.4g} s ± {sigma:.2g} s"),
            )
        K_ref = K * cmath.exp(s * (first - blocks.center))  # Eq 23's B, C refer to the window's first sample
        fit = PeriodFit(
            period=period,
            period_sigma=sigma,
            zeta=zeta,
            omega=omega,
            A=A * self.scale + self.offset,
            B=float(-K_ref.imag) * self.scale,
            C=float(K_ref.real) * self.scale,
            r2=r2,
            residual_rms=math.sqrt(sse / n) * self.scale,
            n_cycles=n_cycles,
            n_samples=n,
            window=self.window,
            valid=True,
            flags=tuple(flags),
            window_policy=self.options.window,
            t_ref=self.t0 + first,
            period_sigma_white=stats.sigma_white,
            zeta_sigma=stats.zeta_sigma,
            alpha_sigma=stats.alpha_sigma,
            omega_sigma=stats.omega_sigma,
            sigma_dof=stats.dof,
            modulation=steady.depth,
            drift=drift,
            notes=tuple(self.notes),
            mean_period=period,
        )
        units = (self.units, (self.scale, self.offset))
        samples = (win.ys, lambda: self._tau_of(win, blocks))  # (the times only when another model is chosen)
        eq23 = PhaseResidual(deviation, cycle_amplitude, omega_d)
        fit, residual = fit_damping(fit, blocks, sol, samples, units, modulation, self.options, eq23)
        if fit.period_sigma < fit.period_sigma_white:  # (never below Eq 27's, whichever model was chosen)
            fit = replace(fit, period_sigma=fit.period_sigma_white)
        fit = with_end_check(with_stationarity(fit, eq23, residual), residual, fit)
        return with_small_swing_period(fit) if self.options.small_swing_period else fit
