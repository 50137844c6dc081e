"""Is a segment a free decay? Its half-cycles must follow one exponential envelope at one period.

After a push the weave's roll rate swings with an envelope that only decays (or only grows) at
one rate: its half-cycle amplitudes, measured from the fitted model's baseline, lie on one
exponential. A record where the rider or the motor pumps the weave (a dip and then a bump; the
second peak above the first in a decaying fit) is not a free decay, and its eigenvalue is no
eigenvalue of the bicycle. The fit itself cannot tell: it follows a bump by turning its Re λ
towards growth with a wide σ, so the envelope is judged on its own.

**Amplitudes.** A half-cycle runs between two zero crossings of the detrended record (linearly
interpolated; crossings closer than 0.4 of a half-period are one, noise), so a record's cut ends
hold none. Its amplitude is the least-squares fit of ``|y|`` to the half-sine over it,
``a = Σ|y|s / Σs²``: white noise σ_w gives it σ_a = σ_w / √Σs² (about a quarter of σ_w at 30
samples a half-cycle, where the largest sample's σ is σ_w and its bias +1.5 σ_w).

**Noise of an amplitude.** White noise is the lesser part: the rider's steering keeps driving the
weave, so a free decay's amplitudes wander about their exponential by a share of the amplitude
(on simulated rides, :mod:`.ridesim`, a few %). An amplitude's σ is taken as
``√((3 σ_a)² + (RIDING_SHARE · envelope)²)``. (The fit's residual RMS is no measure of it: a bump
the fit cannot follow raises the residuals with it, so the bump never stands out of them.)

**Not a free decay** (any one):

1. *A dip and a bump*: with three or more amplitudes, one misses the best exponential through
   them (least squares on log a) by more than its σ, **and** the misfit has the shape of a pumped
   weave: the amplitudes rise and fall (a rise after an earlier amplitude and a fall below an
   earlier one, each beyond 3 √2 σ_a), or they rise and level off (a rise beyond 3 √2 σ_a and
   log a bending down, ``ln a_{k+1} − 2 ln a_k + ln a_{k−1}`` below minus its σ, from each
   amplitude's σ above: a step). The rider's noise bends a free envelope the other way: it holds
   the small amplitudes up, a decay's tail or a growth's start, so ln a bends up.
2. *Against the fit*: where Re λ is beyond its σ, an amplitude rises (< 0: decaying) or falls
   (> 0: growing) from the one before by more than 3 √2 σ_a plus :data:`RELATIVE_TOLERANCE` of
   the larger.
3. *A phase jump*: a free weave keeps its period, so its whole cycles (two adjacent half-cycles,
   whose sum a baseline offset does not change) last alike. A push out of phase with the swing
   shifts the phase: among the cycles whose half-cycles both reach :data:`LARGE_SHARE` of the
   largest amplitude (the rider's steering shifts the phase of small swings), two differ by more
   than :data:`PERIOD_TOLERANCE` of 2π/ω_d (on simulated free rides, with the rider and the
   motor's saturation, 95 % of segments keep their cycles within 7 % of each other).

Units: times s, the signal's (rad/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "LARGE_SHARE",
    "NOISE_AMPLITUDES",
    "PERIOD_TOLERANCE",
    "RELATIVE_TOLERANCE",
    "RIDING_SHARE",
    "HalfCycles",
    "envelope_problem",
    "half_cycle_amplitudes",
]

FloatArray = NDArray[np.float64]

#: An amplitude (or a difference of two) beyond this many of its white-noise σ is beyond noise [-].
NOISE_AMPLITUDES = 3.0
#: The rider-driven wander of a free decay's amplitude about its exponential, as a share of it [-].
RIDING_SHARE = 0.10
#: A step against the fitted direction counts beyond this share of the larger amplitude [-].
RELATIVE_TOLERANCE = 0.08
#: Two whole cycles of a free weave differ in length by at most this share of its period [-].
PERIOD_TOLERANCE = 0.15
#: A cycle's phase counts where both its half-cycles reach this share of the largest amplitude [-].
LARGE_SHARE = 0.5


@dataclass(frozen=True)
class HalfCycles:
    """The whole half-cycles of a detrended record (module docstring), one entry each.

    Attributes:
        times: Each half-cycle's middle [s].
        amplitudes: Its half-sine amplitude [signal units].
        white: Its σ per unit white-noise σ of a sample [-] (1 / √Σs²).
        lengths: Its length, zero crossing to zero crossing [s].
    """

    times: FloatArray
    amplitudes: FloatArray
    white: FloatArray
    lengths: FloatArray


def half_cycle_amplitudes(t: FloatArray, detrended: FloatArray, omega_d: float) -> HalfCycles:
    """The whole half-cycles' times [s], half-sine amplitudes and white-noise factors (module docstring)."""
    crossings = np.flatnonzero(np.signbit(detrended[1:]) != np.signbit(detrended[:-1])) + 1
    kept: list[int] = []
    for c in crossings:
        if not kept or t[c] - t[kept[-1]] > 0.4 * math.pi / omega_d:
            kept.append(int(c))
    before = np.array(kept, dtype=int) - 1  # (the sample before each crossing)
    y0, y1 = np.abs(detrended[before]), np.abs(detrended[kept])
    zero = t[before] + (t[kept] - t[before]) * y0 / np.maximum(y0 + y1, np.finfo(float).tiny)
    times, amplitudes, white, lengths = [], [], [], []
    for k in range(len(kept) - 1):
        a, b, start, stop = kept[k], kept[k + 1], zero[k], zero[k + 1]
        shape = np.sin(np.pi * np.clip((t[a:b] - start) / (stop - start), 0.0, 1.0))
        ss = float(shape @ shape)
        if not ss > 0:
            continue
        times.append(0.5 * (start + stop))
        amplitudes.append(float(np.abs(detrended[a:b]) @ shape) / ss)
        white.append(1.0 / math.sqrt(ss))
        lengths.append(stop - start)
    return HalfCycles(np.array(times), np.array(amplitudes), np.array(white), np.array(lengths))


def _listed(h: HalfCycles) -> str:
    amps = ", ".join(f"{a:.3g}" for a in h.amplitudes)
    return f"half-cycle amplitudes {amps} at {', '.join(f'{x:.2f}' for x in h.times)} s"


def _rise_and_fall(a: FloatArray, tol: FloatArray) -> tuple[bool, bool]:
    """Whether some amplitude rises above, and some falls below, an earlier one by more than ``tol`` (pairwise)."""
    d = a[None, :] - a[:, None]  # d[i, j] = a_j − a_i
    later = np.triu(np.ones_like(d, dtype=bool), 1)
    return bool(np.any(later & (d > tol))), bool(np.any(later & (d < -tol)))


def _exponential_misfit(h: HalfCycles, sigma_w: float) -> float:
    """The largest miss of an amplitude from the best exponential through them, in its σ (module docstring)."""
    a = h.amplitudes
    if a.size < 3 or not np.all(a > 0):
        return 0.0
    slope, level = np.polyfit(h.times - h.times.mean(), np.log(a), 1)
    envelope = np.exp(level + slope * (h.times - h.times.mean()))
    sigma = np.hypot(NOISE_AMPLITUDES * sigma_w * h.white, RIDING_SHARE * envelope)
    return float(np.max(np.abs(a - envelope) / sigma))


def _levels_off(h: HalfCycles, sigma_w: float) -> bool:
    """Whether ln a bends down beyond its σ somewhere (a rise that steps, not a growth; module docstring)."""
    a = h.amplitudes
    if a.size < 3 or not np.all(a > 0):
        return False
    relative = np.hypot(NOISE_AMPLITUDES * sigma_w * h.white / a, RIDING_SHARE)  # σ of ln a
    bend = np.diff(np.log(a), 2)
    sigma = np.sqrt(relative[2:] ** 2 + 4.0 * relative[1:-1] ** 2 + relative[:-2] ** 2)
    return bool(np.any(bend < -sigma))


def _phase_jump(h: HalfCycles, omega_d: float) -> float:
    """The largest difference of two large whole cycles' lengths, a share of 2π/ω_d (module docstring)."""
    if h.amplitudes.size < 3:
        return 0.0
    large = h.amplitudes >= LARGE_SHARE * h.amplitudes.max()
    adjacent = np.isclose(np.diff(h.times), 0.5 * (h.lengths[1:] + h.lengths[:-1]))
    cycles = (h.lengths[1:] + h.lengths[:-1])[adjacent & large[1:] & large[:-1]]
    return float(np.ptp(cycles)) * omega_d / (2.0 * math.pi) if cycles.size > 1 else 0.0


def envelope_problem(
    t: FloatArray, detrended: FloatArray, omega_d: float, real: float, real_sigma: float, white: float
) -> str | None:
    """Why the segment is not a free decay, or None (module docstring).

    Args:
        t: Sample times [s].
        detrended: The samples less the fitted baseline.
        omega_d: The fitted ω_d [rad/s].
        real: The fitted Re λ [1/s] (beyond its σ: < 0, the envelope must not rise; > 0, not fall).
        real_sigma: Its σ [1/s].
        white: The sensor's white-noise σ [signal units] (NaN: taken as 0).
    """
    if t.size < 8 or not omega_d > 0:
        return None
    h = half_cycle_amplitudes(t, detrended, omega_d)
    a = h.amplitudes
    if a.size < 2:
        return None
    sigma_w = white if math.isfinite(white) else 0.0
    pair_white = NOISE_AMPLITUDES * sigma_w * np.hypot(h.white[:, None], h.white[None, :])
    misfit = _exponential_misfit(h, sigma_w)
    rise, fall = _rise_and_fall(a, pair_white)
    if misfit > 1.0 and rise and (fall or _levels_off(h, sigma_w)):
        return (
            f"not_free_decay: the envelope {'dips and rises' if fall else 'steps up'} beyond the noise, "
            f"{misfit:.1f} σ off one exponential ({_listed(h)})"
        )
    steps = np.diff(a)
    tol = NOISE_AMPLITUDES * sigma_w * np.hypot(h.white[:-1], h.white[1:]) + RELATIVE_TOLERANCE * np.maximum(
        a[:-1], a[1:]
    )
    if abs(real) > real_sigma and real < 0 and np.any(steps > tol):
        return f"not_free_decay: the envelope rises where the fit decays ({_listed(h)})"
    if abs(real) > real_sigma and real > 0 and np.any(steps < -tol):
        return f"not_free_decay: the envelope falls where the fit grows ({_listed(h)})"
    jump = _phase_jump(h, omega_d)
    if jump > PERIOD_TOLERANCE:
        return (
            f"not_free_decay: the envelope's phase jumps, two whole cycles differ by {jump:.0%} "
            f"of the period ({_listed(h)})"
        )
    return None
