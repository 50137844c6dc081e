"""Is a segment a free decay? Its half-cycle peaks must follow one exponential envelope.

After a push the weave's roll rate swings with an envelope that only decays (or only grows):
its half-cycle peaks, measured from the fitted model's baseline (offset and trend or real mode),
change monotonically, in the direction of the fitted Re λ. A record where the rider or the
motor pumps the weave (the second peak above the first in a decaying fit; a dip and then a
bump) is not a free decay, and its eigenvalue is no eigenvalue of the bicycle. The peaks are the
largest |y − baseline| of each whole half-cycle: between two zero crossings of the detrended
record (crossings closer than 0.4 of a half-period are one, noise), so a record's cut ends hold
none. A change beyond :data:`NOISE_PEAKS` times the white noise of a peak difference (√2 σ_w)
plus :data:`RELATIVE_TOLERANCE` of the larger peak counts; the fit's direction only where Re λ
is beyond its σ. Units: times s, the signal's (rad/s).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["NOISE_PEAKS", "RELATIVE_TOLERANCE", "envelope_problem", "half_cycle_peaks"]

FloatArray = NDArray[np.float64]

#: A peak difference beyond this many of its white-noise σ is beyond noise [-].
NOISE_PEAKS = 3.0
#: ... plus this share of the larger peak (the peak's sampling and the baseline's error) [-].
RELATIVE_TOLERANCE = 0.08


def half_cycle_peaks(t: FloatArray, detrended: FloatArray, omega_d: float) -> tuple[FloatArray, FloatArray]:
    """The times [s] and sizes |y| of the whole half-cycles' peaks (module docstring)."""
    crossings = np.flatnonzero(np.signbit(detrended[1:]) != np.signbit(detrended[:-1])) + 1
    kept: list[int] = []
    for c in crossings:
        if not kept or t[c] - t[kept[-1]] > 0.4 * math.pi / omega_d:
            kept.append(int(c))
    idx = [a + int(np.argmax(np.abs(detrended[a:b]))) for a, b in zip(kept[:-1], kept[1:], strict=True)]
    return t[idx], np.abs(detrended[idx])


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
        white: The sensor's white-noise σ [signal units].
    """
    if t.size < 8 or not omega_d > 0:
        return None
    times, peaks = half_cycle_peaks(t, detrended, omega_d)
    if peaks.size < 2:
        return None
    noise = NOISE_PEAKS * math.sqrt(2.0) * (white if math.isfinite(white) else 0.0)
    steps = np.diff(peaks)
    tol = noise + RELATIVE_TOLERANCE * np.maximum(peaks[:-1], peaks[1:])
    rises, falls = steps > tol, steps < -tol
    listed = ", ".join(f"{p:.3g}" for p in peaks)
    where = f"half-cycle peaks {listed} at {', '.join(f'{x:.2f}' for x in times)} s"
    if np.any(rises) and np.any(falls):
        return f"not_free_decay: the envelope rises and falls beyond the noise ({where})"
    significant = abs(real) > real_sigma
    if significant and real < 0 and np.any(rises):
        return f"not_free_decay: the envelope rises where the fit decays ({where})"
    if significant and real > 0 and np.any(falls):
        return f"not_free_decay: the envelope falls where the fit grows ({where})"
    return None
