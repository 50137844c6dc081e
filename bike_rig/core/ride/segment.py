"""Automatic segmentation of a long ride record into free decays after perturbations.

A perturbation ("kick") is found in the steer torque when the record has one, else in the
roll rate, confirmed by the wheel speed when the record has one:

* **steer torque**: runs of samples with |T − median T| above ``torque_threshold`` times the
  torque's noise σ (runs closer than ``merge_s`` are one kick); the kick ends when the
  torque is back;
* **roll rate**: with ``z = |y − baseline|`` (baseline: a running median over
  ``10 · window_s``), its largest value over the next ``window_s`` rises above ``threshold``
  noise σ and above ``rise`` times its largest value over the previous ``window_s``: the
  envelope of a free oscillation does not grow that fast within a window (``window_s`` at
  least half the longest weave period), a kick does. The kick's onset is the first sample
  above half-way between the two; it ends at the first peak of ``z`` (smoothed over 50 ms)
  after it. The rider's own motions (starting off, pedalling, turning) pass this test too;
* **wheel speed**: a lateral push jolts the wheel. A roll-rate kick is kept only where the
  wheel speed has a transient within ``speed_window_s`` of its onset
  (:func:`speed_transients`: its residual from a local quadratic, averaged over a push's
  length, beyond ``speed_threshold`` robust σ). Speed changes of riding (starting, braking,
  pedalling) are smooth at that scale.

Each segment starts ``settle_s`` after its kick ends (the fast caster mode dies out) and ends
where the free decay ends (:func:`_free_decay_end`): a decaying sinusoid
``c + e^{σt}(a cos ωt + b sin ωt)`` is fitted to one cycle and grown half a cycle at a time;
it ends where the next cycle's residual holds a weave beyond the noise level (a sequential
test: the rider or the motor took over) or where its envelope falls to ``decay_level``
times the noise level (it no longer stands out of the riding). The noise level is the
riding's roll-rate σ before the kick (``riding_s``, after the last kick's response faded) or
the fit's residual RMS, whichever is larger. The riding is coloured (the weave driven by the
rider's steering, at the decay's own frequency): where that stretch identifies an AR model of
order 1 to ``noise_order`` (:mod:`.whiten`, by BIC, evenly sampled), the decay is fitted by
generalised least squares whitened by it, else by ordinary least squares. Other ends: the
next kick (``gap_s`` before it), the end of the record, ``max_length_s`` (a safety bound, not
the rule). A roll-rate kick not confirmed by the torque or the wheel speed gives a segment
only where its model decays and lasts a cycle or more (else it is the rider's motion:
starting off, a turn), and that segment is flagged ``unconfirmed_kick`` when measured
(:func:`unconfirmed_flag`): never clean.
In the roll rate alone a kick is found only where the oscillation before it has decayed
below 1/``rise`` of the kick's response: record the steer torque where kicks come often. The reasons for
each start and end are recorded. The noise σ is robust: the median absolute deviation of the
second differences (``σ = 1.4826 · MAD(Δ²y) / √6`` for white noise; the weave moves a sample's
second difference by (ω Δt)² of its amplitude, ≈ 0.3 % at 100 Hz).
Units: times s, the signal in its own units (rad/s), torque N m, speed m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .record import RideRecord
from .whiten import NoiseAR, fit_noise_ar

__all__ = [
    "Kick",
    "UNCONFIRMED_KICK",
    "Segment",
    "SegmentOptions",
    "Segmentation",
    "detrend",
    "find_kicks",
    "noise_sigma",
    "segment_record",
    "speed_transients",
    "unconfirmed_flag",
    "why_no_segment",
]

FloatArray = NDArray[np.float64]

#: The flag of a found segment that only the roll rate saw begin (:func:`unconfirmed_flag`).
UNCONFIRMED_KICK = "unconfirmed_kick"
#: The wheel speed's local trend is a quadratic over this long [s].
SPEED_TREND_S = 1.0
#: A push's jolt in the wheel speed lasts about this long [s].
SPEED_PULSE_S = 0.1
#: A stretch is evenly sampled (its noise's AR model holds) where each step is the median one within this share [-].
EVEN_STEP = 0.1


@dataclass(frozen=True)
class SegmentOptions:
    """Segmentation thresholds (module docstring).

    Attributes:
        window_s: Envelope window [s] (at least half the longest weave period).
        threshold: Oscillation level, in noise σ of the signal.
        rise: Growth of the envelope across a window that marks a kick [-].
        torque_threshold: Kick level of the steer torque, in its noise σ.
        merge_s: Torque runs closer than this are one kick [s].
        settle_s: The segment starts this long after its kick ends [s].
        gap_s: The segment ends this long before the next kick [s].
        max_length_s: The longest segment [s] (a safety bound: the free decay's model ends a segment).
        speed_window_s: A wheel-speed transient this close to a roll-rate kick confirms it [s].
        speed_threshold: A wheel-speed transient's level, in the wheel speed's noise σ.
        departure: The mean square of the weave in the next cycle's residual, in the noise level's,
            that ends a free decay [-].
        decay_level: The free decay ends where its envelope falls to this many times the noise level [-].
        riding_s: The riding's roll-rate RMS over this long, ending a quarter ``window_s`` before
            a kick's onset (which lags the push by up to its rise), after the last kick's response
            faded (at least ``window_s`` of it, else the white noise σ), is the noise level's floor [s].
        noise_order: The largest order of the riding's AR model that whitens the decay's fit
            (:mod:`.whiten`; 0: ordinary least squares) [-].
    """

    window_s: float = 1.0
    threshold: float = 8.0
    rise: float = 2.0
    torque_threshold: float = 6.0
    merge_s: float = 0.2
    settle_s: float = 0.2
    gap_s: float = 0.05
    max_length_s: float = 10.0
    speed_window_s: float = 0.3
    speed_threshold: float = 6.0
    departure: float = 4.6
    decay_level: float = 2.0
    riding_s: float = 4.0
    noise_order: int = 12


@dataclass(frozen=True)
class Kick:
    """One perturbation found.

    Attributes:
        onset: Its start [s].
        end: Its end [s] (torque back, or the roll rate's first peak).
        reason: How it was found.
        confirmed: Found in the steer torque or confirmed by the wheel speed (not the roll rate alone).
    """

    onset: float
    end: float
    reason: str
    confirmed: bool = False


@dataclass(frozen=True)
class Segment:
    """One free decay.

    Attributes:
        start: First time [s].
        stop: Last time [s].
        kick: The perturbation before it.
        start_reason: Why it starts there.
        stop_reason: Why it ends there.
    """

    start: float
    stop: float
    kick: Kick
    start_reason: str
    stop_reason: str


@dataclass(frozen=True)
class Segmentation:
    """A record's segmentation (:func:`segment_record`).

    Attributes:
        segments: The free decays, in time order.
        kicks: Every kick found (:func:`find_kicks`), with a segment or without (the rider's own
            motions), in time order.
        detrended: The signal less its baseline (:func:`detrend`), one per sample (units of the signal).
    """

    segments: tuple[Segment, ...]
    kicks: tuple[Kick, ...]
    detrended: FloatArray = field(repr=False, compare=False)


def noise_sigma(y: FloatArray) -> float:
    """Robust white-noise σ of a series: 1.4826 · MAD(Δ²y) / √6 (units of ``y``)."""
    from scipy.stats import median_abs_deviation

    if y.size < 4:
        return math.nan
    d2 = np.diff(y, 2)
    return float(median_abs_deviation(d2, scale="normal") / math.sqrt(6.0))


def _running_max(z: FloatArray, n: int, forward: bool) -> FloatArray:
    """The largest z over the next n samples from i (forward) or the n before i (backward)."""
    from scipy.ndimage import maximum_filter1d

    if forward:  # window [i, i + n)
        return np.asarray(maximum_filter1d(z, size=n, origin=-(n // 2), mode="nearest"), dtype=float)
    out = np.empty_like(z)
    out[0] = 0.0
    out[1:] = maximum_filter1d(z, size=n, origin=n - 1 - n // 2, mode="constant", cval=0.0)[:-1]
    return out


def _torque_kicks(t: FloatArray, torque: FloatArray, opt: SegmentOptions) -> list[Kick]:
    sigma = noise_sigma(torque)
    level = opt.torque_threshold * sigma
    above = np.abs(torque - np.median(torque)) > level
    kicks: list[Kick] = []
    idx = np.flatnonzero(above)
    if not idx.size or not sigma > 0:
        return kicks
    breaks = np.flatnonzero(np.diff(t[idx]) > opt.merge_s)
    for first, last in zip(np.r_[0, breaks + 1], np.r_[breaks, idx.size - 1], strict=True):
        a, b = float(t[idx[first]]), float(t[idx[last]])
        why = f"steer torque beyond {opt.torque_threshold:g}σ = {level:.3g} N m from {a:.2f} to {b:.2f} s"
        kicks.append(Kick(a, b, why, confirmed=True))
    return kicks


def _near(t: FloatArray, times: FloatArray, within: float) -> NDArray[np.bool_]:
    """Whether each of ``t`` lies within ``within`` [s] of one of ``times`` (sorted)."""
    if not times.size:
        return np.zeros(t.size, dtype=bool)
    k = np.clip(np.searchsorted(times, t), 1, times.size - 1) if times.size > 1 else np.zeros(t.size, dtype=int)
    gap = np.minimum(np.abs(t - times[k]), np.abs(t - times[np.maximum(k - 1, 0)]))
    return np.asarray(gap <= within, dtype=bool)


def _signal_kicks(
    t: FloatArray, z: FloatArray, sigma: float, opt: SegmentOptions, only: NDArray[np.bool_] | None = None
) -> list[Kick]:
    """The roll-rate kicks (module docstring); ``only``: where a kick may be found (None: anywhere)."""
    n = max(2, int(round(opt.window_s / float(np.median(np.diff(t))))))
    fwd, bwd = _running_max(z, n, True), _running_max(z, n, False)
    level = opt.threshold * sigma
    kick_at = (fwd > level) & (fwd > opt.rise * bwd)
    if only is not None:
        kick_at &= only
    width = max(1, int(round(0.05 / float(np.median(np.diff(t))))))
    smooth = np.convolve(z, np.ones(width) / width, mode="same")
    kicks: list[Kick] = []
    i = 0
    while True:
        hits = np.flatnonzero(kick_at[i:])
        if not hits.size:
            return kicks
        i += int(hits[0])
        half = 0.5 * (bwd[i] + fwd[i])
        onset = i + int(np.argmax(z[i : i + n] > half))
        ahead = smooth[onset : onset + n // 2 + 1]
        falls = np.flatnonzero(np.diff(ahead) < 0)  # the first peak: where the smoothed z first falls
        peak = onset + (int(falls[0]) if falls.size else int(np.argmax(ahead)))
        kicks.append(
            Kick(
                float(t[onset]),
                float(t[peak]),
                f"roll rate rose {fwd[i] / max(bwd[i], sigma):.1f}× within {opt.window_s:g} s at {t[onset]:.2f} s "
                f"(first peak {t[peak]:.2f} s)",
            )
        )
        i = peak + n  # the next kick: a window after this one's peak at the earliest


def speed_transients(t: FloatArray, speed: FloatArray, opt: SegmentOptions) -> tuple[FloatArray, FloatArray, float]:
    """The wheel speed's transients: times [s], sizes [m/s] and the noise σ of the statistic [m/s].

    The statistic is the speed's residual from its local quadratic (Savitzky–Golay over
    :data:`SPEED_TREND_S`) averaged over :data:`SPEED_PULSE_S` (a push's jolt); a transient is
    where it passes ``speed_threshold`` times its robust σ (1.4826 MAD over the samples where
    the wheel turns: a standing wheel reads a constant).
    """
    from scipy.ndimage import uniform_filter1d
    from scipy.signal import savgol_filter
    from scipy.stats import median_abs_deviation

    good = np.isfinite(speed)
    if good.sum() < 16:
        return np.empty(0), np.empty(0), math.nan
    v = np.interp(t, t[good], speed[good])
    dt = float(np.median(np.diff(t)))
    width = min(max(5, 2 * int(round(SPEED_TREND_S / dt / 2.0)) + 1), v.size - 1 + v.size % 2)
    resid = v - savgol_filter(v, width, 2, mode="interp")
    pulse = np.asarray(uniform_filter1d(resid, max(1, int(round(SPEED_PULSE_S / dt)))), dtype=float)
    turning = np.r_[False, np.diff(v) != 0.0]
    if turning.sum() < 16:
        return np.empty(0), np.empty(0), math.nan
    sigma = float(median_abs_deviation(pulse[turning], scale="normal"))
    if not sigma > 0:
        return np.empty(0), np.empty(0), math.nan
    hits = np.flatnonzero(turning & (np.abs(pulse) > opt.speed_threshold * sigma))
    return t[hits], pulse[hits], sigma


def find_kicks(record: RideRecord, options: SegmentOptions | None = None) -> list[Kick]:
    """The perturbations of a record: from its steer torque if it has one, else its signal.

    Without torque but with a usable wheel speed (one that varies: :func:`speed_transients`
    gives a finite σ), a roll-rate kick is sought only within ``speed_window_s`` of the wheel
    speed's transients (a push).
    """
    opt = options or SegmentOptions()
    return _kicks(record, detrend(record, opt), noise_sigma(record.signal), opt)


def _kicks(record: RideRecord, detrended: FloatArray, sigma: float, opt: SegmentOptions) -> list[Kick]:
    """:func:`find_kicks` with the record's :func:`detrend` and :func:`noise_sigma` of its signal."""
    if record.torque is not None:
        return _torque_kicks(record.times, record.torque, opt)
    z = np.abs(detrended)
    times, sizes, speed_sigma = (
        speed_transients(record.times, record.speed, opt) if record.speed is not None else (None, None, math.nan)
    )
    if times is None or sizes is None or not math.isfinite(speed_sigma):  # no usable wheel speed
        return _signal_kicks(record.times, z, sigma, opt)
    only = _near(record.times, times, opt.speed_window_s)
    confirmed = []
    for kick in _signal_kicks(record.times, z, sigma, opt, only):
        j = int(np.argmin(np.abs(times - kick.onset)))
        why = (
            f"{kick.reason}; wheel speed {sizes[j]:+.2f} m/s off its local trend over {SPEED_PULSE_S:g} s "
            f"({abs(sizes[j]) / speed_sigma:.0f}σ) at {times[j]:.2f} s"
        )
        confirmed.append(Kick(kick.onset, kick.end, why, confirmed=True))
    return confirmed


def detrend(record: RideRecord, options: SegmentOptions | None = None) -> FloatArray:
    """The record's signal less its baseline (:func:`_baseline`) (units of the signal)."""
    return record.signal - _baseline(record.times, record.signal, options or SegmentOptions())


def _baseline(t: FloatArray, y: FloatArray, opt: SegmentOptions) -> FloatArray:
    """The running median of ``y`` over ``10 window_s`` (units of ``y``)."""
    from scipy.ndimage import median_filter

    n = max(3, int(round(10 * opt.window_s / float(np.median(np.diff(t))))))
    return np.asarray(median_filter(y, size=min(n, y.size), mode="nearest"), dtype=float)


def _even(t: FloatArray, step: float | None = None) -> bool:
    """Whether ``t`` is evenly sampled: each step within :data:`EVEN_STEP` of ``step`` (None: the median step) [s]."""
    if t.size < 2:
        return False
    steps = np.diff(t)
    dt = float(np.median(steps)) if step is None else step
    return bool(dt > 0 and np.max(np.abs(steps - dt)) <= EVEN_STEP * dt)


def _decay_model(p: FloatArray, tt: FloatArray) -> FloatArray:
    """``c + e^{σ t} (a cos ω t + b sin ω t)`` for ``p = [c, σ, ω, a, b]`` (units of the signal)."""
    c, sig, w, a, b = p
    return np.asarray(c + np.exp(sig * tt) * (a * np.cos(w * tt) + b * np.sin(w * tt)), dtype=float)


def _fit_decay(tt: FloatArray, y: FloatArray, start: FloatArray, noise: NoiseAR | None = None) -> FloatArray | None:
    """The least-squares ``[c, σ, ω, a, b]`` of :func:`_decay_model` from ``start``, or None (no fit).

    With ``noise`` (the riding's AR model, evenly sampled as ``tt``) the residual is whitened by
    it: generalised least squares.
    """
    from scipy.optimize import least_squares

    def residual(p: FloatArray) -> FloatArray:
        r = _decay_model(p, tt) - y
        return r if noise is None else noise.whiten(r)

    try:
        fit = least_squares(residual, start, method="lm")
    except (ValueError, np.linalg.LinAlgError):
        return None
    return np.asarray(fit.x, dtype=float) if fit.success and np.all(np.isfinite(fit.x)) else None


def _half_period(tt: FloatArray, y: FloatArray, opt: SegmentOptions) -> float | None:
    """Half the period [s] of the strongest oscillation in the first ``2 window_s``, or None.

    From the peak of the Hann-windowed periodogram, zero-padded 8×, periods up to ``2 window_s``
    (None: fewer than 16 samples).
    """
    first = tt <= 2.0 * opt.window_s
    if first.sum() < 16:
        return None
    dt = float(np.median(np.diff(tt)))
    x = y[first] - np.mean(y[first])
    n = 8 * x.size
    power = np.abs(np.fft.rfft(x * np.hanning(x.size), n)) ** 2
    freqs = np.fft.rfftfreq(n, dt)
    allowed = freqs >= 1.0 / (2.0 * opt.window_s)
    if not np.any(allowed) or not np.any(power[allowed] > 0):
        return None
    return 0.5 / float(freqs[allowed][np.argmax(power[allowed])])


@dataclass(frozen=True)
class _DecayEnd:
    """Where a free decay ends (:func:`_free_decay_end`).

    Attributes:
        end: Its end [s], or None (the record ends first).
        reason: Why it ends there.
        period: The model's period [s] (inf: no oscillation).
        fades: Where the model's envelope reaches the end's level [s] (≥ ``end``; inf: never).
        rate: The model's σ = Re λ at its end [1/s] (NaN: no model).
    """

    end: float | None
    reason: str
    period: float
    fades: float
    rate: float = math.nan


def _weave_departure(tau: FloatArray, residual: FloatArray, omega: float) -> float:
    """The mean square ``(a² + b²) / 2`` of the weave in a residual [signal units²].

    ``a cos ωτ + b sin ωτ`` is fitted beside an offset and a slope (the slow modes, not the weave).
    """
    basis = np.column_stack([np.ones(tau.size), tau, np.cos(omega * tau), np.sin(omega * tau)])
    coef = np.linalg.lstsq(basis, residual, rcond=None)[0]
    return float(0.5 * (coef[2] ** 2 + coef[3] ** 2))


def _fades(t0: float, params: FloatArray, level: float) -> float:
    """Where ``√(a² + b²) e^{σ t}`` of ``params`` falls to ``level`` [s] (inf: it does not fall)."""
    amplitude, sig = float(math.hypot(params[3], params[4])), float(params[1])
    if amplitude <= level:
        return t0
    return t0 + math.log(level / amplitude) / sig if sig < 0 else math.inf


def _free_decay_end(
    t: FloatArray, y: FloatArray, floor: float, opt: SegmentOptions, ar: NoiseAR | None = None
) -> _DecayEnd:
    """Where the decaying sinusoid from ``t[0]`` stops explaining ``y`` (module docstring).

    The model is fitted to one cycle, then to one more half-cycle at a time. Before each
    half-cycle is added, the next cycle's residual from the model fitted so far is tested: the
    weave in it (a sinusoid at the model's ω fitted beside an offset and a slope, which the slow
    modes may leave) with a mean square beyond ``departure`` times the noise level's (a χ² with
    2 dof, an amplitude and a phase, passes 4.6 once in 100) ends the decay where the fit ends:
    the rider or the motor took over. The decay also ends where its envelope ``√(a² + b²) e^{σ t}`` falls to
    ``decay_level`` times the noise level: beyond, it no longer stands out of the riding; that
    end is taken from a fit reaching half a cycle beyond it. The noise level is the fit's
    residual RMS or ``floor`` (the riding's level before the kick), whichever is larger. With
    ``ar`` (the riding's AR model, :mod:`.whiten`) each fit is whitened by it; the residual RMS
    and the departure test stay those of the plain residual.
    """
    tt = t - t[0]
    t0 = float(t[0])
    half = _half_period(tt, y, opt) if tt.size >= 16 else None
    if half is None:
        return _DecayEnd(t0, "no oscillation: too few samples", math.inf, t0)
    end = 2.0 * half
    params: FloatArray | None = None
    refined = False
    while True:
        inside = tt <= end
        if params is None:
            w = math.pi / half
            x = tt[inside]
            basis = np.column_stack([np.ones(x.size), np.cos(w * x), np.sin(w * x)])
            c, a, b = np.linalg.lstsq(basis, y[inside], rcond=None)[0]
            params = np.array([c, 0.0, w, a, b])
        fitted = _fit_decay(tt[inside], y[inside], params, ar)
        if fitted is None:
            return _DecayEnd(t0 + end, "the decaying sinusoid cannot be fitted beyond here", 2.0 * half, t0 + end)
        params = fitted
        n = int(inside.sum())
        rms = float(np.sqrt(np.sum((y[inside] - _decay_model(params, tt[inside])) ** 2) / max(n - 5, 1)))
        sig, w = float(params[1]), float(params[2])
        if not (w > 0 and 0.5 < (math.pi / w) / half < 2.0):
            why = f"the decaying sinusoid fitted to here has ω {w:.3g} rad/s"
            return _DecayEnd(t0 + end, why, 2.0 * half, t0 + end)
        half = math.pi / w
        noise = max(rms, floor)
        level = opt.decay_level * noise
        fades = _fades(t0, params, level)
        lam = f"λ ≈ {sig:.2f} + {w:.2f}i 1/s" + (f", whitened by the riding's AR({ar.order})" if ar is not None else "")
        if fades <= t0 + end:
            if not refined and end < fades - t0 + half <= tt[-1]:
                refined, end = True, fades - t0 + half  # the envelope from data beyond its end too
                continue
            why = f"free decay ends: its envelope falls to {opt.decay_level:g}× the noise level {noise:.3g} ({lam})"
            return _DecayEnd(fades, why, 2.0 * half, fades, sig)
        refined = False
        chunk = (tt > end) & (tt <= end + 2.0 * half)
        if tt[-1] < end + 2.0 * half or chunk.sum() < 8:
            return _DecayEnd(None, "", 2.0 * half, fades, sig)
        ratio = _weave_departure(tt[chunk] - end, y[chunk] - _decay_model(params, tt[chunk]), w) / noise**2
        if ratio > opt.departure:
            why = (
                f"free decay ends: over the next cycle the weave leaves the model by {math.sqrt(ratio):.1f}× "
                f"the noise level {noise:.3g} ({lam}): the rider or the motor took over"
            )
            return _DecayEnd(t0 + end, why, 2.0 * half, fades, sig)
        end += half


def segment_record(record: RideRecord, options: SegmentOptions | None = None) -> Segmentation:
    """The free decays of a long record (module docstring), in time order, with every kick found."""
    opt = options or SegmentOptions()
    t = record.times
    sigma = noise_sigma(record.signal)
    detrended = detrend(record, opt)
    kicks = _kicks(record, detrended, sigma, opt)
    dt = float(np.median(np.diff(t)))
    segments = []
    previous = -math.inf  # where the last kick's response fades: the riding's level is measured after it
    for k, kick in enumerate(kicks):
        start = kick.end + opt.settle_s
        i0 = int(np.searchsorted(t, start))
        if i0 >= t.size:
            break
        stops = []
        if k + 1 < len(kicks):
            stops.append((kicks[k + 1].onset - opt.gap_s, f"next kick at {kicks[k + 1].onset:.2f} s"))
        stops.append((float(t[-1]), "end of record"))
        stops.append((start + opt.max_length_s, f"the longest segment, {opt.max_length_s:g} s"))
        limit = min(s[0] for s in stops)
        i1 = int(np.searchsorted(t, limit, side="right"))
        lead = kick.onset - 0.25 * opt.window_s  # (the onset lags the push by up to its rise)
        before = (t >= lead - opt.riding_s) & (t < lead) & (t > previous)
        enough = np.sum(before) * dt >= opt.window_s
        riding = float(np.sqrt(np.mean(detrended[before] ** 2))) if enough else sigma
        even = enough and _even(t[before]) and _even(t[i0:i1], float(np.median(np.diff(t[before]))))
        ar = fit_noise_ar(detrended[before], opt.noise_order) if even else None
        decay = _free_decay_end(t[i0:i1], detrended[i0:i1], max(riding, sigma), opt, ar)
        if decay.end is not None:
            stops.append((decay.end, decay.reason))
        stop, why = min(stops, key=lambda s: s[0])
        previous = max(stop, min(decay.fades, stop + opt.riding_s))  # the response lasts until it fades
        seen = decay.rate < 0 and stop - start >= decay.period
        if stop <= start or not (kick.confirmed or seen):
            continue  # the rider's own motion: no decaying oscillation of a cycle or more
        segments.append(Segment(start, stop, kick, f"{opt.settle_s:g} s after the kick ({kick.reason})", why))
    return Segmentation(tuple(segments), tuple(kicks), detrended)


def why_no_segment(record: RideRecord, options: SegmentOptions | None = None) -> str:
    """Why :func:`segment_record` finds no segment in ``record``: what was found, in words."""
    opt = options or SegmentOptions()
    if record.torque is not None:
        return f"no steer-torque kick beyond {opt.torque_threshold:g}σ of its noise"
    detrended, sigma = detrend(record, opt), noise_sigma(record.signal)
    rolls = _signal_kicks(record.times, np.abs(detrended), sigma, opt)
    confirmed = _kicks(record, detrended, sigma, opt)
    if not rolls:
        rising = f"{opt.rise:g}× within {opt.window_s:g} s above {opt.threshold:g}σ"
        return f"no roll-rate kick (an envelope rising {rising})"
    if confirmed or record.speed is None:
        return f"{len(rolls)} roll-rate kicks, none followed by a decaying oscillation of a cycle or more"
    times, _, _ = speed_transients(record.times, record.speed, opt)
    jolts = 1 + int(np.sum(np.diff(times) > opt.speed_window_s)) if times.size else 0
    return (
        f"{len(rolls)} roll-rate kicks, none within {opt.speed_window_s:g} s of a wheel-speed transient "
        f"({jolts} beyond {opt.speed_threshold:g}σ in the record): the rider's own motions, "
        "or pushes that do not jolt the wheel (a record without a speed tries every roll-rate kick)"
    )


def unconfirmed_flag(segment: Segment, record: RideRecord) -> str | None:
    """The flag of a found segment whose kick only the roll rate shows (None: confirmed).

    Neither the steer torque nor a wheel-speed jolt marks its start, and the rider's own motions
    (starting off, a turn, steering) look alike: such a segment is reported but never clean.
    """
    if segment.kick.confirmed:
        return None
    missing = "no wheel-speed jolt near it" if record.speed is not None else "the record has no wheel speed"
    return (
        f"{UNCONFIRMED_KICK}: only the roll rate shows a kick ({missing}, no steer torque): "
        "the rider's own motions look alike"
    )
