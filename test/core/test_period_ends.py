"""The check of the phase at the window's ends: the record's own mean period, free of a period law."""

from __future__ import annotations

import math

import numpy as np

from bike_rig.core.period import FlagCode, fit_period
from bike_rig.core.period.ends import END_CYCLES, MIN_CYCLES, ONE_SIGMA, bias_aware_sigma, end_check
from bike_rig.core.period.stationarity import PhaseResidual
from test.core.test_period_mean import RATE_HZ, swing_record
from test.support.signals import LSB, gyro_trial


def _residual(phase: np.ndarray, noise: float, seed: int = 0) -> PhaseResidual:
    """Per-cycle departures whose phase is ``phase`` [rad] plus white noise of ``noise`` rad, at ω = 2π rad/s."""
    rng = np.random.default_rng(seed)
    amplitude = np.ones(phase.size)
    wobble = noise * (rng.standard_normal(phase.size) + 1j * rng.standard_normal(phase.size))
    return PhaseResidual((1j * phase + wobble) * amplitude, amplitude, 2 * math.pi)


def test_the_ends_measure_the_phase_gained_beyond_the_model() -> None:
    n = 20
    t = np.arange(n) + 0.5  # cycle centres, s (a 1 s period)
    # a phase linear in time is what a frequency error leaves: the ends' lines extrapolate it exactly
    check = end_check(_residual(0.01 * t, 1e-9))
    assert check is not None and math.isclose(check.shift, 0.01 * n, rel_tol=1e-6)
    # a phase that bends only in the last cycles (a late period change): the last line sees it
    late = np.where(t > 15, 0.004 * (t - 15) ** 2, 0.0)
    check = end_check(_residual(late, 1e-9))
    assert check is not None and 0.8 * 0.004 * 25 < check.shift <= 0.004 * 25 * 1.05
    # the ends' mean period: the model's moved by that phase over the window
    ends, _ = check.period(1.0)
    assert math.isclose(ends, 2 * math.pi * n / (2 * math.pi * n + check.shift))


def test_the_ends_sigma_is_the_scatter_of_their_shift_under_the_model() -> None:
    n = 24
    shifts, sigmas = [], []
    for seed in range(400):
        check = end_check(_residual(np.zeros(n), 0.01, seed))
        assert check is not None
        shifts.append(check.shift)
        sigmas.append(check.sigma)
    # (the fit's phase offset and frequency are absorbed: σ is that of the projected noise)
    assert 0.85 < np.std(shifts) / np.median(sigmas) < 1.15
    assert end_check(_residual(np.zeros(MIN_CYCLES - 1), 0.01)) is None
    assert END_CYCLES >= 2


def test_a_late_change_is_seen_by_the_ends_and_carried_by_the_sigma() -> None:
    # the fork of issue 28 on a noisy gyro: −3 ms in the last 7 s, which the swing law absorbs
    records = [swing_record(seed, late=(23.0, -0.003)) for seed in range(40)]
    fits = [fit_period(r.samples, RATE_HZ) for r in records]
    truth = np.array([r.mean_period(f.window) for f, r in zip(fits, records, strict=True)])
    period = np.array([f.period for f in fits])
    ends = np.array([f.ends_period for f in fits])
    sigma = np.array([f.period_sigma for f in fits])
    own = sigma / np.array([f.sigma_widening for f in fits])
    # the law's mean period is biased beyond its own σ; the ends' is much closer to the truth
    assert np.mean(np.abs(period - truth) <= own) < 0.25
    assert abs(np.mean(ends - truth)) < 0.5 * abs(np.mean(period - truth))
    # the widened σ covers far more often (63 % on 200 seeds: bench/bench_period_late.py)
    assert np.mean(np.abs(period - truth) <= sigma) >= 0.4
    assert not any(f.has_flag(FlagCode.PERIOD_DRIFT) for f in fits)  # (too small to be certain)


def test_every_widening_by_the_ends_is_said_in_a_note() -> None:
    # clean trials and late changes alike: whenever the ends widen σ, a note gives both periods and both σ
    records = [swing_record(seed, late=(23.0, -0.003 * (seed % 2))) for seed in range(30)]
    fits = [fit_period(r.samples, RATE_HZ) for r in records]
    widened = [f for f in fits if any("is widened to" in note for note in f.notes)]
    # (the distance's σ under the law is at most ends_period_sigma: beyond it the ends surely depart)
    departed = [f for f in fits if abs(f.ends_period - f.period) > f.ends_period_sigma]
    assert departed and set(map(id, departed)) <= set(map(id, widened))
    for f in widened:
        note = next(note for note in f.notes if "is widened to" in note)
        assert f"{f.period_sigma:.2g} s to hold" in note and f"{f.ends_period:.6g}" in note


def test_short_records_have_no_ends_check_and_steady_ones_agree_with_it() -> None:
    short = fit_period(gyro_trial(1, period=2.0, duration=10.0).samples, RATE_HZ)
    assert short.valid and math.isnan(short.ends_period)
    fits = [fit_period(gyro_trial(seed, period=1.5, zeta=0.003).samples, RATE_HZ) for seed in range(100)]
    z = np.array([(f.ends_period - 1.5) / f.ends_period_sigma for f in fits])
    assert 0.55 <= np.mean(np.abs(z) <= 1) <= 0.85, z  # (the ends' own σ is honest)


def test_the_bias_aware_sigma_holds_one_sigma_of_the_truth_whatever_the_distance() -> None:
    rng = np.random.default_rng(3)
    assert math.isclose(bias_aware_sigma(0.0, 3.0, 4.0), 5.0, rel_tol=1e-9)  # (no distance: the combined σ)
    for distance, sigma_distance, sigma in [(0.5, 1.0, 0.3), (-1.5, 1.0, 0.5), (6.0, 1.0, 2.0), (-40.0, 2.0, 1.0)]:
        h = bias_aware_sigma(distance, sigma_distance, sigma)
        scale = math.hypot(sigma_distance, sigma)
        # the truth about the model's value: N(distance, S²); ±h holds ONE_SIGMA of it
        truth = distance + scale * rng.standard_normal(200_000)
        assert abs(np.mean(np.abs(truth) <= h) - ONE_SIGMA) < 0.004
        assert abs(distance) < h < abs(distance) + scale  # (beyond the distance, less than a σ beyond)
    assert math.isclose(bias_aware_sigma(-40.0, 2.0, 1.0), 40.0 + 0.4747 * math.sqrt(5.0), rel_tol=1e-4)


def test_the_ends_refer_to_the_models_own_period_when_the_windows_moved_it() -> None:
    # the record on a quiet gyro: the windowed test rejects the swing law and moves the
    # period to the windows'; the ends' phase departures are the model's, so is their period
    records = [swing_record(seed, late=(23.0, -0.007), noise=LSB, drift=3 * LSB) for seed in range(20)]
    fits = [fit_period(r.samples, RATE_HZ) for r in records]
    assert all(any("the mean period is the windows'" in note for note in f.notes) for f in fits)
    z = np.array([(f.ends_period - r.mean_period(f.window)) / f.ends_period_sigma for f, r in zip(fits, records)])
    assert np.median(np.abs(z)) < 1.5, z  # (referred to the windows' period instead: about 8)
