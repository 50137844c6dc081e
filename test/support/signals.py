"""Synthetic rate-gyro trials for the period fitter's tests.

A trial is the paper's rig in miniature: a damped oscillation (Eq 23) seen by a rate gyro with
white noise, a bias that drifts as a random walk, and a 12-bit ADC over ±100 °/s (the
CRS03-100 of the paper on a 12-bit DAQ). Optionally a second, close mode (the coupled swing of
the paper's Fig. 7) with energy exchange.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bike_rig.core.sim.pendulum import PendulumMotion, pendulum_rate

FULL_SCALE = math.radians(100.0)  # ±100 °/s in rad/s
BITS = 12
LSB = 2 * FULL_SCALE / 2**BITS  # ≈ 8.5e-4 rad/s


@dataclass(frozen=True)
class GyroTrial:
    """A simulated trial and its truth."""

    samples: NDArray[np.float64]
    times: NDArray[np.float64]
    rate_hz: float
    period: float  # the true damped period T = 2π / (ω sqrt(1 − ζ²)) [s]
    zeta: float
    omega: float
    truth: dict[str, float] = field(default_factory=dict)


def quantise(y: NDArray[np.float64], bits: int = BITS, full_scale: float = FULL_SCALE) -> NDArray[np.float64]:
    """A ``bits``-bit ADC over ±full_scale: rounds to its steps and saturates at its ends."""
    lsb = 2 * full_scale / 2**bits
    code = np.clip(np.round((y + full_scale) / lsb), 0, 2**bits - 1)
    return code * lsb - full_scale


def gyro_trial(
    seed: int,
    period: float = 1.5,
    zeta: float = 0.003,
    amplitude: float = 0.05,
    rate_hz: float = 1000.0,
    duration: float = 30.0,
    noise: float = LSB,
    drift: float = 3 * LSB,
    bias: float = 0.01,
    bits: int | None = BITS,
    times: NDArray[np.float64] | None = None,
    second_mode: tuple[float, float] | None = None,
) -> GyroTrial:
    """One simulated trial.

    Args:
        seed: Seed of the random generator.
        period: True damped period [s].
        zeta: Damping ratio.
        amplitude: Rate amplitude at t = 0 [rad/s].
        rate_hz: Sample rate [Hz] (ignored with ``times``).
        duration: Record length [s] (ignored with ``times``).
        noise: White noise σ [rad/s].
        drift: σ of the bias random walk at the end of the record [rad/s].
        bias: Constant gyro bias [rad/s].
        bits: ADC resolution, or None for no quantisation.
        times: Sample times [s], for uneven sampling.
        second_mode: (frequency ratio, relative amplitude) of a second, close mode.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(round(duration * rate_hz)) / rate_hz if times is None else np.asarray(times, dtype=float)
    omega_d = 2 * math.pi / period
    omega = omega_d / math.sqrt(1 - zeta**2)
    phase = rng.uniform(0, 2 * math.pi)
    y = bias + amplitude * np.exp(-zeta * omega * t) * np.sin(omega_d * t + phase)
    if second_mode is not None:
        ratio, rho = second_mode
        y += rho * amplitude * np.exp(-zeta * omega * t) * np.sin(ratio * omega_d * t + rng.uniform(0, 2 * math.pi))
    y += noise * rng.standard_normal(t.size)
    y += np.cumsum(rng.standard_normal(t.size)) * (drift / math.sqrt(t.size))
    if bits is not None:
        y = quantise(y, bits)
    return GyroTrial(y, t, rate_hz, period, zeta, omega, {"phase": phase})


def coupled_trial(seed: int, period: float = 1.0, ratio: float = 1.03, exchange: float = 0.8, **kw: float) -> GyroTrial:
    """The paper's beating: torsion coupled to a swinging mode ``ratio`` times faster.

    Started torsionally, the energy flows to the swing and back at the beat frequency. The gyro
    sees both normal modes; ``exchange`` is the second mode's relative amplitude (1: the
    torsion stops completely at each half beat; the paper saw "neither ever reaching zero").
    """
    return gyro_trial(seed, period=period, second_mode=(ratio, exchange), **kw)  # type: ignore[arg-type]


RATE_HZ = 1000.0


def pendulum_trial(
    seed: int,
    period: float = 1.6,
    zeta: float = 0.0,
    loss_per_cycle: float = 0.0,
    compound: bool = False,
    swing: float | None = None,
    rate_amplitude: float = 0.05,
    duration: float = 30.0,
) -> tuple[np.ndarray, PendulumMotion]:
    """A pendulum's rate through the test gyro: rad/s samples at 1 kHz, and its motion."""
    (samples,), motion = pendulum_trials(
        [seed], period, zeta, loss_per_cycle, compound, swing, rate_amplitude, duration
    )
    return samples, motion


def pendulum_trials(
    seeds: Iterable[int],
    period: float = 1.6,
    zeta: float = 0.0,
    loss_per_cycle: float = 0.0,
    compound: bool = False,
    swing: float | None = None,
    rate_amplitude: float = 0.05,
    duration: float = 30.0,
) -> tuple[list[np.ndarray], PendulumMotion]:
    """:func:`pendulum_trial` of each seed, the same samples, with one integration of the motion.

    The seeds' records differ only in the phase they start at and in their noise: one
    :func:`pendulum_rate` call over every record's sample times (each shifted by its phase)
    integrates the shared motion once and evaluates it where each record needs it.
    """
    rngs = [np.random.default_rng(seed) for seed in seeds]
    w0 = 2 * math.pi / period
    theta0 = rate_amplitude / w0 if swing is None else swing
    motion = PendulumMotion(period, theta0, zeta, loss_per_cycle * theta0 * w0**2 / 4, compound)
    t = np.arange(round(duration * RATE_HZ)) / RATE_HZ
    shifted = np.concatenate([t + float(rng.uniform(0, period)) for rng in rngs])
    order = np.argsort(shifted, kind="stable")
    rates = np.empty_like(shifted)
    rates[order] = pendulum_rate(shifted[order], motion)
    out = []
    for rng, rate in zip(rngs, np.split(rates, len(rngs)), strict=True):
        y = rate * (rate_amplitude / (theta0 * w0))
        y += 0.01 + LSB * rng.standard_normal(t.size)
        y += np.cumsum(rng.standard_normal(t.size)) * (3 * LSB / math.sqrt(t.size))
        out.append(quantise(y))
    return out, motion
