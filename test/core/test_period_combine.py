"""combine_periods: weighted mean, Birge ratio, and what is left out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.core.period import DEFAULT_WINDOW, CombinedPeriod, Flag, FlagCode, PeriodFit, combine_periods, fit_period
from test.support.signals import gyro_trial


def _fit(period: float, sigma: float, flags: tuple[Flag, ...] = ()) -> PeriodFit:
    return PeriodFit(
        period=period,
        period_sigma=sigma,
        zeta=0.0,
        omega=2 * math.pi / period,
        A=0.0,
        B=0.0,
        C=1.0,
        r2=1.0,
        residual_rms=0.0,
        n_cycles=20.0,
        n_samples=30000,
        window=(0, 30000),
        valid=True,
        flags=flags,
        window_policy=DEFAULT_WINDOW,
    )


BEATING = Flag(FlagCode.BEATING, "beats")


def test_weighted_mean_and_internal_sigma() -> None:
    got = combine_periods([_fit(1.0, 0.1), _fit(1.1, 0.2)])
    w1, w2 = 1 / 0.1**2, 1 / 0.2**2
    assert got.value == pytest.approx((w1 * 1.0 + w2 * 1.1) / (w1 + w2), rel=1e-14)
    assert got.sigma_internal == pytest.approx(1 / math.sqrt(w1 + w2), rel=1e-14)
    chi2 = w1 * (1.0 - got.value) ** 2 + w2 * (1.1 - got.value) ** 2
    assert got.chi2 == pytest.approx(chi2, rel=1e-12) and got.dof == 1
    assert got.birge_ratio == pytest.approx(math.sqrt(chi2), rel=1e-12)
    assert got.birge_ratio < 1 and got.sigma == got.sigma_internal  # consistent: no inflation
    assert (got.n_used, got.n_flagged, got.n_invalid) == (2, 0, 0)


def test_scatter_beyond_sigma_inflates_by_the_birge_ratio() -> None:
    got = combine_periods([_fit(1.000, 1e-4), _fit(1.003, 1e-4), _fit(0.998, 1e-4)])
    assert got.value == pytest.approx(1.000333333, rel=1e-9)
    expected_chi2 = sum(((p - got.value) / 1e-4) ** 2 for p in (1.000, 1.003, 0.998))
    assert got.chi2 == pytest.approx(expected_chi2, rel=1e-9)
    assert got.birge_ratio == pytest.approx(math.sqrt(expected_chi2 / 2), rel=1e-9)
    assert got.sigma == pytest.approx(got.sigma_internal * got.birge_ratio, rel=1e-12)
    # the inflated σ is the standard error of the mean of the scatter
    assert got.sigma == pytest.approx(np.std([1.000, 1.003, 0.998], ddof=1) / math.sqrt(3), rel=1e-9)
    assert any("Birge ratio" in n for n in got.notes)


def test_flagged_and_invalid_trials_are_left_out_but_counted() -> None:
    invalid = fit_period(np.zeros(100), sample_rate_hz=1000.0)
    got = combine_periods([_fit(1.0, 0.01), _fit(2.0, 0.01, (BEATING,)), invalid, _fit(1.02, 0.01)])
    assert got.value == pytest.approx(1.01)
    assert (got.n_used, got.n_flagged, got.n_invalid) == (2, 1, 1)
    assert any("trial 2 left out, redo it: beating: beats" in n for n in got.notes)
    assert any(n.startswith("trial 3 has no period") for n in got.notes)
    with_flagged = combine_periods([_fit(1.0, 0.01), _fit(2.0, 0.01, (BEATING,))], include_flagged=True)
    assert with_flagged.n_used == 2 and with_flagged.value == pytest.approx(1.5)


def test_nothing_usable() -> None:
    got = combine_periods([_fit(1.0, 0.01, (BEATING,))])
    assert isinstance(got, CombinedPeriod)
    assert math.isnan(got.value) and math.isnan(got.sigma)
    assert (got.n_used, got.n_flagged) == (0, 1) and "no usable trial" in got.notes
    assert math.isnan(combine_periods([]).value)


def test_single_trial_keeps_its_sigma() -> None:
    got = combine_periods([_fit(1.5, 2e-5)])
    assert (got.value, got.sigma, got.dof) == (1.5, 2e-5, 0)
    assert math.isnan(got.birge_ratio)
    assert any("single usable trial" in n for n in got.notes)


def test_zero_sigma_trial_is_left_out() -> None:
    got = combine_periods([_fit(1.0, 0.0), _fit(1.1, 0.01)])
    assert got.value == 1.1 and got.n_invalid == 1


def test_three_simulated_trials() -> None:
    fits = [fit_period(gyro_trial(s, period=1.7).samples, 1000.0) for s in range(3)]
    got = combine_periods(fits)
    assert got.n_used == 3
    assert abs(got.value - 1.7) < 3 * got.sigma
    assert got.sigma <= max(f.period_sigma for f in fits)
