"""Beating (the paper's Fig. 7) is flagged; clean trials are not flagged at all."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from bike_rig.core.period import FlagCode, fit_period
from test.support.signals import LSB, coupled_trial, gyro_trial

N_CLEAN = 200


def test_coupled_swing_mode_is_flagged_as_beating() -> None:
    flagged = 0
    n = 60
    for seed in range(n):
        r = np.random.default_rng(seed)
        trial = coupled_trial(seed, period=r.uniform(0.8, 1.6), ratio=1.03, exchange=r.uniform(0.3, 0.9))
        fit = fit_period(trial.samples, sample_rate_hz=1000.0)
        flagged += fit.has_flag(FlagCode.BEATING)
        if fit.has_flag(FlagCode.BEATING):
            assert "two close modes" in next(f.reason for f in fit.flags if f.code is FlagCode.BEATING)
            assert fit.modulation > 0.02
    assert flagged == n


@pytest.mark.parametrize(("ratio", "exchange"), [(1.03, 0.1), (0.97, 0.5), (1.05, 1.0)])
def test_weaker_or_other_coupled_modes_are_flagged(ratio: float, exchange: float) -> None:
    fits = [fit_period(coupled_trial(s, period=1.2, ratio=ratio, exchange=exchange).samples, 1000.0) for s in range(20)]
    assert sum(f.has_flag(FlagCode.BEATING) for f in fits) >= 19


def test_beating_biases_the_period_far_beyond_sigma() -> None:
    # why the flag matters: even a 10 % second mode moves the period beyond the fit's own σ (the
    # check of the window's ends widens it to carry part of that)
    fit = fit_period(coupled_trial(3, period=1.2, exchange=0.1).samples, 1000.0)
    assert abs(fit.period - 1.2) > 2 * fit.period_sigma / fit.sigma_widening
    assert not fit.clean


def _clean_trial(seed: int) -> tuple[np.ndarray, float]:
    r = np.random.default_rng(50_000 + seed)
    rate = float(r.choice([100.0, 1000.0, 1000.0, 1000.0, 10000.0]))
    trial = gyro_trial(
        seed,
        period=r.uniform(0.7, 2.5),
        zeta=r.uniform(0.0005, 0.02),
        amplitude=r.uniform(0.03, 0.08),
        noise=r.uniform(0.3, 2.0) * LSB,
        drift=r.uniform(0.0, 6.0) * LSB,
        rate_hz=rate,
        duration=30.0 if rate < 5000 else 15.0,
    )
    return trial.samples, rate


def test_clean_trials_are_not_flagged() -> None:
    codes: Counter[str] = Counter()
    flagged = 0
    for seed in range(N_CLEAN):
        samples, rate = _clean_trial(seed)
        fit = fit_period(samples, sample_rate_hz=rate)
        assert fit.valid
        codes.update(fit.flag_codes)
        flagged += bool(fit.flags)
    assert codes["beating"] < 0.02 * N_CLEAN, codes
    assert flagged < 0.02 * N_CLEAN, codes


def test_noise_free_quantised_trials_are_not_flagged() -> None:
    # the hardest case for the clipping and held-sample tests: long plateaus at every peak
    for seed in range(20):
        for kw in ({"amplitude": 0.01, "rate_hz": 10000.0, "duration": 10.0}, {"amplitude": 0.005}):
            trial = gyro_trial(seed, noise=0.0, drift=0.0, zeta=0.0, **kw)  # type: ignore[arg-type]
            fit = fit_period(trial.samples, sample_rate_hz=trial.rate_hz)
            assert fit.clean, (seed, kw, fit.flags)
