"""Fit of the paper's decaying oscillation (Eq 23) to one trial, with an honest σ of the period.

Stages
------
1. **Clean-up.** Non-finite samples (and samples with non-finite timestamps) are left out and
   flagged. Bad data never raise: they give a result with ``valid=False`` and a flag saying
   why. The fit itself works on block means scaled to about ±1, so any finite input works.
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
   (``scipy.optimize.leastsq``, MINPACK) fits the two nonlinear parameters with the analytic
   (Kaufman) Jacobian of the projected residual; it stops when the sum of squares falls by
   less than 1e-4 of itself, by then the period is within 0.02 σ of the optimum.
5. **Uneven timestamps** (``times`` with jitter or gaps, or samples left out): the block means
   are then only nearly exact, and Gauss–Newton steps on every sample, with the analytic
   Jacobian of all five parameters, finish the fit.
6. **Residuals** of every sample give r², the residual RMS and the sample-level flags
   (:mod:`~bike_rig.core.period.quality`).

For a 30 s trial at 1 kHz this takes about 0.9 ms (``bench/bench_period.py``): a few passes
over the samples (block sums, the residuals, boolean scans for the flags), everything else on
a few hundred block means.

σ of the period
---------------
The paper's Eq 26–27 (``U = σ_y² H⁻¹``, H = JᵀJ) assume independent residuals. A rate gyro's
bias drifts (a random walk) and its samples are quantised, so the residuals are serially
correlated and Eq 27 is optimistic: for the simulated 12-bit gyro with drift, by a factor of 2
to 10 in σ. It is still reported (``period_sigma_white``), but ``period_sigma`` is a sandwich
(autocorrelation-consistent, batch-means) estimate:

``Var(omega_d) = Σ_c (Σ_{i in cycle c} h_i r_i)²``, ``h = gᵀJ`` the influence of each sample on
``omega_d = ω sqrt(1 − ζ²)`` (g the omega_d row of H⁻¹), r the residuals, c over whole cycles.

Within a whole cycle slow drift integrates to almost nothing against the oscillating influence,
so what the per-cycle sums measure is the residual power near the oscillation frequency — the
power that moves the period — whatever its spectrum. Two corrections make it honest:

* the residuals are smaller than the noise by the fit's leverage: the estimate is divided by
  its own expectation under white noise relative to the truth,
  ``1 − Σ_c v_cᵀ H⁻¹ v_c / |h|²`` (``v_c = Σ_{i in c} J_i h_i``);
* with few cycles the estimate is itself uncertain: σ is multiplied by the Student-t factor
  ``t_ν(0.8413)`` for its effective degrees of freedom ν (Satterthwaite, from the per-cycle
  weights), so that ±σ still covers the truth 68 % of the time (GUM Annex G).

Whole cycles matter: with a partial last cycle slow drift leaks into the sums. The statistics
use the block means (the influence hardly varies inside a block). T = 2π / omega_d (Eq 25), so
``σ_T = 2π σ(omega_d) / omega_d²``; ζ and ω get their σ from the same sandwich for
(ζω, omega_d) and the exact Jacobian of the map. ``test/core/test_period_sigma.py`` checks the
coverage of ±σ on simulated trials with white noise, a random-walk drift and 12-bit
quantisation.
"""

from __future__ import annotations

import cmath
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import leastsq
from scipy.special import stdtrit

from .oscillation import TWO_PI, damped_cosine, damped_cosine_even, zeta_omega
from .quality import beating_flag, clipping_flag, drift_flag, held_flag, modulation_index, noise_and_quantum
from .result import Flag, FlagCode, PeriodFit
from .spectrum import MAX_SPECTRUM_POINTS, block_sums, block_times, peak_of_blocks
from .window import DEFAULT_WINDOW, WindowPolicy, first_at_or_after, select_window, select_window_even

__all__ = ["FitOptions", "fit_period"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

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
#: A relative σ of the period above this means the oscillation is not determined.
MAX_RELATIVE_SIGMA = 0.05
#: Why MINPACK's Levenberg–Marquardt stopped without converging.
_LEASTSQ_STOPS = {
    5: "too many function evaluations",
    6: "no further reduction of the sum of squares possible",
    7: "no further improvement of the parameters possible",
    8: "the residuals are orthogonal to the Jacobian",
}
#: One-sided normal quantile of a ±1σ interval: Φ(1).
_PHI1 = 0.8413447460685429


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
    """

    window: WindowPolicy = DEFAULT_WINDOW
    min_cycles: float = 4.0
    min_r2: float = 0.9
    max_modulation: float = 0.02
    max_drift: float = 0.5


class _Invalid(Exception):
    """Internal: the trial has no period; carries the flags that say why."""

    def __init__(self, *flags: Flag):
        super().__init__()
        self.flags = flags


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
    options = FitOptions(window, min_cycles, min_r2, max_modulation, max_drift)
    with np.errstate(all="ignore"):
        return _Fitter(options).run(samples, rate, times)


def _as_series(values: ArrayLike, what: str) -> FloatArray:
    """``values`` as a contiguous 1-D float64 array, or an invalid result saying why not."""
    try:
        array = np.asarray(values)
    except (TypeError, ValueError) as exc:  # ragged nested sequences
        raise _Invalid(Flag(FlagCode.EMPTY, f"the {what} are not an array of numbers ({exc})")) from None
    if array.dtype.kind not in "biuf":
        raise _Invalid(Flag(FlagCode.EMPTY, f"the {what} are not real numbers (dtype {array.dtype})"))
    array = np.squeeze(array)
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1:
        raise _Invalid(Flag(FlagCode.EMPTY, f"the {what} must be one series, got shape {np.shape(values)}"))
    return np.ascontiguousarray(array, dtype=np.float64)


def _inverse3(a: float, b: float, c: float, d: float, e: float, f: float) -> tuple[tuple[float, float, float], ...]:
    """Inverse of the symmetric 3 × 3 matrix [[a, b, c], [b, d, e], [c, e, f]] (cofactors, in
    plain floats: far cheaper than LAPACK for one tiny matrix). Raises LinAlgError if singular."""
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    det = a * c00 + b * c01 + c * c02
    if not abs(det) > 1e-300:
        raise np.linalg.LinAlgError("singular normal equations")
    c11, c12, c22 = (a * f - c * c) / det, (b * c - a * e) / det, (a * d - b * b) / det
    c00, c01, c02 = c00 / det, c01 / det, c02 / det
    return (c00, c01, c02), (c01, c11, c12), (c02, c12, c22)


def _block_phasors(s: complex, tau: FloatArray, step: float, k: int, k_last: int, even: bool) -> ComplexArray:
    """Means of ``exp(s t)`` over blocks of k samples (the last of k_last) centred at ``tau``:
    ``g_k(s) exp(s τ)``, exact for evenly spaced samples (``even``; ``step`` the interval). Then
    the blocks of equal length are evenly spaced too, and the phasors come from short tables and
    one outer product when there are many."""
    n = tau.size
    gain = _gain(s, k, step)
    if even and n >= 64:
        m = int(math.isqrt(n - 1)) + 1
        spacing = k * step
        fine = np.exp((s * spacing) * np.arange(m))
        coarse = np.exp(s * (tau[0] + (spacing * m) * np.arange(-(-n // m))))
        coarse *= gain
        z = np.multiply.outer(coarse, fine).ravel()[:n]
        z[-1] = cmath.exp(s * tau[-1]) * _gain(s, k_last, step)  # the last block: its own centre and length
        return z
    z = np.exp(s * tau)
    z *= gain
    if k_last != k:
        z[-1] *= _gain(s, k_last, step) / gain
    return z


def _gain(s: complex, k: int, step: float) -> complex:
    x = s * step
    if k <= 1 or abs(x) < 1e-12:
        return 1.0 + 0j
    return cmath.sinh(k * x / 2) / (k * cmath.sinh(x / 2))


@dataclass
class _Solution:
    """The fit in the scaled units, t from the window centre."""

    alpha: float  # ζω [1/s]
    omega_d: float  # ω sqrt(1 − ζ²) [rad/s]
    A: float
    K: complex  # C − iB at the centre time


class _Fitter:
    """One fit: holds the options, the flags and notes gathered on the way."""

    def __init__(self, options: FitOptions):
        self.options = options
        self.flags: list[Flag] = []
        self.notes: list[str] = []
        self.window: tuple[int, int] = (0, 0)
        self.n_used = 0
        self.t0 = 0.0  # time of the first finite sample, on the caller's axis [s]
        self.extremes = (-1.0, 1.0)  # the window's smallest and largest scaled samples

    def run(self, samples: ArrayLike, rate: float | None, times: ArrayLike | None) -> PeriodFit:
        try:
            return self._run(samples, rate, times)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            # degenerate data (e.g. times spanning 1e300 s) that slipped past the checks
            failure = _Invalid(Flag(FlagCode.FIT_FAILED, f"numerical failure on these data ({exc})"))
            return self._invalid(failure)
        except _Invalid as exc:
            return self._invalid(exc)

    def _invalid(self, exc: _Invalid) -> PeriodFit:
        return PeriodFit.invalid(
            tuple(self.flags) + exc.flags,
            self.options.window,
            window=self.window,
            n_samples=self.n_used,
            notes=tuple(self.notes),
        )

    # ------------------------------------------------------------------ driver
    def _run(self, samples: ArrayLike, rate: float | None, times: ArrayLike | None) -> PeriodFit:
        t, y, index, even = self._clean(samples, rate, times)
        if even is not None:  # samples k · even [s]: their times are never materialised
            start, stop = select_window_even(even, y, self.options.window)
        else:
            assert t is not None
            start, stop = select_window(t, y, self.options.window)
        self._set_window(index, start, stop)
        if stop - start < MIN_SAMPLES:
            raise _Invalid(
                Flag(FlagCode.EMPTY, f"{stop - start} samples in the window ({self.options.window.describe()})")
            )
        tw = None if t is None else t[start:stop]
        if tw is None:
            assert even is not None
            first, last = start * even, (stop - 1) * even
        else:
            first, last = float(tw[0]), float(tw[-1])
        yw = y[start:stop]
        lo, hi = float(np.min(yw)), float(np.max(yw))
        if hi == lo:
            raise _Invalid(Flag(FlagCode.CONSTANT, f"all {yw.size} samples in the window equal {lo:.6g}"))
        # The fit works on the block means scaled to about ±1 (any finite input); the samples
        # themselves are only scaled when squares of them could overflow.
        offset = 0.5 * lo + 0.5 * hi
        scale = 0.5 * hi - 0.5 * lo
        if not scale > np.finfo(float).tiny:
            raise _Invalid(Flag(FlagCode.CONSTANT, f"the samples vary by only {2 * scale:.3g}"))
        self.scale, self.offset = scale, offset
        if max(abs(lo), abs(hi)) < 1e150 and scale > 1e-150:
            ys, self.units = yw, (scale, offset)  # samples in their own units
            self.extremes = (lo, hi)
        else:
            ys = yw / scale - offset / scale
            self.units = (1.0, 0.0)
            self.extremes = (lo / scale - offset / scale, hi / scale - offset / scale)  # as ys holds them
        n = ys.size
        step = even if even is not None else (last - first) / (n - 1)  # the (mean) sample interval

        # block sums, for the spectrum and (grouped) for the fit
        k_spec = max(1, math.ceil(n / MAX_SPECTRUM_POINTS))
        sums, sizes = block_sums(ys, k_spec)
        spec_times = block_times(tw, k_spec, sizes, even, first)
        peak = peak_of_blocks(spec_times, sums / sizes, last - first, even=even is not None)
        if peak is None or not peak.prominence >= MIN_PROMINENCE:
            what = "none" if peak is None else f"the highest has prominence {peak.prominence:.1f} < {MIN_PROMINENCE:g}"
            raise _Invalid(Flag(FlagCode.NO_OSCILLATION, f"no oscillation stands out of the noise ({what})"))
        guess_cycles = (n * step) * peak.omega / TWO_PI
        if guess_cycles < MIN_VALID_CYCLES - CYCLE_TOLERANCE:
            raise _Invalid(self._too_few(guess_cycles, TWO_PI / peak.omega))
        keep = n
        if self.options.window.whole_cycles:
            # (a window within 5 % of a cycle of the next whole number is kept whole)
            whole = math.floor(guess_cycles + CYCLE_TOLERANCE)
            end = first + (whole * TWO_PI / peak.omega - 0.5 * step)
            if tw is None:
                assert even is not None
                keep = first_at_or_after(end, even, start + n) - start
            else:
                keep = int(np.searchsorted(tw, end))
            keep = max(0, min(n, keep))
            if keep < n:
                stop = start + keep
                self._set_window(index, start, stop)
                if keep < MIN_SAMPLES:
                    raise _Invalid(Flag(FlagCode.EMPTY, f"{keep} samples in {whole} whole cycles"))
                ys = ys[:keep]
                if tw is not None:
                    tw = tw[:keep]
                n = keep
                last = (stop - 1) * even if even is not None else float(tw[-1])  # type: ignore[index]
                step = even if even is not None else (last - first) / (n - 1)

        # blocks of about 1/BLOCKS_PER_CYCLE cycle: whole groups of the spectrum's blocks
        k = max(1, int(round(TWO_PI / peak.omega / BLOCKS_PER_CYCLE / step)))
        group = k // k_spec
        if group >= 1 and even is not None:
            k = group * k_spec
            full = n // k  # blocks of k samples, then one shorter block
            grouped = np.add.reduceat(sums[: full * group], np.arange(0, full * group, group)) if full else sums[:0]
            if n > full * k:
                grouped = np.append(grouped, np.sum(ys[full * k : n]))
            counts = np.full(grouped.size, float(k))
            counts[-1] = n - k * (grouped.size - 1)
            tb = block_times(None, k, counts, even, first)
            yb = grouped / counts
        else:
            sums_k, counts = block_sums(ys, k)
            tb = block_times(tw, k, counts, even, first)
            yb = sums_k / counts
        units_scale, units_offset = self.units
        yb = (yb - units_offset) / units_scale  # about ±1
        center = 0.5 * (first + last)
        sol = self._varpro(tb - center, yb, counts, step, peak.omega, n * step, even is not None)
        if tw is not None and even is None:
            sol = self._gauss_newton(tw - center, ys, sol, n * step)
        return self._result(tw, first, ys, tb, yb, counts, k, center, step, even is not None, sol)

    # ------------------------------------------------------------------ clean-up
    def _clean(
        self, samples: ArrayLike, rate: float | None, times: ArrayLike | None
    ) -> tuple[FloatArray | None, FloatArray, NDArray[np.intp] | None, float | None]:
        """Finite samples; their times from the first one, or None with their even spacing [s]
        (given a rate and no sample left out); their positions in the input (None: all)."""
        y = _as_series(samples, "samples")
        n = y.size
        if n == 0:
            raise _Invalid(Flag(FlagCode.EMPTY, "no samples"))
        t: FloatArray | None = None
        if rate is None:
            assert times is not None
            t = _as_series(times, "timestamps")
            if t.size != n:
                raise _Invalid(Flag(FlagCode.BAD_TIMES, f"{t.size} timestamps for {n} samples"))
        # (a finite sum means finite samples; only otherwise are they checked one by one)
        finite = None if math.isfinite(float(np.sum(y))) else np.isfinite(y)
        if t is not None:
            finite = np.isfinite(t) if finite is None else finite & np.isfinite(t)
        index = None
        if finite is not None and not np.all(finite):
            n_finite = int(np.count_nonzero(finite))
            if n_finite == 0:
                raise _Invalid(Flag(FlagCode.NON_FINITE, f"all {n} samples (or their times) are NaN or infinite"))
            bad = np.flatnonzero(~finite)
            self.flags.append(
                Flag(
                    FlagCode.NON_FINITE,
                    f"{bad.size} of {n} samples are NaN/infinite (first at index {bad[0]}); they were left out",
                )
            )
            index = np.flatnonzero(finite)
            y = y[finite]
            if t is None:
                assert rate is not None
                t = index.astype(float) * (1.0 / rate)
            else:
                t = t[finite]
        if t is None:
            assert rate is not None
            even = 1.0 / rate
            if not math.isfinite(n * even):
                raise _Invalid(Flag(FlagCode.BAD_TIMES, "the times span more than the floating-point range"))
            return None, y, None, even
        if rate is None and t.size > 1:  # (given times: they must increase)
            dt = np.diff(t)
            if not np.all(dt > 0):
                first = int(np.flatnonzero(~(dt > 0))[0]) + 1
                where = first if index is None else int(index[first])
                raise _Invalid(Flag(FlagCode.BAD_TIMES, f"the timestamps do not increase at sample {where}"))
            typical = float(np.median(dt))
            gaps = np.flatnonzero(dt > 3.0 * typical)
            if gaps.size:
                longest = float(np.max(dt[gaps]))
                self.notes.append(f"{gaps.size} gaps in the timestamps (longest {longest:.3g} s), fitted as they are")
        self.t0 = float(t[0])
        if self.t0 != 0.0:
            t = t - t[0]
        if not math.isfinite(float(t[-1])):
            raise _Invalid(Flag(FlagCode.BAD_TIMES, "the times span more than the floating-point range"))
        return t, y, index, None

    def _set_window(self, index: NDArray[np.intp] | None, start: int, stop: int) -> None:
        """Record the window as indices into the input samples."""
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

    @staticmethod
    def _too_few(n_cycles: float, period: float) -> Flag:
        return Flag(
            FlagCode.TOO_FEW_CYCLES,
            f"{n_cycles:.2f} cycles of {period:.4g} s in the window, at least {MIN_VALID_CYCLES:g} are needed: "
            "record longer (or shorten the lead-in)",
        )

    # ------------------------------------------------------------------ variable projection
    def _varpro(
        self,
        tau: FloatArray,
        yb: FloatArray,
        counts: FloatArray,
        step: float,
        omega0: float,
        duration: float,
        even: bool = True,
    ) -> _Solution:
        """Levenberg–Marquardt on the block means for (ζω, omega_d); A, B, C by projection."""
        weight = np.sqrt(counts)
        target = yb * weight
        tau_w = tau * weight
        weighted_y = counts * yb
        total, moment = float(np.sum(counts)), float(np.sum(weighted_y))  # Σc, Σc·y
        k, k_last = int(counts[0]), int(counts[-1])
        cache: dict[bytes, tuple[ComplexArray, FloatArray, tuple[float, float, float], FloatArray]] = {}  # per x

        def solve(x: FloatArray) -> tuple[ComplexArray, FloatArray, tuple[float, float, float], FloatArray]:
            """Block-mean phasors, inverse normal matrix, (A, B, C) and the weighted residual."""
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                s = complex(-x[0], x[1])
                z = _block_phasors(s, tau, step, k, k_last, even)
                # normal equations of the basis (1, Im z, Re z) weighted by the counts c, from
                # Σ c z, Σ c z², Σ c |z|² and Σ c y z
                cz = counts * z
                s1, s2 = complex(np.dot(counts, z)), complex(np.dot(cz, z))
                p, y1 = float(np.vdot(z, cz).real), complex(np.dot(weighted_y, z))
                inverse = _inverse3(total, s1.imag, s1.real, 0.5 * (p - s2.real), 0.5 * s2.imag, 0.5 * (p + s2.real))
                (i00, i01, i02), (_, i11, i12), (_, _, i22) = inverse
                coef = (
                    i00 * moment + i01 * y1.imag + i02 * y1.real,
                    i01 * moment + i11 * y1.imag + i12 * y1.real,
                    i02 * moment + i12 * y1.imag + i22 * y1.real,
                )
                fitted = (complex(coef[2], -coef[1]) * z).real
                fitted += coef[0]
                fitted *= weight
                cache[key] = (z, np.array(inverse), coef, np.subtract(target, fitted, out=fitted))
            return cache[key]

        def residual(x: FloatArray) -> FloatArray:
            return solve(x)[3]

        jacobians: dict[bytes, FloatArray] = {}

        def jacobian(x: FloatArray) -> FloatArray:
            """Kaufman's Jacobian of the projected residual, −P⊥ ∂f/∂(ζω, omega_d), by rows."""
            key = x.tobytes()
            if key not in jacobians:
                jacobians.clear()
                jacobians[key] = _kaufman(*solve(x)[:3])
            return jacobians[key]

        def _kaufman(z: ComplexArray, inverse: FloatArray, coef: tuple[float, float, float]) -> FloatArray:
            kz = complex(coef[2], -coef[1]) * z
            d = np.empty((2, tau.size))  # −∂f/∂(ζω), −∂f/∂omega_d
            np.multiply(tau_w, kz.real, out=d[0])
            np.multiply(tau_w, kz.imag, out=d[1])
            basis = np.empty((3, tau.size))  # the weighted basis (1, Im z, Re z)
            basis[0] = weight
            np.multiply(z.imag, weight, out=basis[1])
            np.multiply(z.real, weight, out=basis[2])
            return d - ((d @ basis.T) @ inverse) @ basis

        try:
            with warnings.catch_warnings():  # a fit that stops short is reported below, not warned about
                warnings.simplefilter("ignore", RuntimeWarning)
                x, status = leastsq(
                    residual, np.array([0.0, omega0]), Dfun=jacobian, col_deriv=True, xtol=1e-10, ftol=1e-4
                )
            coef = np.array(solve(x)[2])
        except (ValueError, TypeError, np.linalg.LinAlgError) as exc:
            raise _Invalid(Flag(FlagCode.FIT_FAILED, f"the least-squares fit failed ({exc})")) from None
        alpha, omega_d = float(x[0]), float(x[1])
        K = complex(coef[2], -coef[1])
        if omega_d < 0:  # the same curve, with the sine's sign flipped
            omega_d, K = -omega_d, K.conjugate()
        if not (
            status in (1, 2, 3, 4)
            and math.isfinite(alpha)
            and omega_d > 0
            and abs(alpha) * duration < 30.0
            and np.all(np.isfinite(coef))
        ):
            why = _LEASTSQ_STOPS.get(int(status), f"MINPACK status {status}")
            raise _Invalid(Flag(FlagCode.FIT_FAILED, f"the fit did not converge to an oscillation ({why})"))
        return _Solution(alpha, omega_d, float(coef[0]), K)

    # ------------------------------------------------------------------ uneven timing
    def _gauss_newton(self, tau: FloatArray, y: FloatArray, sol: _Solution, duration: float) -> _Solution:
        """Gauss–Newton on every sample with the analytic Jacobian of (A, B, C, ζω, omega_d).

        ``y`` is in ``self.units``; the solution in and out refers to the scaled samples.
        """
        units_scale, units_offset = self.units
        alpha, omega_d = sol.alpha, sol.omega_d
        A, K = units_offset + units_scale * sol.A, units_scale * sol.K
        J = np.empty((5, tau.size))
        J[0] = 1.0
        for _ in range(8):
            z = np.exp(complex(-alpha, omega_d) * tau)
            kz = K * z
            J[1] = z.imag
            J[2] = z.real
            np.multiply(tau, kz.real, out=J[3])
            np.multiply(tau, kz.imag, out=J[4])
            J[3:] *= -1.0
            r = y - A - kz.real
            M = np.einsum("in,jn->ij", J, J)
            d = np.sqrt(np.diag(M))
            try:
                delta = (np.linalg.solve(M / np.outer(d, d), np.einsum("in,n->i", J, r) / d)) / d
            except np.linalg.LinAlgError:
                raise _Invalid(Flag(FlagCode.FIT_FAILED, "the Gauss–Newton refinement is singular")) from None
            A += float(delta[0])
            K += complex(delta[2], -delta[1])
            alpha += float(delta[3])
            omega_d += float(delta[4])
            # converged when the step changes the phase by ≪ 0.01 rad over the window
            if not max(abs(delta[3]), abs(delta[4])) * duration > 1e-3:
                break
        if not (math.isfinite(omega_d) and omega_d > 0 and math.isfinite(alpha) and abs(alpha) * duration < 30.0):
            raise _Invalid(Flag(FlagCode.FIT_FAILED, "the Gauss–Newton refinement diverged"))
        return _Solution(alpha, omega_d, (A - units_offset) / units_scale, K / units_scale)

    # ------------------------------------------------------------------ statistics and flags
    def _result(
        self,
        t: FloatArray | None,
        first: float,
        y: FloatArray,
        tb: FloatArray,
        yb: FloatArray,
        counts: FloatArray,
        k: int,
        center: float,
        step: float,
        uniform: bool,
        sol: _Solution,
    ) -> PeriodFit:
        """The statistics and flags of the fit. ``t``: the window's times (None when evenly
        spaced by ``step`` from ``first``)."""
        n = y.size
        alpha, omega_d, A, K = sol.alpha, sol.omega_d, sol.A, sol.K
        s = complex(-alpha, omega_d)
        duration = n * step
        n_cycles = duration * omega_d / TWO_PI
        if n_cycles < MIN_VALID_CYCLES - CYCLE_TOLERANCE:
            raise _Invalid(self._too_few(n_cycles, TWO_PI / omega_d))

        # residuals of every sample, in the units of y
        units_scale, units_offset = self.units
        if uniform or t is None:
            r = damped_cosine_even(first - center, step, n, s, -units_scale * K, -(units_offset + units_scale * A))
        else:
            r = damped_cosine(t - center, s, -units_scale * K)
            r -= units_offset + units_scale * A
        r += y
        # (long dot products stay out of BLAS: its thread pool stalls for ms on a busy machine)
        sse = float(np.einsum("i,i->", r, r)) / units_scale**2  # in the scaled units
        if not math.isfinite(sse):
            raise _Invalid(Flag(FlagCode.FIT_FAILED, "the fitted curve overflows"))
        sst = self._sst(y, float(np.dot(yb, counts)) / n)
        r2 = 1.0 - sse / sst if sst > 0 else math.nan
        s2 = sse / max(1, n - 5)  # Eq 26

        # the design on the block means: per-block Jacobian of the block-mean model
        tau_b = tb - center
        e = _block_phasors(s, tau_b, step, int(counts[0]), int(counts[-1]), uniform)
        ke = K * e
        if uniform:  # residual sum per block (scaled): the block-mean model is exact
            rb = yb - A
            rb -= ke.real
            rb *= counts
        else:
            rb = np.add.reduceat(r, np.arange(0, n, k))
            rb *= 1.0 / units_scale
        nb = tb.size
        Jb = np.empty((5, nb))
        Jb[0] = 1.0
        Jb[1] = e.imag
        Jb[2] = e.real
        np.multiply(tau_b, ke.real, out=Jb[3])
        np.multiply(tau_b, ke.imag, out=Jb[4])
        Jb[3:] *= -1.0
        Jc = Jb * counts
        M = Jc @ Jb.T  # H of Eq 27 (JᵀJ), from the blocks
        try:
            G = np.asarray(np.linalg.inv(M), dtype=float)
        except np.linalg.LinAlgError:
            raise _Invalid(Flag(FlagCode.FIT_FAILED, "the fit's Hessian is singular")) from None
        period = TWO_PI / omega_d  # Eq 25
        dT = TWO_PI / omega_d**2
        sigma_white = dT * math.sqrt(max(0.0, s2 * float(G[4, 4])))  # Eq 27

        # per whole cycle (in blocks), in one pass: Σ J_i r_i (the score), Σ J_i h_i and Σ h_i²
        # (h: each sample's influence on omega_d), samples, Σ |exp(s τ)|²
        n_blocks = max(1, int(math.floor(n_cycles + 0.25)))
        cycle_of = ((tb - first) * (omega_d / TWO_PI)).astype(np.intp)
        np.minimum(cycle_of, n_blocks - 1, out=cycle_of)
        cycle_starts = np.searchsorted(cycle_of, np.arange(n_blocks))
        cycle_starts = cycle_starts[np.diff(np.append(cycle_starts, nb)) > 0]
        h = G[4] @ Jb
        rows = np.empty((13, nb))
        np.multiply(Jb, rb, out=rows[:5])
        np.multiply(Jc, h, out=rows[5:10])
        np.multiply(counts, h * h, out=rows[10])
        rows[11] = counts
        np.multiply(counts, e.real**2 + e.imag**2, out=rows[12])
        per_cycle_sums = np.add.reduceat(rows, cycle_starts, axis=1)
        score = per_cycle_sums[:5]
        cov2, dof = _sandwich(G, score, per_cycle_sums[5:10], per_cycle_sums[10])
        if cov2 is None:
            cov2, dof = s2 * G[3:, 3:], float(n - 5)
            self.notes.append("too few cycles for the drift-robust σ: σ from Eq 27 (white residuals)")
        factor = float(stdtrit(dof, _PHI1)) if dof < 1e6 else 1.0
        sigma = dT * math.sqrt(max(0.0, float(cov2[1, 1]))) * factor
        zeta, omega = zeta_omega(alpha, omega_d)
        jac = np.array([[omega_d**2 / omega**3, -alpha * omega_d / omega**3], [alpha / omega, omega_d / omega]])
        zw_cov = jac @ cov2 @ jac.T * factor**2

        # beating and drift statistics, per cycle
        per_cycle, power = per_cycle_sums[11], per_cycle_sums[12]
        cycle_amplitude = abs(K) * np.sqrt(power / per_cycle)
        # per cycle: the residual's least-squares complex amplitude at the fitted frequency
        deviation = (score[2] - 1j * score[1]) * (2.0 / K) * (cycle_amplitude / power)
        modulation = modulation_index(deviation, cycle_amplitude)
        drift = float(np.ptp(score[0] / per_cycle)) / (2.0 * abs(K)) if abs(K) > 0 else math.nan

        flags = list(self.flags)
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
        noise, quantum = noise_and_quantum(y, r)  # (in the units of y)
        new += [
            beating_flag(modulation, self.options.max_modulation),
            clipping_flag(y, r, noise, quantum, self.extremes, self._sample_units()),
            held_flag(y, r, noise, quantum, self.extremes, self._time_of(t, first, step)),
            drift_flag(drift, self.options.max_drift),
        ]
        flags += [f for f in new if f is not None]
        if not sigma < MAX_RELATIVE_SIGMA * period:
            raise _Invalid(
                *flags[len(self.flags) :],
                Flag(FlagCode.NO_OSCILLATION, f"the period is not determined: {period:.4g} s ± {sigma:.2g} s"),
            )

        K_ref = K * cmath.exp(s * (first - center))  # Eq 23's B, C refer to the window's first sample
        return PeriodFit(
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
            period_sigma_white=sigma_white,
            zeta_sigma=math.sqrt(max(0.0, float(zw_cov[0, 0]))),
            omega_sigma=math.sqrt(max(0.0, float(zw_cov[1, 1]))),
            sigma_dof=dof,
            modulation=modulation.depth,
            drift=drift,
            notes=tuple(self.notes),
        )


def _sandwich(G: FloatArray, score: FloatArray, v: FloatArray, e: FloatArray) -> tuple[FloatArray | None, float]:
    """Covariance of (ζω, omega_d) from the per-cycle score sums, and its degrees of freedom.

    Args:
        G: H⁻¹ (5 × 5).
        score: Σ J_i r_i per cycle, 5 × cycles.
        v: Σ J_i h_i per cycle (h the influence of each sample on omega_d), 5 × cycles.
        e: Σ h_i² per cycle.

    Returns:
        The 2 × 2 covariance and ν, or (None, 0) with fewer than two cycles.
    """
    if score.shape[1] < 2:
        return None, 0.0
    rows = G[3:] @ score  # per-cycle contributions to the (ζω, omega_d) estimates
    cov = rows @ rows.T
    expected = e - np.einsum("ic,ic->c", v, G @ v)  # E[contribution_c²] / σ² under white noise
    total = float(np.sum(expected))
    e_total = float(np.sum(e))
    if not total > 0.05 * e_total:
        return None, 0.0
    dof = total**2 / float(np.dot(expected, expected))
    return cov * (e_total / total), max(1.0, dof)
