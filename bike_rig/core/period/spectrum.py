"""Initial guess of the oscillation frequency from the spectrum, and the block sums it uses.

The guess only has to land inside the least-squares fit's basin (about half a spectral bin,
1 / (2 × window length)), so it works on block means (:func:`spectrum_block`): at most
``MAX_SPECTRUM_POINTS`` of them, unless that would make them fewer than ``MIN_SPECTRUM_RATE``
per second; a Hann-windowed, zero-padded periodogram of the detrended series, whose highest
peak is refined by a parabola through the logarithm of its three top bins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MAX_SPECTRUM_POINTS",
    "MIN_SPECTRUM_RATE",
    "Periodogram",
    "SpectralPeak",
    "block_sums",
    "block_times",
    "peak_of_blocks",
    "periodogram",
    "periodograms",
    "spectrum_block",
]

FloatArray = NDArray[np.float64]

#: The periodogram uses block means of the window, at most this many (a 30 s window: 34 a
#: second; the FFT stays short)...
MAX_SPECTRUM_POINTS = 1024
#: ...unless that makes fewer than this many a second [Hz]: oscillations of up to a quarter of
#: the block rate are found, so a record of any length is searched up to 8 Hz (periods from
#: 0.125 s); 1024 means of a 120 s window would have stopped at 2.1 Hz (periods from 0.47 s).
MIN_SPECTRUM_RATE = 32.0


def spectrum_block(n: int, step: float) -> int:
    """Samples per block mean of the spectrum, for a window of ``n`` samples ``step`` s apart.

    As few as make at most ``MAX_SPECTRUM_POINTS`` means, but never so many that there are
    fewer than ``MIN_SPECTRUM_RATE`` means a second (and at least 1).
    """
    k = math.ceil(n / MAX_SPECTRUM_POINTS)
    if step > 0 and math.isfinite(step):
        k = min(k, math.floor(1.0 / (MIN_SPECTRUM_RATE * step)))
    return max(1, k)


@dataclass(frozen=True)
class SpectralPeak:
    """The highest spectral peak of a series.

    Attributes:
        omega: Its angular frequency [rad/s].
        prominence: Its power over the median power of the surrounding two octaves (excluding
            the peak's own lobe) [-]: tens for noise, thousands for a clear oscillation.
    """

    omega: float
    prominence: float


def block_sums(y: FloatArray, k: int) -> tuple[FloatArray, FloatArray]:
    """Sums of consecutive blocks of ``k`` samples (the last may be shorter), and their sizes."""
    n = y.size
    starts = np.arange(0, n, k)
    counts = np.full(starts.size, float(k))
    counts[-1] = n - k * (starts.size - 1)
    return np.add.reduceat(y, starts), counts


def block_times(
    t: FloatArray | None, k: int, counts: FloatArray, step: float | None = None, first: float = 0.0
) -> FloatArray:
    """Mean time of each block of :func:`block_sums` [s].

    From the times ``t``, or, for samples evenly spaced by ``step`` from ``first``, computed.
    """
    if step is None:
        assert t is not None
        return np.add.reduceat(t, np.arange(0, t.size, k)) / counts
    centres = np.arange(0.0, k * counts.size, k)
    centres += 0.5 * (counts - 1.0)
    centres *= step
    centres += first
    return centres


@lru_cache(maxsize=8)
def _hann(m: int) -> FloatArray:
    return np.hanning(m)


@lru_cache(maxsize=8)
def _ramp(m: int) -> tuple[FloatArray, float]:
    x = np.linspace(-1.0, 1.0, m)
    return x, float(np.dot(x, x))


@dataclass(frozen=True)
class Periodogram:
    """A Hann-windowed, zero-padded periodogram of detrended block means.

    Attributes:
        power: |FFT|² of the detrended, Hann-windowed series, per padded bin [units²].
        nfft: FFT length (the series' length m, padded to a power of two, then doubled).
        m: Points in the series.
        df: Padded bin spacing [Hz]; a Fourier (independent-frequency) bin is ``nfft / m``
            padded bins.
        lo: Lowest padded bin searched (``min_cycles`` per record).
        hi: Highest padded bin searched (a quarter of the block rate).
    """

    power: FloatArray
    nfft: int
    m: int
    df: float
    lo: int
    hi: int

    @property
    def pad(self) -> float:
        """Padded bins per Fourier bin [-]."""
        return self.nfft / self.m


def periodogram(
    tb: FloatArray, yb: FloatArray, duration: float, even: bool = False, min_cycles: float = 1.0
) -> Periodogram | None:
    """The periodogram of block means ``yb`` at times ``tb`` of a ``duration`` s record.

    The block means are put on an even grid (interpolated when the times are uneven), their
    mean and linear trend removed, Hann-windowed and zero-padded.

    Returns:
        The periodogram, or None when the series is too short (fewer than 8 points, or no
        bin between ``min_cycles`` per record and a quarter of the block rate).
    """
    found = periodograms(tb, yb[np.newaxis], duration, even, min_cycles)
    return None if found is None else found[0]


def periodograms(
    tb: FloatArray, yb: FloatArray, duration: float, even: bool = False, min_cycles: float = 1.0
) -> list[Periodogram] | None:
    """:func:`periodogram` of each row of ``yb`` (series × blocks) at the same times, in one FFT."""
    m = tb.size
    if m < 8 or not duration > 0:
        return None
    # put the block means on an even grid (they are already, unless the times are uneven)
    step = float(tb[-1] - tb[0]) / (m - 1)
    if not even:
        grid = tb[0] + step * np.arange(m)
        if not np.allclose(tb, grid, rtol=0.0, atol=0.01 * step):
            yb = np.stack([np.interp(grid, tb, row) for row in yb])
    x, xx = _ramp(m)
    detrended = yb - np.mean(yb, axis=1, keepdims=True)
    detrended -= np.outer(np.einsum("ij,j->i", yb, x) / xx, x)
    detrended *= _hann(m)
    nfft = 1 << (int(m - 1).bit_length() + 1)
    spectrum = np.fft.rfft(detrended, nfft, axis=1)
    power = spectrum.real**2
    power += spectrum.imag**2
    df = 1.0 / (nfft * step)
    lo = max(1, math.ceil(min_cycles / (duration * df)))
    hi = min(power.shape[1] - 2, int(0.25 / (step * df)))
    if hi <= lo:
        return None
    return [Periodogram(row, nfft, m, df, lo, hi) for row in power]


def peak_of_blocks(
    tb: FloatArray, yb: FloatArray, duration: float, even: bool = False, min_cycles: float = 1.0
) -> SpectralPeak | None:
    """The dominant oscillation of block means ``yb`` at times ``tb`` of a ``duration`` s record.

    Args:
        tb: Block times [s], increasing (possibly unevenly spaced).
        yb: Block means (finite).
        duration: The record's length [s].
        even: The blocks are evenly spaced.
        min_cycles: Lowest frequency searched, in cycles per record.

    Returns:
        The peak, or None when the series is too short to have one.
    """
    spec = periodogram(tb, yb, duration, even, min_cycles)
    if spec is None:
        return None
    power, lo, hi, df, nfft, m = spec.power, spec.lo, spec.hi, spec.df, spec.nfft, spec.m
    i = lo + int(np.argmax(power[lo : hi + 1]))
    p0, p1, p2 = (math.log(max(float(v), 1e-300)) for v in power[i - 1 : i + 2])
    curvature = p0 - 2.0 * p1 + p2
    shift = 0.5 * (p0 - p2) / curvature if curvature < 0 else 0.0
    lobe = 2 * nfft // m + 1  # Hann main lobe half-width, in padded bins
    around = np.concatenate((power[max(lo, i // 2) : max(lo, i - lobe)], power[i + lobe + 1 : min(hi, 2 * i) + 1]))
    if around.size >= 4:
        middle = around.size // 2
        background = float(np.partition(around, middle)[middle])  # the median (upper, if even)
    else:
        background = 0.0
    prominence = float(power[i]) / background if background > 0 else math.inf
    return SpectralPeak(omega=2.0 * math.pi * (i + max(-0.5, min(0.5, shift))) * df, prominence=prominence)
