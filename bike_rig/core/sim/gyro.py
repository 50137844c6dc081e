"""One trial's signal: a lightly damped pendulum seen through the rate gyro and the ADC.

θ(t) = θ₀ e^(−ζ ωₙ t) cos(ω_d t + φ), ω_d = ωₙ √(1 − ζ²); the gyro senses θ'(t) (paper Eq 23),
or the sum of two close modes when the swing beats (Fig 7). Sensor chain (section 9: CRS03,
NI USB-6008, 1 kHz): v = V₀ + s (ω + b(t) + n(t)) with true scale s, bias b (turn-on plus random
walk) and white noise n (σ = density √(f_s / 2)); quantised to ``bits`` over the input range
(mid-tread) and clipped at the rails; stored as (v − V₀) / s_nominal, rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .rig import Adc, Gyro

__all__ = ["Mode", "adc_quantise", "angular_rate", "gyro_volts", "rate_from_volts"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Mode:
    """One damped oscillation mode of the pendulum angle.

    Attributes:
        period: Undamped natural period 2π / ωₙ, s.
        damping_ratio: ζ.
        amplitude: θ₀, rad.
        phase: φ, rad.
    """

    period: float
    damping_ratio: float
    amplitude: float
    phase: float

    @property
    def damped_period(self) -> float:
        """The period of the observed oscillation, 2π / ω_d = T / √(1 − ζ²), s (paper Eq 25)."""
        return self.period / float(np.sqrt(1.0 - self.damping_ratio**2))


def angular_rate(t: FloatArray, modes: tuple[Mode, ...]) -> FloatArray:
    """Rate of the pendulum angle, rad/s: the time derivative of the sum of the modes.

    Args:
        t: Sample times, s.
        modes: One mode, or two for a beating trial.

    Returns:
        θ'(t) = Σ θ₀ e^(−ζωₙt) [−ζωₙ cos(ω_d t + φ) − ω_d sin(ω_d t + φ)], rad/s.
    """
    rate = np.zeros_like(t)
    for m in modes:
        wn = 2.0 * np.pi / m.period
        wd = wn * np.sqrt(1.0 - m.damping_ratio**2)
        arg = wd * t + m.phase
        decay = m.amplitude * np.exp(-m.damping_ratio * wn * t)
        rate += decay * (-m.damping_ratio * wn * np.cos(arg) - wd * np.sin(arg))
    return rate


def gyro_volts(
    rate: FloatArray, gyro: Gyro, sample_rate: float, scale_factor: float, rng: np.random.Generator
) -> FloatArray:
    """Analogue output of the gyro, V (before the ADC).

    Args:
        rate: True angular rate about the sensitive axis, rad/s.
        gyro: The gyro's description (bias, drift and noise).
        sample_rate: Samples per second, Hz.
        scale_factor: This gyro's true scale factor, V / (rad/s).
        rng: Source of the bias, its random walk and the noise.

    Returns:
        V₀ + s (rate + b₀ + random walk + white noise), V.
    """
    n = rate.shape[-1]
    bias = gyro.bias * rng.standard_normal()
    steps = rng.standard_normal(size=(n,))
    steps[0] = 0.0
    drift = np.cumsum(steps) * (gyro.bias_drift / np.sqrt(sample_rate))
    noise = gyro.noise_sigma(sample_rate) * rng.standard_normal(size=(n,))
    return gyro.zero_rate_output + scale_factor * (rate + bias + drift + noise)


def adc_quantise(volts: FloatArray, adc: Adc) -> FloatArray:
    """What the ADC reads: the nearest code of ``bits`` over [low, high], clipped at the rails, V.

    Codes 0 … 2^bits − 1 stand for low + code × LSB.
    """
    top = 2**adc.bits - 1
    codes = np.clip(np.rint((volts - adc.low) / adc.lsb), 0, top)
    return adc.low + codes * adc.lsb


def rate_from_volts(volts: FloatArray, gyro: Gyro) -> FloatArray:
    """Rate as the acquisition software stores it: (v − V₀) / s_nominal, rad/s."""
    return (volts - gyro.zero_rate_output) / gyro.scale_factor
