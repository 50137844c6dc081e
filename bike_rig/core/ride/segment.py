"""Automatic segmentation of a long ride record into free decays after perturbations.

A perturbation ("kick") is found in the steer torque when the record has one, else in the
roll rate:

* **steer torque**: runs of samples with |T − median T| above ``torque_threshold`` times the
  torque's noise σ (runs closer than ``merge_s`` are one kick); the kick ends when the
  torque is back;
* **roll rate**: with ``z = |y − baseline|`` (baseline: a running median over
  ``10 · window_s``), its largest value over the next ``window_s`` rises above ``threshold``
  noise σ and above ``rise`` times its largest value over the previous ``window_s``: the
  envelope of a free oscillation does not grow that fast within a window (``window_s`` at
  least half the longest weave period), a kick does. The kick's onset is the first sample
  above half-way between the two; it ends at the first peak of ``z`` after it.

Each segment starts ``settle_s`` after its kick ends (the fast caster mode dies out) and ends
at the first of: the free decay's end (its half-cycle peaks, :func:`.envelope.half_cycle_peaks`,
leave the exponential envelope fitted to the ones before by more than ``envelope_tolerance``
and the noise: the rider or the motor took over), the oscillation lost in noise (``z`` stays
below ``threshold`` σ for a whole window), the next kick (``gap_s`` before it), the end of the
record, ``max_length_s`` (a safety bound, not the rule).
In the roll rate alone a kick is found only where the oscillation before it has decayed
below 1/``rise`` of the kick's response: record the steer torque where kicks come often. The reasons for
each start and end are recorded. The noise σ is robust: the median absolute deviation of the
second differences (``σ = 1.4826 · MAD(Δ²y) / √6`` for white noise; the weave moves a sample's
second difference by (ω Δt)² of its amplitude, ≈ 0.3 % at 100 Hz).
Units: times s, the signal in its own units (rad/s), torque N m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .envelope import half_cycle_peaks
from .record import RideRecord

__all__ = ["Kick", "Segment", "SegmentOptions", "find_kicks", "noise_sigma", "segment_record"]

FloatArray = NDArray[np.float64]

#: MAD of a normal distribution's samples times this is its σ.
MAD_TO_SIGMA = 1.482602218505602


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
        max_length_s: The longest segment [s] (a safety bound: the envelope ends a segment).
        envelope_tolerance: A half-cycle peak this far from the envelope (relative) ends the free decay.
        envelope_peaks: Peaks that define the envelope before it may end the segment.
    """

    window_s: float = 1.0
    threshold: float = 8.0
    rise: float = 2.0
    torque_threshold: float = 6.0
    merge_s: float = 0.2
    settle_s: float = 0.2
    gap_s: float = 0.05
    max_length_s: float = 10.0
    envelope_tolerance: float = 0.25
    envelope_peaks: int = 4


@dataclass(frozen=True)
class Kick:
    """One perturbation found.

    Attributes:
        onset: Its start [s].
        end: Its end [s] (torque back, or the roll rate's first peak).
        reason: How it was found.
    """

    onset: float
    end: float
    reason: str


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


def noise_sigma(y: FloatArray) -> float:
    """Robust white-noise σ of a series: 1.4826 · MAD(Δ²y) / √6 (units of ``y``)."""
    if y.size < 4:
        return math.nan
    d2 = np.diff(y, 2)
    return float(MAD_TO_SIGMA * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


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
        kicks.append(Kick(a, b, why))
    return kicks


def _signal_kicks(t: FloatArray, z: FloatArray, sigma: float, opt: SegmentOptions) -> list[Kick]:
    n = max(2, int(round(opt.window_s / float(np.median(np.diff(t))))))
    fwd, bwd = _running_max(z, n, True), _running_max(z, n, False)
    level = opt.threshold * sigma
    kick_at = (fwd > level) & (fwd > opt.rise * bwd)
    kicks: list[Kick] = []
    i = 0
    while True:
        hits = np.flatnonzero(kick_at[i:])
        if not hits.size:
            return kicks
        i += int(hits[0])
        half = 0.5 * (bwd[i] + fwd[i])
        onset = i + int(np.argmax(z[i : i + n] > half))
        peak = onset + int(np.argmax(z[onset : onset + n // 2 + 1]))
        kicks.append(
            Kick(
                float(t[onset]),
                float(t[peak]),
                f"roll rate rose {fwd[i] / max(bwd[i], sigma):.1f}× within {opt.window_s:g} s at {t[onset]:.2f} s "
                f"(first peak {t[peak]:.2f} s)",
            )
        )
        i = peak + n  # the next kick: a window after this one's peak at the earliest


def find_kicks(record: RideRecord, options: SegmentOptions | None = None) -> list[Kick]:
    """The perturbations of a record: from its steer torque if it has one, else its signal."""
    opt = options or SegmentOptions()
    if record.torque is not None:
        return _torque_kicks(record.times, record.torque, opt)
    z = np.abs(record.signal - _baseline(record.times, record.signal, opt))
    return _signal_kicks(record.times, z, noise_sigma(record.signal), opt)


def _baseline(t: FloatArray, y: FloatArray, opt: SegmentOptions) -> FloatArray:
    from scipy.ndimage import median_filter

    n = max(3, int(round(10 * opt.window_s / float(np.median(np.diff(t))))))
    return np.asarray(median_filter(y, size=min(n, y.size), mode="nearest"), dtype=float)


def _free_decay_end(t: FloatArray, z: FloatArray, sigma: float, opt: SegmentOptions) -> tuple[float, str] | None:
    """Where the half-cycle peaks of ``z`` (from a segment's start) leave their exponential envelope, or None.

    The half-period is the median spacing of the zero crossings of ``z`` smoothed over 50 ms (no
    chatter of the noise); peaks below ``threshold`` σ are noise (the oscillation is lost).
    """
    if t.size < 8:
        return None
    dt = float(np.median(np.diff(t)))
    width = max(1, int(round(0.05 / dt)))
    smooth = np.convolve(z, np.ones(width) / width, mode="same")
    crossings = np.flatnonzero(np.signbit(smooth[1:]) != np.signbit(smooth[:-1]))
    if crossings.size < opt.envelope_peaks + 2:
        return None
    half = float(np.median(np.diff(t[crossings])))
    times, peaks = half_cycle_peaks(t, smooth, math.pi / half)
    above = np.flatnonzero(peaks < opt.threshold * sigma)
    times, peaks = (times[: above[0]], peaks[: above[0]]) if above.size else (times, peaks)
    for k in range(opt.envelope_peaks, peaks.size):
        slope, icpt = np.polyfit(times[:k], np.log(peaks[:k]), 1)
        expected = math.exp(icpt + slope * times[k])
        tol = opt.envelope_tolerance * expected + 3.0 * math.sqrt(2.0) * sigma
        if abs(peaks[k] - expected) > tol:
            end = float(times[k - 1] + 0.5 * half)  # the last peak on the envelope's half-cycle
            return end, (
                f"free decay ends: the half-cycle peak at {times[k]:.2f} s is {peaks[k]:.3g}, "
                f"the envelope of the {k} before says {expected:.3g}"
            )
    return None


def segment_record(record: RideRecord, options: SegmentOptions | None = None) -> list[Segment]:
    """The free decays of a long record (module docstring), in time order."""
    opt = options or SegmentOptions()
    t, y = record.times, record.signal
    sigma = noise_sigma(y)
    z = np.abs(y - _baseline(t, y, opt))
    n = max(2, int(round(opt.window_s / float(np.median(np.diff(t))))))
    quiet = _running_max(z, n, True) < opt.threshold * sigma
    kicks = find_kicks(record, opt)
    segments = []
    for k, kick in enumerate(kicks):
        start = kick.end + opt.settle_s
        i0 = int(np.searchsorted(t, start))
        if i0 >= t.size:
            break
        stops = []
        lost = np.flatnonzero(quiet[i0:])
        if lost.size:
            level = f"{opt.threshold:g}σ = {opt.threshold * sigma:.3g}"
            stops.append((float(t[i0 + int(lost[0])]), f"lost in noise: below {level} for {opt.window_s:g} s"))
        if k + 1 < len(kicks):
            stops.append((kicks[k + 1].onset - opt.gap_s, f"next kick at {kicks[k + 1].onset:.2f} s"))
        stops.append((float(t[-1]), "end of record"))
        decay_end = _free_decay_end(t[i0:], (y - _baseline(t, y, opt))[i0:], sigma, opt)
        if decay_end is not None:
            stops.append(decay_end)
        stops.append((start + opt.max_length_s, f"the longest segment, {opt.max_length_s:g} s"))
        stop, why = min(stops, key=lambda s: s[0])
        if stop <= start:
            continue
        segments.append(Segment(start, stop, kick, f"{opt.settle_s:g} s after the kick ({kick.reason})", why))
    return segments
