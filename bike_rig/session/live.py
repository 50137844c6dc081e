"""What the operator sees while a trial records: the last seconds of gyro rate, and warnings.

:class:`LiveTrace` keeps the recording trial's last ``window_s`` of samples and warns of
**no samples** (none for ``silence_s`` of wall time; :func:`silence_advice` per source kind),
**clipping** (runs of at least :data:`MIN_CLIP_RUN` equal samples at the window's extreme, at
least twice, in the last ``clip_window_s``) and **amplitude too small** (the spectral peak of the
full last ``amplitude_window_s`` under :data:`MIN_SNR` times the median bin). The amplitude
shown is the spectral peak's ``2 |X_k| / n``, which noise does not inflate. Rates rad/s, times s.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["MIN_CLIP_RUN", "MIN_SNR", "LiveStatus", "LiveTrace", "silence_advice"]

FloatArray = NDArray[np.float64]

#: Equal samples in a row at the window's extreme that count as a clipped peak.
MIN_CLIP_RUN = 5
#: Smallest ratio of the spectral peak to the median bin that does not warn.
MIN_SNR = 10.0


_SILENCE_ADVICE = {
    "sim": "the simulated source is starved: is the machine loaded? (it catches up; abort the trial if not)",
    "bag": "the replayed session has stalled: is the machine loaded? (abort the trial if it does not resume)",
    "can": "silent bus, wrong CAN id or unplugged gyro? (abort the trial, check the wiring, the interface and the id)",
    "daq": "DAQ not acquiring or gyro unplugged? (abort the trial, check the wiring and the channel)",
}


def silence_advice(source: str) -> str:
    """What to check when ``source`` (its kind first: ``sim``, ``bag``, ``can``, ``daq``) sends nothing."""
    kind = source.split()[0].lower() if source.strip() else ""
    return _SILENCE_ADVICE.get(kind, "is the gyro connected and streaming? (abort the trial, check the wiring)")


@dataclass(frozen=True)
class LiveStatus:
    """The recording trial as the console shows it.

    Attributes:
        trial_id: The trial.
        samples: Samples received so far.
        seconds: Rig time recorded so far, s.
        amplitude: The oscillation's amplitude over the last seconds (spectral peak), rad/s
            (NaN before enough samples).
        warnings: One line each (empty when all is well).
    """

    trial_id: str
    samples: int
    seconds: float
    amplitude: float
    warnings: tuple[str, ...]


@dataclass
class LiveTrace:
    """The recording trial's recent samples and their warnings (no samples, clipping, small swing).

    Attributes:
        trial_id: The trial.
        started_wall_s: Wall time the start was accepted, s (any monotonic clock).
        source: The gyro source's name, its kind first (``sim gyro``, ``can gyro``), for the
            no-samples warning.
        window_s: Rig time kept for the trace, s.
        silence_s: Wall time without samples that warns, s.
    """

    trial_id: str
    started_wall_s: float
    source: str = "gyro"
    window_s: float = 10.0
    silence_s: float = 1.0
    amplitude_window_s: float = 4.0
    clip_window_s: float = 4.0
    rate_hz: float = math.nan
    samples: int = 0
    last_sample_wall_s: float | None = None
    _blocks: deque[FloatArray] = field(default_factory=deque, repr=False)
    _kept: int = 0
    _next: int | None = None

    def add(self, rates: FloatArray, rate_hz: float, now_wall_s: float, first_index: int | None = None) -> None:
        """Add a batch of samples (rad/s) at ``rate_hz`` received at wall time ``now_wall_s``.

        ``first_index`` is the batch's first sample's index in the trial: a batch that does not
        follow the previous one (a batch lost on the way) starts the trace afresh, so the
        analysis never runs across a gap.
        """
        if rates.size == 0:
            return
        if first_index is not None and self._next is not None and first_index != self._next:
            self._blocks.clear()
            self._kept = 0
        if first_index is not None:
            self._next = first_index + int(rates.size)
        self.rate_hz = rate_hz
        self.samples += int(rates.size)
        self.last_sample_wall_s = now_wall_s
        self._blocks.append(np.asarray(rates, dtype=np.float64))
        self._kept += int(rates.size)
        keep = int(self.window_s * rate_hz) if math.isfinite(rate_hz) and rate_hz > 0 else 10_000
        while self._blocks and self._kept - self._blocks[0].size >= keep:
            self._kept -= self._blocks.popleft().size

    def recent(self, seconds: float | None = None) -> FloatArray:
        """The last ``seconds`` of samples (all kept when None), rad/s."""
        y = np.concatenate(list(self._blocks)) if self._blocks else np.zeros(0)
        if seconds is None or not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            return y
        return y[-max(1, int(seconds * self.rate_hz)) :]

    def status(self, now_wall_s: float) -> LiveStatus:
        """The trial's status and warnings at wall time ``now_wall_s``."""
        warnings = []
        since = now_wall_s - (self.last_sample_wall_s if self.last_sample_wall_s is not None else self.started_wall_s)
        if since >= self.silence_s:
            what = "no samples yet" if self.samples == 0 else "no samples"
            warnings.append(f"{what} from the {self.source} for {since:.1f} s: {silence_advice(self.source)}")
        recent = self.recent(self.amplitude_window_s)
        amplitude, snr = _spectral_peak(recent)
        if snr < MIN_SNR and self._window_full(recent.size):
            warnings.append(
                f"amplitude {amplitude:.3g} rad/s stands only {snr:.1f}× above the noise: "
                "too small to fit, swing it wider"
            )
        clip = self._clipped(self.recent(self.clip_window_s))
        if clip:
            warnings.append(clip)
        seconds = self.samples / self.rate_hz if math.isfinite(self.rate_hz) and self.rate_hz > 0 else 0.0
        return LiveStatus(self.trial_id, self.samples, seconds, amplitude, tuple(warnings))

    def _window_full(self, n: int) -> bool:
        """Whether ``n`` samples fill the amplitude window (at the known rate)."""
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            return False
        return n >= int(self.amplitude_window_s * self.rate_hz)

    @staticmethod
    def _clipped(y: FloatArray) -> str:
        if y.size < 2 * MIN_CLIP_RUN:
            return ""
        for side, extreme in (("maximum", float(np.max(y))), ("minimum", float(np.min(y)))):
            at = (y == extreme).astype(np.int8)
            edges = np.flatnonzero(np.diff(np.concatenate(([0], at, [0]))))
            runs = edges[1::2] - edges[0::2]
            if int(np.count_nonzero(runs >= MIN_CLIP_RUN)) >= 2:
                return (
                    f"the signal clips at its {side} ({extreme:.4g} rad/s held for {int(np.max(runs))} samples): "
                    "the gyro or ADC saturates, use a smaller swing"
                )
        return ""


def _spectral_peak(y: FloatArray) -> tuple[float, float]:
    """The main oscillation's amplitude (rad/s) and its spectral peak's ratio to the median bin.

    The peak bin's frequency is refined by a parabola through the log magnitudes of it and its
    neighbours, and the amplitude is the least-squares sinusoid (with offset) at that frequency,
    so a record of a fraction of a cycle more or less is not under-read. ``inf`` ratio: too few
    samples to tell.
    """
    if y.size < 64:
        return math.nan, math.inf
    mag = np.abs(np.fft.rfft(y - np.mean(y)))
    k = int(np.argmax(mag[1:])) + 1
    floor = float(np.median(mag[1:]))
    shift = 0.0
    if 1 <= k < mag.size - 1 and min(mag[k - 1], mag[k + 1]) > 0:
        a, b, c = np.log(mag[k - 1 : k + 2])
        shift = float(0.5 * (a - c) / (a - 2 * b + c)) if a - 2 * b + c != 0 else 0.0
    phase = 2 * np.pi * (k + shift) / y.size * np.arange(y.size)
    basis = np.column_stack([np.cos(phase), np.sin(phase), np.ones(y.size)])
    coef = np.linalg.lstsq(basis, y, rcond=None)[0]
    amplitude = float(np.hypot(coef[0], coef[1]))
    return amplitude, (float(mag[k]) / floor if floor > 0 else math.inf)
