"""Fit of the paper's decaying oscillation (Eq 23) to one trial, with an honest σ of the period.

Stages
------
1. **Clean-up.** Non-finite samples (and samples with non-finite timestamps) are left out and
   flagged; the window's samples are scaled to about ±1. Bad data never raise: they give a
   result with ``valid=False`` and a flag saying why.
2. **Window** (:mod:`~bike_rig.core.period.window`): the policy's samples.
3. **Initial guess** (:mod:`~bike_rig.core.period.spectrum`): the highest peak of the
   spectrum; a peak that does not stand out of its surroundings means there is no oscillation.
   Unless the policy says otherwise, the window is then cut at its end to a whole number of
   cycles of the guessed period.
4. **Variable projection** on means of blocks of about 1/24 cycle. The mean over a block of k
   evenly spaced samples of ``exp(s t)`` (``s = −ζω + iω sqrt(1 − ζ²)``) is exactly
   ``g_k(s) exp(s t̄)``, ``g_k(s) = sinh(k s Δt/2) / (k sinh(s Δt/2))``, so the block means
   follow Eq 23 with the same ζ, ω, A, B, C: the fit of the block means *is* a least-squares fit
   of Eq 23 to the samples, restricted to the block averages (it gives up the signal inside the
   blocks, < 1 % of the oscillation's information) at a small fraction of the cost. For fixed
   (ζω, ω sqrt(1 − ζ²)) Eq 23 is linear in A, B, C, which are solved for; Levenberg–Marquardt
   (``scipy.optimize.leastsq``, MINPACK) fits the two nonlinear parameters with the analytic
   (Kaufman) Jacobian of the projected residual.
5. **Uneven timestamps** (``times`` with jitter or gaps, or samples left out): the block means
   are then only nearly exact, and Gauss–Newton steps on every sample, with the analytic
   Jacobian of all five parameters, finish the fit.
6. **Residuals** of every sample give r², the residual RMS and the sample-level flags
   (:mod:`~bike_rig.core.period.quality`).

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

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import leastsq
from scipy.special import stdtrit

from .model import TWO_PI, damped_cosine, zeta_omega
from .quality import beating_flag, clipping_flag, drift_flag, held_flag, modulation_index, noise_and_quantum
from .result import Flag, FlagCode, PeriodFit
from .spectrum import block_means, spectral_peak
from .window import DEFAULT_WINDOW, WindowPolicy, select_window

__all__ = ["FitOptions", "fit_period"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Block means per cycle in the variable-projection stage.
BLOCKS_PER_CYCLE = 24
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


def _block_gain(s: complex, counts: FloatArray, step: float) -> ComplexArray:
    """``g_k(s)``: mean of ``exp(s t)`` over k evenly spaced samples over its centre value."""
    x = s * step
    if abs(x) < 1e-12:
        return np.ones(counts.size, dtype=complex)
    return np.sinh(counts * (x / 2)) / (counts * np.sinh(x / 2))


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
        t, y, index, uniform = self._clean(samples, rate, times)
        start, stop = select_window(t, y, self.options.window)
        self._set_window(index, start, stop)
        if stop - start < MIN_SAMPLES:
            raise _Invalid(
                Flag(FlagCode.EMPTY, f"{stop - start} samples in the window ({self.options.window.describe()})")
            )
        tw = t[start:stop]
        yw = y[start:stop]
        lo, hi = float(np.min(yw)), float(np.max(yw))
        if hi == lo:
            raise _Invalid(Flag(FlagCode.CONSTANT, f"all {yw.size} samples in the window equal {lo:.6g}"))
        # scale to about ±1 (any finite input, even near the float limits)
        offset = 0.5 * lo + 0.5 * hi
        scale = 0.5 * hi - 0.5 * lo
        if not scale > np.finfo(float).tiny:
            raise _Invalid(Flag(FlagCode.CONSTANT, f"the samples vary by only {2 * scale:.3g}"))
        ys = (yw - offset) / scale if math.isfinite(hi - lo) else yw / scale - offset / scale
        self.scale, self.offset = scale, offset
        step = float(tw[-1] - tw[0]) / (tw.size - 1)  # the sample interval (mean, if uneven)

        peak = spectral_peak(tw, ys, even=uniform)
        if peak is None or not peak.prominence >= MIN_PROMINENCE:
            what = "none" if peak is None else f"the highest has prominence {peak.prominence:.1f} < {MIN_PROMINENCE:g}"
            raise _Invalid(Flag(FlagCode.NO_OSCILLATION, f"no oscillation stands out of the noise ({what})"))
        guess_cycles = (tw.size * step) * peak.omega / TWO_PI
        if guess_cycles < MIN_VALID_CYCLES - CYCLE_TOLERANCE:
            raise _Invalid(self._too_few(guess_cycles, TWO_PI / peak.omega))
        if self.options.window.whole_cycles:
            # (a window within 5 % of a cycle of the next whole number is kept whole)
            whole = math.floor(guess_cycles + CYCLE_TOLERANCE)
            keep = int(np.searchsorted(tw, tw[0] + (whole * TWO_PI / peak.omega - 0.5 * step)))
            if keep < tw.size:
                stop = start + keep
                self._set_window(index, start, stop)
                if keep < MIN_SAMPLES:
                    raise _Invalid(Flag(FlagCode.EMPTY, f"{keep} samples in {whole} whole cycles"))
                tw, ys = tw[:keep], ys[:keep]
                step = float(tw[-1] - tw[0]) / (tw.size - 1)

        k = max(1, int(round(TWO_PI / peak.omega / BLOCKS_PER_CYCLE / step)))
        tb, yb, counts = block_means(tw, ys, k, step if uniform else None)
        center = 0.5 * float(tw[0] + tw[-1])
        sol = self._varpro(tb - center, yb, counts, step, peak.omega, tw.size * step)
        if not uniform:
            sol = self._gauss_newton(tw - center, ys, sol, tw.size * step)
        return self._result(tw, ys, tb, counts, k, center, step, uniform, sol)

    # ------------------------------------------------------------------ clean-up
    def _clean(
        self, samples: ArrayLike, rate: float | None, times: ArrayLike | None
    ) -> tuple[FloatArray, FloatArray, NDArray[np.intp] | None, bool]:
        """Finite samples, their times from the first one, original positions, evenly spaced."""
        y = _as_series(samples, "samples")
        n = y.size
        if n == 0:
            raise _Invalid(Flag(FlagCode.EMPTY, "no samples"))
        if rate is not None:
            t = np.arange(n) / rate
        else:
            assert times is not None
            t = _as_series(times, "timestamps")
            if t.size != n:
                raise _Invalid(Flag(FlagCode.BAD_TIMES, f"{t.size} timestamps for {n} samples"))
        uniform = rate is not None
        finite = np.isfinite(y) & np.isfinite(t)
        n_finite = int(np.count_nonzero(finite))
        index = None
        if n_finite < n:
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
            y, t = y[finite], t[finite]
            uniform = False
        if rate is None and t.size > 1:
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
        t = t - t[0]
        if not math.isfinite(float(t[-1])):
            raise _Invalid(Flag(FlagCode.BAD_TIMES, "the times span more than the floating-point range"))
        return t, y, index, uniform

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

    @staticmethod
    def _too_few(n_cycles: float, period: float) -> Flag:
        return Flag(
            FlagCode.TOO_FEW_CYCLES,
            f"{n_cycles:.2f} cycles of {period:.4g} s in the window, at least {MIN_VALID_CYCLES:g} are needed: "
            "record longer (or shorten the lead-in)",
        )

    # ------------------------------------------------------------------ variable projection
    def _varpro(
        self, tau: FloatArray, yb: FloatArray, counts: FloatArray, step: float, omega0: float, duration: float
    ) -> _Solution:
        """Levenberg–Marquardt on the block means for (ζω, omega_d); A, B, C by projection."""
        weight = np.sqrt(counts)
        target = yb * weight
        cache: dict[bytes, tuple[ComplexArray, FloatArray, FloatArray, FloatArray, FloatArray]] = {}

        def solve(x: FloatArray) -> tuple[ComplexArray, FloatArray, FloatArray, FloatArray, FloatArray]:
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                s = complex(-x[0], x[1])
                z = _block_gain(s, counts, step) * np.exp(s * tau)
                basis = np.empty((tau.size, 3))
                basis[:, 0] = weight
                np.multiply(z.imag, weight, out=basis[:, 1])
                np.multiply(z.real, weight, out=basis[:, 2])
                normal = basis.T @ basis
                coef = np.asarray(np.linalg.solve(normal, basis.T @ target), dtype=float)
                cache[key] = (np.asarray(z, dtype=complex), basis, normal, coef, target - basis @ coef)
            return cache[key]

        def residual(x: FloatArray) -> FloatArray:
            return solve(x)[4]

        def jacobian(x: FloatArray) -> FloatArray:
            z, basis, normal, coef, _ = solve(x)
            kz = complex(coef[2], -coef[1]) * z
            d = np.empty((tau.size, 2))
            d[:, 0] = -tau * kz.real * weight  # ∂f/∂(ζω)
            d[:, 1] = -tau * kz.imag * weight  # ∂f/∂omega_d
            return -(d - basis @ np.linalg.solve(normal, basis.T @ d))  # Kaufman: −P⊥ ∂f/∂x

        try:
            x, _, _, message, status = leastsq(
                residual, np.array([0.0, omega0]), Dfun=jacobian, full_output=True, xtol=1e-10
            )
            coef = solve(x)[3]
        except (ValueError, np.linalg.LinAlgError) as exc:
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
            raise _Invalid(Flag(FlagCode.FIT_FAILED, f"the fit did not converge to an oscillation ({message})"))
        return _Solution(alpha, omega_d, float(coef[0]), K)

    # ------------------------------------------------------------------ uneven timing
    def _gauss_newton(self, tau: FloatArray, y: FloatArray, sol: _Solution, duration: float) -> _Solution:
        """Gauss–Newton on every sample with the analytic Jacobian of (A, B, C, ζω, omega_d)."""
        alpha, omega_d, A, K = sol.alpha, sol.omega_d, sol.A, sol.K
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
        return _Solution(alpha, omega_d, A, K)

    # ------------------------------------------------------------------ statistics and flags
    def _result(
        self,
        t: FloatArray,
        y: FloatArray,
        tb: FloatArray,
        counts: FloatArray,
        k: int,
        center: float,
        step: float,
        uniform: bool,
        sol: _Solution,
    ) -> PeriodFit:
        n = t.size
        alpha, omega_d, A, K = sol.alpha, sol.omega_d, sol.A, sol.K
        s = complex(-alpha, omega_d)
        duration = n * step
        n_cycles = duration * omega_d / TWO_PI
        if n_cycles < MIN_VALID_CYCLES - CYCLE_TOLERANCE:
            raise _Invalid(self._too_few(n_cycles, TWO_PI / omega_d))

        # residuals of every sample
        fitted = damped_cosine(t - center, s, K, step if uniform else None)
        fitted += A
        r = y - fitted
        if not np.all(np.isfinite(r)):
            raise _Invalid(Flag(FlagCode.FIT_FAILED, "the fitted curve overflows"))
        # (long dot products stay out of BLAS: its thread pool stalls for ms on a busy machine)
        sse = float(np.einsum("i,i->", r, r))
        sst = float(np.einsum("i,i->", y, y)) - float(np.sum(y)) ** 2 / n
        r2 = 1.0 - sse / sst if sst > 0 else math.nan
        s2 = sse / max(1, n - 5)  # Eq 26

        # the design on the block means: per-block Jacobian of the block-mean model
        starts = np.arange(0, n, k)
        rb = np.add.reduceat(r, starts)  # residual sum per block
        tau_b = tb - center
        e = _block_gain(s, counts, step) * np.exp(s * tau_b)
        ke = K * e
        Jb = np.stack([np.ones(tb.size), e.imag, e.real, -tau_b * ke.real, -tau_b * ke.imag])
        M = (Jb * counts) @ Jb.T  # H of Eq 27 (JᵀJ), from the blocks
        d = np.sqrt(np.diag(M))
        try:
            G = np.linalg.inv(M / np.outer(d, d)) / np.outer(d, d)
        except np.linalg.LinAlgError:
            raise _Invalid(Flag(FlagCode.FIT_FAILED, "the fit's Hessian is singular")) from None
        period = TWO_PI / omega_d  # Eq 25
        dT = TWO_PI / omega_d**2
        sigma_white = dT * math.sqrt(max(0.0, s2 * float(G[4, 4])))  # Eq 27

        # whole cycles of blocks
        n_blocks = max(1, int(math.floor(n_cycles + 0.25)))
        cycle_of = np.minimum(((tb - t[0]) * (omega_d / TWO_PI)).astype(np.intp), n_blocks - 1)
        cycle_starts = np.searchsorted(cycle_of, np.arange(n_blocks))
        cycle_starts = cycle_starts[np.diff(np.append(cycle_starts, tb.size)) > 0]
        score = np.add.reduceat(Jb * rb, cycle_starts, axis=1)  # Σ J_i r_i per cycle, 5 × cycles
        cov2, dof = _sandwich(Jb, counts, G, score, cycle_starts)
        if cov2 is None:
            cov2, dof = s2 * G[3:, 3:], float(n - 5)
            self.notes.append("too few cycles for the drift-robust σ: σ from Eq 27 (white residuals)")
        factor = float(stdtrit(dof, _PHI1)) if dof < 1e6 else 1.0
        sigma = dT * math.sqrt(max(0.0, float(cov2[1, 1]))) * factor
        zeta, omega = zeta_omega(alpha, omega_d)
        jac = np.array([[omega_d**2 / omega**3, -alpha * omega_d / omega**3], [alpha / omega, omega_d / omega]])
        zw_cov = jac @ cov2 @ jac.T * factor**2

        # beating and drift statistics, per cycle
        per_cycle = np.add.reduceat(counts, cycle_starts)
        power = np.add.reduceat(counts * np.abs(e) ** 2, cycle_starts)  # Σ |exp(s τ)|² per cycle
        cycle_amplitude = abs(K) * np.sqrt(power / per_cycle)
        # per cycle: the residual's least-squares complex amplitude at the fitted frequency
        deviation = 2.0 * (score[2] - 1j * score[1]) * (cycle_amplitude / (K * power))
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
        noise, quantum = noise_and_quantum(y, r)
        new += [
            beating_flag(modulation, self.options.max_modulation),
            clipping_flag(y, fitted, noise, quantum, self.scale, self.offset),
            held_flag(y, fitted, noise, quantum, t + self.t0),
            drift_flag(drift, self.options.max_drift),
        ]
        flags += [f for f in new if f is not None]
        if not sigma < MAX_RELATIVE_SIGMA * period:
            raise _Invalid(
                *flags[len(self.flags) :],
                Flag(FlagCode.NO_OSCILLATION, f"the period is not determined: {period:.4g} s ± {sigma:.2g} s"),
            )

        K_ref = K * np.exp(s * (t[0] - center))  # Eq 23's B, C refer to the window's first sample
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
            t_ref=self.t0 + float(t[0]),
            period_sigma_white=sigma_white,
            zeta_sigma=math.sqrt(max(0.0, float(zw_cov[0, 0]))),
            omega_sigma=math.sqrt(max(0.0, float(zw_cov[1, 1]))),
            sigma_dof=dof,
            modulation=modulation.depth,
            drift=drift,
            notes=tuple(self.notes),
        )


def _sandwich(
    Jb: FloatArray, counts: FloatArray, G: FloatArray, score: FloatArray, cycle_starts: NDArray[np.intp]
) -> tuple[FloatArray | None, float]:
    """Covariance of (ζω, omega_d) from the per-cycle score sums, and its degrees of freedom.

    Args:
        Jb: Jacobian of the block-mean model, 5 × blocks.
        counts: Samples per block.
        G: H⁻¹ (5 × 5).
        score: Σ J_i r_i per cycle, 5 × cycles.
        cycle_starts: First block of each cycle.

    Returns:
        The 2 × 2 covariance and ν, or (None, 0) with fewer than two cycles.
    """
    if cycle_starts.size < 2:
        return None, 0.0
    rows = G[3:] @ score  # per-cycle contributions to the (ζω, omega_d) estimates
    cov = rows @ rows.T
    h = G[4] @ Jb  # influence on omega_d of each sample of a block
    v = np.add.reduceat(Jb * (counts * h), cycle_starts, axis=1)  # Σ J_i h_i per cycle
    e = np.add.reduceat(counts * h * h, cycle_starts)  # Σ h_i² per cycle
    expected = e - np.einsum("ic,ij,jc->c", v, G, v)  # E[contribution_c²] / σ² under white noise
    total = float(np.sum(expected))
    if not total > 0.05 * float(np.sum(e)):
        return None, 0.0
    dof = total**2 / float(np.sum(expected**2))
    return cov * (float(np.sum(e)) / total), max(1.0, dof)
