"""The small-swing period (an explicit option): its systematic from trimmed windows, in its σ and the budget."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.period import WindowPolicy, combine_periods, fit_period
from bike_rig.core.period.small_swing import SMALL_SWING_SOURCE, small_swing_parts, trimmed_windows
from bike_rig.core.uncertainty.budget import uncertainty_budget
from test.core.test_period_mean import RATE_HZ, T0, swing_record
from test.support.signals import LSB


def test_trimmed_windows_leave_out_a_quarter_at_either_end() -> None:
    late, early = trimmed_windows(1.0, 29.0)
    assert (late.start_s, late.stop_s) == (8.0, 29.0) and (early.start_s, early.stop_s) == (1.0, 22.0)


def test_the_small_swing_period_carries_its_window_dependence_and_covers_the_truth() -> None:
    fits = [fit_period(swing_record(seed).samples, RATE_HZ, small_swing_period=True) for seed in range(30)]
    assert all(f.period == f.small_swing_period and math.isfinite(f.small_swing_systematic) for f in fits)
    assert all(len(f.small_swing_windows) == 4 for f in fits)  # (both trimmed windows keep the swing law)
    for f in fits:  # σ² = the fit's σ² + the systematic's
        assert f.period_sigma == pytest.approx(math.hypot(f.small_swing_period_sigma, f.small_swing_systematic))
    z = np.array([(f.period - T0) / f.period_sigma for f in fits])
    assert 0.6 <= np.mean(np.abs(z) <= 1) <= 0.95, z
    # the default is untouched: the mean period, no small-swing systematic evaluated
    plain = fit_period(swing_record(0).samples, RATE_HZ)
    assert math.isnan(plain.small_swing_systematic) and plain.period == plain.mean_period


def test_the_small_swing_period_agrees_with_itself_over_windows_within_its_sigma() -> None:
    spans = [(1.0, None), (1.0, 22.0), (8.0, None)]
    agree = total = 0
    for seed in range(10):
        record = swing_record(seed)
        fits = [
            fit_period(record.samples, RATE_HZ, window=WindowPolicy.span(*span), small_swing_period=True)
            for span in spans
        ]
        for i, a in enumerate(fits):
            for b in fits[i + 1 :]:
                total += 1
                agree += abs(a.period - b.period) <= math.hypot(a.period_sigma, b.period_sigma)
    assert agree >= 0.8 * total, (agree, total)


def test_a_late_change_gives_the_small_swing_period_a_systematic_or_a_flag() -> None:
    # the fork: the period drops 7 ms in the last 7 s, the swing hardly changing
    for seed in range(4):
        record = swing_record(seed, late=(23.0, -0.007), noise=LSB, drift=3 * LSB)
        fit = fit_period(record.samples, RATE_HZ, small_swing_period=True)
        assert fit.small_swing_systematic > 0
        assert any("the small-swing period depends on the window" in note for note in fit.notes)
        assert abs(fit.period - T0) <= fit.period_sigma


def test_combined_trials_add_their_shared_systematic_whole() -> None:
    fits = [fit_period(swing_record(seed).samples, RATE_HZ, small_swing_period=True) for seed in range(3)]
    fits = [dataclasses.replace(f, period_sigma=math.hypot(2e-4, 3e-4), small_swing_systematic=3e-4) for f in fits]
    combined = combine_periods(fits)
    # the statistical parts (2e-4 each) average down, the shared 3e-4 does not
    assert combined.systematic == pytest.approx(3e-4)
    assert combined.sigma >= 3e-4 and combined.sigma_internal == pytest.approx(2e-4 / math.sqrt(3))
    assert any("shared by the trials" in note for note in combined.notes)
    plain = combine_periods([fit_period(swing_record(seed).samples, RATE_HZ) for seed in range(3)])
    assert plain.systematic == 0.0


def test_the_budget_shows_the_small_swing_systematic_as_a_line_of_its_own() -> None:
    ps = compute_parameters(load_measurements(config_file("bicycles/browser.yaml")))
    assert ps.raw is not None
    key = next(k for k in ps.raw.names if k.startswith("TtB"))
    sigma = math.sqrt(float(ps.raw.covariance[list(ps.raw.names).index(key)][list(ps.raw.names).index(key)]))
    fit = dataclasses.replace(
        fit_period(swing_record(0).samples, RATE_HZ, small_swing_period=True), small_swing_systematic=0.6 * sigma
    )
    parts = small_swing_parts([(key, fit), ("TcB1", fit_period(swing_record(1).samples, RATE_HZ))])
    assert parts == {SMALL_SWING_SOURCE: {key: pytest.approx(0.6 * sigma)}}
    plain, split = uncertainty_budget(ps), uncertainty_budget(ps, sigma_parts=parts)
    for a, b in zip(plain.outputs, split.outputs, strict=True):
        assert b.sigma == a.sigma and sum(s.share for s in b.shares) == pytest.approx(1.0)
        whole = next((s for s in a.shares if s.key == key), None)
        if whole is None:
            continue
        line = next(s for s in b.shares if s.input.endswith(f"({SMALL_SWING_SOURCE})"))
        rest = next(s for s in b.shares if s.key == key and s is not line)
        assert line.share == pytest.approx(0.36 * whole.share) and rest.share == pytest.approx(0.64 * whole.share)
        assert math.hypot(line.contribution, rest.contribution) == pytest.approx(whole.contribution)
    assert small_swing_parts([(key, fit_period(swing_record(1).samples, RATE_HZ))]) == {}
