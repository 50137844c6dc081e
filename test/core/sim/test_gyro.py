"""The pendulum motion, the gyro and the ADC."""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.core.sim.gyro import Mode, adc_quantise, angular_rate, gyro_volts, rate_from_volts
from bike_rig.core.sim.rig import Adc, Gyro


def _angle(t: np.ndarray, m: Mode) -> np.ndarray:
    wn = 2 * np.pi / m.period
    wd = wn * np.sqrt(1 - m.damping_ratio**2)
    return m.amplitude * np.exp(-m.damping_ratio * wn * t) * np.cos(wd * t + m.phase)


def test_rate_is_the_derivative_of_the_damped_angle() -> None:
    modes = (Mode(2.1, 0.01, 0.01, 0.7), Mode(1.9, 0.01, 0.004, 2.0))
    t = np.linspace(0.0, 20.0, 2001)
    h = 1e-5
    numeric = sum((_angle(t + h, m) - _angle(t - h, m)) / (2 * h) for m in modes)
    assert angular_rate(t, modes) == pytest.approx(numeric, abs=1e-9)


def test_zero_crossings_are_half_a_damped_period_apart() -> None:
    """θ' = e^(−ζωt)(B sin + C cos)(ω_d t) vanishes every π/ω_d: the period is Eq 25's."""
    m = Mode(1.7, 0.05, 0.01, 0.3)
    t = np.arange(0.0, 30.0, 1e-4)
    r = angular_rate(t, (m,))
    i = np.nonzero(np.signbit(r[:-1]) != np.signbit(r[1:]))[0]
    crossings = t[i] - r[i] * (t[i + 1] - t[i]) / (r[i + 1] - r[i])
    assert np.diff(crossings) == pytest.approx(m.damped_period / 2, abs=1e-8)
    assert m.damped_period == pytest.approx(1.7 / np.sqrt(1 - 0.05**2), rel=1e-15)


def _gyro(**kw: float) -> Gyro:
    base = {
        "scale_factor": 1.0,
        "scale_factor_tolerance": 0.0,
        "zero_rate_output": 2.5,
        "bias": 0.0,
        "bias_drift": 0.0,
        "noise_density": 0.0,
    }
    base.update(kw)
    return Gyro(**base)


def test_white_noise_has_the_stated_density(seed: int) -> None:
    """σ per sample = density √(f_s / 2).

    With 400 000 samples the sample σ leaves ±1 % of it with probability 4e-19 (χ²), and the
    mean leaves ±6 standard errors with 2e-9.
    """
    g = _gyro(noise_density=2e-4)
    v = gyro_volts(np.zeros(400_000), g, 1000.0, 1.2, np.random.default_rng(seed))
    assert np.std((v - 2.5) / 1.2) == pytest.approx(2e-4 * np.sqrt(500.0), rel=0.01)
    assert abs(np.mean((v - 2.5) / 1.2)) < 6 * 2e-4 * np.sqrt(500.0) / np.sqrt(400_000)


def test_bias_and_its_random_walk_have_the_stated_sizes(seed: int) -> None:
    """1000 independent trials of 1 s: the turn-on bias has σ = bias and the walk grows as drift √t.

    A sample variance leaves ±40 % of the truth when χ²₉₉₉ / 999 leaves [0.6, 1.4], probability
    7e-16 per check.
    """
    rng = np.random.default_rng(seed)
    g = _gyro(bias=0.02)
    starts = np.array([gyro_volts(np.zeros(2), g, 1000.0, 1.0, rng)[0] - 2.5 for _ in range(1000)])
    assert np.var(starts) == pytest.approx(0.02**2, rel=0.4)
    g = _gyro(bias_drift=1e-3)
    walks = np.array([gyro_volts(np.zeros(1001), g, 1000.0, 1.0, rng) - 2.5 for _ in range(1000)])
    assert np.all(walks[:, 0] == 0.0)
    assert np.var(walks[:, -1]) == pytest.approx(1e-3**2 * 1.0, rel=0.4)


def test_adc_quantises_to_its_codes_and_clips_at_the_rails() -> None:
    adc = Adc(bits=12, low=-5.0, high=5.0, sample_rate=1000.0)
    v = np.linspace(-4.9, 4.9, 10_001)
    q = adc_quantise(v, adc)
    codes = (q - adc.low) / adc.lsb
    assert np.all(np.abs(codes - np.rint(codes)) < 1e-9)
    assert np.max(np.abs(q - v)) <= adc.lsb / 2 + 1e-12
    assert len(np.unique(q)) == pytest.approx(9.8 / adc.lsb, abs=2)
    clipped = adc_quantise(np.array([-7.0, 6.0, 1e9]), adc)
    assert clipped.tolist() == [adc.low, adc.high - adc.lsb, adc.high - adc.lsb]


def test_rate_is_converted_back_by_the_nominal_scale() -> None:
    g = _gyro(scale_factor=1.146, zero_rate_output=2.5)
    assert rate_from_volts(np.array([2.5, 2.5 + 1.146 * 0.03]), g) == pytest.approx([0.0, 0.03], abs=1e-15)
