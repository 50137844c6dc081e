"""Records without an oscillation must have no period; real oscillations keep theirs.

Prints counts, asserts nothing:

1. **Noise records** (no oscillation at all), ``--records`` of each kind (default 1000), each
   5–60 s at 1 kHz: white Gaussian noise; the quantised noise of a silent gyro (a 12-bit and a
   16-bit ADC: a constant offset code plus ±1–2 LSB); a random walk; a random walk under white
   noise; 1/f noise; a slow drift (a ramp, a parabola or a warm-up exponential under quantised
   noise); a constant; a single step; a single spike. How many are called valid (the design:
   at most 1e-4 of the records of any kind, ``bike_rig.core.period.detection``), and why the
   others are not.
2. **Real oscillations** at decreasing amplitude (a decaying sinusoid, ζ = 0.002, T from 1 to
   2 s, random phase, under white noise of σ = 1 at 1 kHz; 30 s records, and 10 s records of
   T = 2 to 2.5 s, a few cycles only): the fraction called valid at each amplitude, and how
   often a valid period lies within 3σ of the truth. SNR is given two ways: the amplitude over
   the noise's σ per sample (a/σ at 1 kHz), and the signal's energy over the noise variance,
   ``N a² / (2 σ²)`` (N samples, the decay neglected): the matched filter's SNR², which does
   not depend on the sample rate.

Every record's seed is ``--seed`` + its index, printed with the kinds; a record can be redone
with ``--only KIND --seed S --records 1``.
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter
from collections.abc import Callable

import numpy as np

from bike_rig.core.period import fit_period

RATE_HZ = 1000.0
FloatArray = np.ndarray
Noise = Callable[[np.random.Generator, int], FloatArray]


def _white(rng: np.random.Generator, n: int) -> FloatArray:
    return rng.normal(0.0, 1.0, n)


def _adc(bits: int) -> Noise:
    """A silent gyro seen by a ``bits`` ADC: mid-scale code plus noise of 0.3 to 1 LSB (±1–2 LSB)."""

    def noise(rng: np.random.Generator, n: int) -> FloatArray:
        offset = 2 ** (bits - 1) + rng.uniform(-20.0, 20.0)
        return np.round(offset + rng.normal(0.0, rng.uniform(0.3, 1.0), n))

    return noise


def _walk(rng: np.random.Generator, n: int) -> FloatArray:
    return np.cumsum(rng.normal(0.0, 1.0, n))


def _walk_under_white(rng: np.random.Generator, n: int) -> FloatArray:
    return np.cumsum(rng.normal(0.0, 10 ** rng.uniform(-3.0, 0.0), n)) + rng.normal(0.0, 1.0, n)


def _flicker(rng: np.random.Generator, n: int) -> FloatArray:
    spectrum = np.fft.rfft(rng.normal(0.0, 1.0, n))
    f = np.arange(spectrum.size, dtype=float)
    f[0] = 1.0
    return np.fft.irfft(spectrum / np.sqrt(f), n)


def _drift(rng: np.random.Generator, n: int) -> FloatArray:
    x = np.linspace(0.0, 1.0, n)
    shape = rng.integers(3)
    slow = x if shape == 0 else (x - rng.uniform(0, 1)) ** 2 if shape == 1 else 1 - np.exp(-x / rng.uniform(0.05, 0.5))
    return np.round(2048 + rng.uniform(-30, 30) * slow + rng.normal(0.0, rng.uniform(0.3, 1.0), n))


def _constant(rng: np.random.Generator, n: int) -> FloatArray:
    return np.full(n, float(rng.integers(4096)))


def _step(rng: np.random.Generator, n: int) -> FloatArray:
    y = rng.normal(0.0, 0.01, n)
    y[rng.integers(1, n) :] += rng.choice((-1.0, 1.0))
    return y


def _spike(rng: np.random.Generator, n: int) -> FloatArray:
    y = rng.normal(0.0, 0.01, n)
    y[rng.integers(n)] += rng.uniform(5.0, 500.0)
    return y


KINDS: dict[str, Noise] = {
    "white": _white,
    "adc12": _adc(12),
    "adc16": _adc(16),
    "random_walk": _walk,
    "walk+white": _walk_under_white,
    "1/f": _flicker,
    "slow_drift": _drift,
    "constant": _constant,
    "step": _step,
    "spike": _spike,
}


def noise_records(kinds: list[str], records: int, seed: int) -> None:
    """Part 1: how many records of each noise kind are called valid."""
    print(f"noise records: {records} of each kind, 5-60 s at {RATE_HZ:g} Hz, seeds {seed}..{seed + records - 1}")
    print(f"{'kind':<12} {'records':>7} {'valid':>5}  why the others have no period")
    total_valid = 0
    for kind in kinds:
        why: Counter[str] = Counter()
        valid = 0
        for i in range(records):
            rng = np.random.default_rng(seed + i)
            n = int(rng.uniform(5.0, 60.0) * RATE_HZ)
            fit = fit_period(KINDS[kind](rng, n), sample_rate_hz=RATE_HZ)
            if fit.valid:
                valid += 1
                print(f"  VALID: {kind} seed {seed + i}, {n} samples: {fit.period:.4g} s {fit.flag_codes}")
            else:
                why[fit.flags[-1].code.value] += 1
        total_valid += valid
        reasons = ", ".join(f"{code} {count}" for code, count in why.most_common())
        print(f"{kind:<12} {records:>7} {valid:>5}  {reasons}")
    print(f"valid: {total_valid} of {records * len(kinds)} noise records")


def _oscillation(rng: np.random.Generator, amplitude: float, duration: float, period: float) -> FloatArray:
    """A decaying sinusoid (ζ = 0.002) of initial ``amplitude`` under white noise of σ = 1."""
    zeta = 0.002
    t = np.arange(int(duration * RATE_HZ)) / RATE_HZ
    omega_d = 2 * math.pi / period
    omega = omega_d / math.sqrt(1 - zeta**2)
    y = amplitude * np.exp(-zeta * omega * t) * np.sin(omega_d * t + rng.uniform(0, 2 * math.pi))
    return y + rng.normal(0.0, 1.0, t.size)


def oscillation_sweep(per_level: int, seed: int, duration: float, periods: tuple[float, float]) -> None:
    """Part 2: the fraction of real oscillations called valid, by amplitude."""
    levels = np.geomspace(0.03, 1.0, 13)
    n = int(duration * RATE_HZ)
    print(
        f"\nreal oscillations: {duration:g} s, T {periods[0]:g}-{periods[1]:g} s, zeta 0.002, white noise sigma 1; "
        f"{per_level} per amplitude, seeds {seed}..{seed + per_level - 1}"
    )
    print(f"{'a/sigma':>8} {'N a2/2s2':>9} {'valid':>7} {'within 3 sigma':>15}")
    half = None
    for amplitude in levels:
        valid = covered = 0
        for i in range(per_level):
            rng = np.random.default_rng(seed + i)
            period = rng.uniform(*periods)
            fit = fit_period(_oscillation(rng, float(amplitude), duration, period), sample_rate_hz=RATE_HZ)
            if fit.valid:
                valid += 1
                covered += abs(fit.period - period) <= 3 * fit.period_sigma
        energy = n * amplitude**2 / 2
        if half is None and valid >= per_level / 2:
            half = (amplitude, energy)
        print(f"{amplitude:8.3f} {energy:9.0f} {valid:>3}/{per_level:<3} {covered:>7}/{valid:<3}")
    if half is not None:
        print(f"valid in half the records from a/sigma = {half[0]:.3f} (N a2/2s2 = {half[1]:.0f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=1000, help="noise records per kind (default 1000)")
    parser.add_argument("--per-level", type=int, default=50, help="oscillations per amplitude (default 50)")
    parser.add_argument("--seed", type=int, default=20261126, help="seed of the first record")
    parser.add_argument("--only", choices=sorted(KINDS), help="one noise kind, and no oscillation sweep")
    args = parser.parse_args()
    start = time.perf_counter()
    noise_records([args.only] if args.only else list(KINDS), args.records, args.seed)
    if not args.only:
        oscillation_sweep(args.per_level, args.seed, 30.0, (1.0, 2.0))
        oscillation_sweep(args.per_level, args.seed, 10.0, (2.0, 2.5))
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
