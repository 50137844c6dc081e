"""Whether a trial holds an oscillation at all: its spectral peak against the noise floor.

A period means an oscillation was found. After the fit, the record's periodogram at the fitted
frequency is tested against the noise floor there, which the periodogram of the fit's
residuals gives (the oscillation, beating or decaying, is then out of it). The test is
designed for a false-alarm probability of at most ``FALSE_ALARM`` (1e-4) per record of pure
noise — white, quantised, 1/f or a random walk:

* **The floor** is the mean of the lowest 3/4 of K residual bins nearest the peak, two Fourier
  bins apart (Hann-windowed bins that far apart are nearly independent) and at least
  ``LOBE_BINS`` Fourier bins from it. Dropping the top quarter keeps a few bins of a second
  mode (beating) or a spur out of the floor.
* **Coloured noise.** The floor bins are brought to the peak's frequency by a power law
  ``(f / f_peak)^s``. With at least ``MIN_BELOW`` floor bins below the peak the slope s is the
  residual spectrum's own (least squares on log power against log frequency), between 0
  (white) and 2 (random walk). With fewer (a record of a few cycles: the floor lies above the
  peak only) s = 2 — the reddest noise a rate gyro makes (its bias is a random walk), an upper
  bound for anything between white noise and a random walk.
* **The false-alarm probability.** For noise, each periodogram bin is exponentially
  distributed about the spectrum. The mean L of the lowest k of K independent exponential bins
  is, by Rényi's representation of their order statistics, ``Σ_i E_i (k − i + 1) / (k (K − i + 1))``
  (E_i independent unit exponentials), so the chance that a noise bin exceeds ``z L`` is exactly
  ``Π_{i=1..k} 1 / (1 + z (k − i + 1) / (k (K − i + 1)))``. The fit may have landed on any of the M
  Fourier frequencies of the searched band: by the union bound the record's false-alarm
  probability is at most M times that. The floor is tried with K = 8, 16 and 32 bins (fewer
  bins are less inflated by a red slope, more are less noisy) and the best is kept, at the
  price of a factor 3 (Bonferroni); the first floor whose bound decides "found" ends the
  search (the verdict is the same, and a record that stands out costs one floor).

A record is called an oscillation when that bound is at most ``FALSE_ALARM``. For white noise
and many cycles the peak must stand 42–47× above the floor (K = 32, 256–1024 frequencies:
23–25 times the mean noise bin); the simulated trials of the shipped bicycles stand far above
that (their largest false-alarm bound is below 1e-13). A few-cycle record, whose floor can
only be extrapolated from above with the random-walk bound, needs a much larger swing.
``bench/bench_noise_validity.py`` counts the records of noise called valid and measures where
real oscillations stop being valid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .spectrum import Periodogram, periodograms

__all__ = ["FALSE_ALARM", "FLOOR_BINS", "Detection", "detect", "false_alarm_of_bin"]

FloatArray = NDArray[np.float64]

#: Largest false-alarm probability of a record called an oscillation [-].
FALSE_ALARM = 1e-4
#: Numbers of residual bins the floor is tried with.
FLOOR_BINS = (8, 16, 32)
#: Fraction of the floor bins (the lowest) averaged into the floor.
FLOOR_KEPT = 0.75
#: Fourier bins either side of the peak left out of the floor (Hann's main lobe is ±2).
LOBE_BINS = 3
#: Fourier bins between floor bins.
BIN_SPACING = 2
#: Floor bins below the peak needed to measure the floor's slope (else the random-walk bound).
MIN_BELOW = 4
#: Steepest noise spectrum assumed, as the exponent of 1/f (a random walk) [-].
MAX_RED_SLOPE = 2.0
#: Fewest floor bins a floor is made of.
_MIN_FLOOR_BINS = 4


@dataclass(frozen=True)
class Detection:
    """The test of a fitted oscillation against the noise floor.

    Attributes:
        false_alarm: Upper bound of the probability that noise alone gives a peak this high
            anywhere in the searched band [-] (1 when it cannot be told).
        ratio: The peak's power over the floor [-].
        frequency: The fitted frequency [Hz].
        floor_bins: Residual bins the floor was made of (0: too few to make one).
        slope: Exponent s of the floor's ``f^-s`` correction [-] (0 white, 2 random walk).
    """

    false_alarm: float
    ratio: float
    frequency: float
    floor_bins: int
    slope: float

    @property
    def found(self) -> bool:
        """Whether the peak is an oscillation (false-alarm probability at most ``FALSE_ALARM``)."""
        return self.false_alarm <= FALSE_ALARM

    def describe(self) -> str:
        """One line for a flag: the peak, its ratio to the floor and the false-alarm probability."""
        if self.floor_bins == 0:
            return f"the record has too few frequencies to tell an oscillation at {self.frequency:.3g} Hz from noise"
        return (
            f"the fitted {self.frequency:.3g} Hz ({1.0 / self.frequency:.4g} s) stands {self.ratio:.3g}× above "
            f"the noise floor around it, which noise alone reaches with probability {min(1.0, self.false_alarm):.2g} "
            f"(an oscillation needs at most {FALSE_ALARM:g})"
        )


def false_alarm_of_bin(z: float, n_bins: int, kept: int) -> float:
    """P(a noise bin > z L), L the mean of the lowest ``kept`` of ``n_bins`` i.i.d. noise bins [-].

    Exact for exponentially distributed bins (a periodogram of Gaussian noise); see the
    module docstring.
    """
    if not z > 0:
        return 1.0
    i = np.arange(1, kept + 1, dtype=float)
    return float(np.exp(-np.sum(np.log1p(z * (kept - i + 1.0) / (kept * (n_bins - i + 1.0))))))


def _floor_bins(spec: Periodogram, at: float, count: int) -> NDArray[np.intp]:
    """Up to ``count`` padded bins, ``BIN_SPACING`` Fourier bins apart, nearest to bin ``at``.

    They start ``LOBE_BINS`` Fourier bins from ``at`` on either side and stay in the band.
    """
    pad = spec.pad
    steps = np.arange(count, dtype=float)
    offsets = (LOBE_BINS + BIN_SPACING * steps) * pad
    positions = np.concatenate((at - offsets, at + offsets))
    distance = np.concatenate((offsets, offsets))
    bins = np.rint(positions).astype(np.intp)
    inside = (bins >= spec.lo) & (bins <= spec.hi)
    bins, distance = bins[inside], distance[inside]
    return bins[np.argsort(distance, kind="stable")][:count]


def _slope(power: FloatArray, log_f: FloatArray, n_below: int) -> float:
    """Exponent s of the floor's ``f^-s`` shape, from 0 (white) to ``MAX_RED_SLOPE``."""
    if n_below < MIN_BELOW:
        return MAX_RED_SLOPE
    centred = log_f - float(np.mean(log_f))
    spread = float(np.dot(centred, centred))
    if not spread > 0:
        return MAX_RED_SLOPE
    fitted = float(np.dot(centred, np.log(np.maximum(power, np.finfo(float).tiny)))) / spread
    return min(MAX_RED_SLOPE, max(0.0, -fitted))


def _one_floor(peak: float, residual: FloatArray, bins: NDArray[np.intp], at: float) -> tuple[float, float, float]:
    """(probability per bin, ratio, slope) of the floor made of ``bins`` of the residual spectrum."""
    log_f = np.log(bins / at)
    slope = _slope(residual[bins], log_f, int(np.count_nonzero(bins < at)))
    values = np.sort(residual[bins] * np.exp(slope * log_f))
    kept = max(1, int(FLOOR_KEPT * bins.size))
    floor = float(np.mean(values[:kept]))
    ratio = peak / floor if floor > 0 else (math.inf if peak > 0 else 0.0)
    return false_alarm_of_bin(ratio, bins.size, kept), ratio, slope


def detect(tb: FloatArray, yb: FloatArray, rb: FloatArray, duration: float, omega_d: float, even: bool) -> Detection:
    """Test the fitted oscillation at ``omega_d`` against the noise floor of the residuals.

    Args:
        tb: Block times [s], increasing.
        yb: Block means of the samples (any unit).
        rb: Block means of the fit's residuals (same unit).
        duration: The window's length [s].
        omega_d: The fitted damped angular frequency [rad/s].
        even: The blocks are evenly spaced.

    Returns:
        The detection; ``found`` says whether the record holds an oscillation (a found one
        carries the first floor that decided it, a miss the best of all floors).
    """
    frequency = omega_d / (2.0 * math.pi)
    both = periodograms(tb, np.stack((yb, rb)), duration, even)
    if both is None or not frequency > 0:
        return Detection(1.0, math.nan, frequency, 0, math.nan)
    data, residual = both
    at = frequency / data.df  # the fitted frequency, in padded bins
    reach = math.ceil(data.pad)
    centre = int(round(at))
    first, last = max(data.lo, centre - reach), min(data.hi, centre + reach)
    if not (first <= last and at > 0):
        return Detection(1.0, math.nan, frequency, 0, math.nan)
    peak = float(np.max(data.power[first : last + 1]))
    searched = max(1.0, (data.hi - data.lo) / data.pad)  # Fourier frequencies in the band
    best = Detection(1.0, math.nan, frequency, 0, math.nan)
    for count in FLOOR_BINS:
        bins = _floor_bins(residual, at, count)
        if bins.size < _MIN_FLOOR_BINS:
            continue
        per_bin, ratio, slope = _one_floor(peak, residual.power, bins, at)
        bound = min(1.0, searched * len(FLOOR_BINS) * per_bin)
        if best.floor_bins == 0 or bound < best.false_alarm:
            best = Detection(bound, ratio, frequency, int(bins.size), slope)
        if best.found:
            break  # (the smallest floor already decides; larger ones are only tried for a miss)
    return best
