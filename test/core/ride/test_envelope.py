"""The free-decay check: a dip and a bump is flagged whatever the fit's σ; free decays are not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import Feedback, resolve_feedback
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.envelope import envelope_problem, half_cycle_amplitudes
from bike_rig.core.ride.ridesim import RideConditions, simulate_log, simulate_segment
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import WhippleMatrices

OMEGA = 8.7  # rad/s
DT = 0.01
Ride = tuple[WhippleMatrices, float, Feedback]


def _swing(amplitudes: tuple[float, ...], seed: int, noise: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """A weave whose half-cycle peaks are ``amplitudes`` (linear between them), with white noise [rad/s]."""
    t = np.arange(0.0, (len(amplitudes) + 0.6) * math.pi / OMEGA, DT)
    at = 0.05 + (np.arange(len(amplitudes)) + 0.5) * math.pi / OMEGA
    clean = np.interp(t, at, amplitudes) * np.sin(OMEGA * (t - 0.05))
    return t, clean + np.random.default_rng(seed).normal(0.0, noise, t.size)


def test_half_cycle_amplitudes_measure_a_sine_and_their_white_noise() -> None:
    t = np.arange(0.0, 2.0, DT)
    h = half_cycle_amplitudes(t, 0.2 * np.sin(OMEGA * t + 0.3), OMEGA)
    assert h.amplitudes.size == 4  # the cut ends hold no whole half-cycle
    assert h.amplitudes == pytest.approx(0.2, rel=0.01)
    n = math.pi / OMEGA / DT  # samples a half-cycle
    assert h.white == pytest.approx(math.sqrt(2.0 / n), rel=0.1)  # σ_a / σ_w = 1 / √Σ sin²
    spread = [half_cycle_amplitudes(*_swing((0.2,) * 4, s), OMEGA).amplitudes for s in range(200)]
    assert np.std(spread) == pytest.approx(0.01 * np.mean(h.white), rel=0.25)


def test_a_bump_one_second_into_a_decay_is_flagged_whatever_the_fits_sigma() -> None:
    """A dip and a bump (the hole: Re −0.4 ± 0.9, rises and falls each within the old tolerance)."""
    bumped = (0.20, 0.18, 0.165, 0.15, 0.215, 0.20)
    for seed in range(10):
        t, y = _swing(bumped, seed)
        problem = envelope_problem(t, y, OMEGA, -0.4, 0.9, 0.01)
        assert problem is not None and problem.startswith("not_free_decay"), (seed, problem)


@pytest.mark.parametrize("amplitudes", [(0.09, 0.09, 0.16, 0.16), (0.12, 0.11, 0.10, 0.17, 0.17)])
def test_an_envelope_that_steps_up_and_levels_off_is_flagged(amplitudes: tuple[float, ...]) -> None:
    """A dip hidden before the first whole half-cycle: only the rise that levels off is left to see."""
    for seed in range(10):
        t, y = _swing(amplitudes, seed)
        problem = envelope_problem(t, y, OMEGA, 0.3, 1.2, 0.01)
        assert problem is not None and problem.startswith("not_free_decay"), (seed, problem)


@pytest.mark.parametrize("shift", [1.2, -1.2])
def test_a_phase_jump_is_flagged_where_the_envelope_looks_free(shift: float) -> None:
    """A push out of phase at the third peak: the cycle over it is 1.2 / 2π ≈ 19 % off the others."""
    t = np.arange(0.0, 6.6 * math.pi / OMEGA, DT)
    phase = OMEGA * (t - 0.05) + shift * (t > 0.05 + 2.5 * math.pi / OMEGA)
    for seed in range(10):
        y = 0.15 * np.sin(phase) + np.random.default_rng(seed).normal(0.0, 0.01, t.size)
        assert envelope_problem(t, y, OMEGA, 0.0, 0.9, 0.01) is not None, seed
        steady = 0.15 * np.sin(OMEGA * (t - 0.05)) + np.random.default_rng(seed).normal(0.0, 0.01, t.size)
        assert envelope_problem(t, steady, OMEGA, 0.0, 0.9, 0.01) is None, seed


@pytest.mark.parametrize(
    "amplitudes",
    [
        (0.09, 0.092, 0.10, 0.12, 0.16, 0.22),  # a growth whose small start the rider held up
        (0.20, 0.17, 0.145, 0.123, 0.105, 0.09),  # a decay
        (0.09, 0.105, 0.123, 0.145, 0.17, 0.20),  # a growth
        (0.20, 0.15, 0.12, 0.105, 0.095, 0.09),  # a decay whose rate falls: monotone, bent, no pump
        (0.15,) * 6,  # undamped
    ],
)
def test_monotone_envelopes_are_free_decays_when_the_fit_cannot_tell_the_direction(
    amplitudes: tuple[float, ...],
) -> None:
    for seed in range(10):
        t, y = _swing(amplitudes, seed)
        assert envelope_problem(t, y, OMEGA, 0.0, 0.9, 0.01) is None, seed


@pytest.fixture(scope="module")
def ride() -> Ride:
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None
    return browser.matrices, browser.g, fb


def _pumped(ride: Ride, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """A simulated decay (×2 roll-rate gain, 2.5 m/s: −0.57 + 10.4i) with a second push ~1 s in that pumps it.

    Returns the times [s], the measured roll rate [rad/s] and the bump: the half-cycle amplitude
    after the push over the one before it (noise-free record).
    """
    matrices, g, fb = ride
    gains = fb.gains(2.5) * np.array([1.0, 1.0, 2.0, 1.0])
    rng = np.random.default_rng(seed)
    quiet = RideConditions(noise=0.0, rider_torque=0.0, saturation=math.inf)
    _, response, weave = simulate_log(matrices, g, 2.5, gains, 5.0, (0.0,), quiet, rng)
    period = 2.0 * math.pi / weave.imag
    at = float(rng.uniform(0.8, 1.2))
    free = simulate_segment(
        matrices,
        g,
        2.5,
        gains,
        max(2.0, at / period + 0.8),
        RideConditions(noise=0.0, rider_torque=0.2),
        rng,
    )
    i = int(round(at / DT))
    push = np.zeros_like(free.roll_rate)
    push[i:] = float(rng.uniform(0.4, 1.0)) * response[: push.size - i]
    after = slice(i, i + int(0.75 * period / DT))
    pumping = 1.0 if np.abs(free.roll_rate + push)[after].max() > np.abs(free.roll_rate - push)[after].max() else -1.0
    y = free.roll_rate + pumping * push
    h = half_cycle_amplitudes(free.times, y - y.mean(), weave.imag)
    ratio = h.amplitudes[h.times > free.times[i]].max() / h.amplitudes[h.times < free.times[i]][-1]
    return free.times, y + rng.normal(0.0, 0.01, y.size), float(ratio)


def test_a_simulated_ride_pumped_about_one_second_in_is_flagged(ride: Ride) -> None:
    """Most clear bumps (≥ 1.3 times the half-cycle before) are flagged, none left clean with the flag."""
    clear = [(t, y) for t, y, ratio in (_pumped(ride, seed) for seed in range(14)) if ratio >= 1.3]
    assert len(clear) >= 8
    found = [fit_segment(t, y, speed=2.5) for t, y in clear]
    flagged = [any(f.startswith("not_free_decay") for f in m.flags) for m in found]
    assert sum(flagged) >= 0.6 * len(clear), [m.flags for m in found]
    assert not any(m.clean for m, f in zip(found, flagged, strict=True) if f)


def test_simulated_free_decays_are_rarely_flagged(ride: Ride) -> None:
    assert _envelope_flagged(ride, ((2.5, 2.0), (4.2, 2.0), (3.0, 1.0), (4.5, 1.0)), seed=11) <= 1


def test_simulated_growing_weaves_are_rarely_flagged(ride: Ride) -> None:
    """Unstable weaves (shipped gains at 2 m/s: +0.36/s; half the roll-rate gain at 3 m/s: +0.66/s)."""
    assert _envelope_flagged(ride, ((2.0, 1.0), (3.0, 0.5)), seed=12) <= 1


def _envelope_flagged(ride: Ride, cases: tuple[tuple[float, float], ...], seed: int) -> int:
    """How many of 6 simulated segments per (speed [m/s], roll-rate gain scale) the envelope check flags."""
    matrices, g, fb = ride
    rng = np.random.default_rng(seed)
    flagged = 0
    for v, scale in cases:
        gains = fb.gains(v) * np.array([1.0, 1.0, scale, 1.0])
        for _ in range(6):
            s = simulate_segment(
                matrices, g, v, gains, float(rng.uniform(1.2, 2.5)), RideConditions(rider_torque=0.2), rng
            )
            flags = fit_segment(s.times, s.roll_rate, speed=v).flags
            flagged += any(f.startswith("not_free_decay: the envelope") for f in flags)
    return flagged
