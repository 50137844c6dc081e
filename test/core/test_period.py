"""The period fitter on synthetic trials: Eq 23/25, rates, timestamps, windows, bad data, flags."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from bike_rig.core.period import (
    DEFAULT_WINDOW,
    FlagCode,
    PeriodFit,
    WindowKind,
    WindowPolicy,
    damped_oscillation,
    damped_period,
    fit_period,
)
from bike_rig.core.period.damping import MAX_OFFSET_INTERVALS, offset_hats
from bike_rig.core.period.oscillation import alpha_omega_d, fit_variance, zeta_omega
from bike_rig.core.period.window import first_at_or_after
from test.support.signals import LSB, gyro_trial, quantise

# ---------------------------------------------------------------- the paper's equations


def test_eq25_period_of_the_damped_oscillation() -> None:
    # printed Eq 25 misplaces the root; T = 2π / (ω sqrt(1 − ζ²))
    assert damped_period(0.0, 2 * math.pi) == pytest.approx(1.0, rel=1e-15)
    assert damped_period(0.6, 2 * math.pi) == pytest.approx(1.0 / 0.8, rel=1e-15)


def test_eq23_zero_crossings_are_half_a_damped_period_apart() -> None:
    zeta, omega = 0.05, 7.0
    t = np.linspace(0.0, 10.0, 200001)
    f = damped_oscillation(t, 0.0, 0.0, 1.0, zeta, omega)
    crossings = t[np.flatnonzero(np.diff(np.sign(f)) != 0)]
    assert np.diff(crossings) == pytest.approx(damped_period(zeta, omega) / 2, abs=1e-4)


def test_eq26_equals_the_residual_variance_at_the_optimum() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0, 20, 4000)
    y = damped_oscillation(t, 0.2, 1.0, 0.3, 0.01, 4.0) + 0.05 * rng.standard_normal(t.size)
    fit = fit_period(y, times=t, window=WindowPolicy.lead_in(0.0, whole_cycles=False))
    residual = y - fit.predict(t)
    assert fit_variance(y, fit.predict(t)) == pytest.approx(residual @ residual / (t.size - 5), rel=1e-3)


def test_zeta_omega_round_trip() -> None:
    alpha, omega_d = alpha_omega_d(0.02, 5.0)
    assert zeta_omega(alpha, omega_d) == pytest.approx((0.02, 5.0), rel=1e-14)


# ---------------------------------------------------------------- recovering the period


@pytest.mark.parametrize(("rate_hz", "period"), [(100.0, 0.8), (1000.0, 1.5), (1000.0, 3.4), (10000.0, 2.1)])
def test_period_recovered_at_any_rate(rate_hz: float, period: float) -> None:
    trial = gyro_trial(7, period=period, rate_hz=rate_hz, duration=30.0)
    fit = fit_period(trial.samples, sample_rate_hz=rate_hz)
    assert fit.valid and fit.clean, fit.flags
    assert abs(fit.period - period) < 4 * fit.period_sigma
    assert fit.period == pytest.approx(period, rel=2e-4)
    assert fit.period_sigma < 1e-3 * period
    assert fit.zeta == pytest.approx(trial.zeta, abs=5e-4)
    assert fit.omega == pytest.approx(trial.omega, rel=2e-4)
    assert fit.n_cycles == pytest.approx(round(fit.n_cycles), abs=0.05)  # whole cycles
    assert fit.r2 > 0.95


@pytest.mark.parametrize(
    ("rate_hz", "duration", "period"),
    [(1000.0, 120.0, 0.2), (1000.0, 120.0, 0.3), (2000.0, 60.0, 0.152), (200.0, 600.0, 0.8), (50.0, 600.0, 1.0)],
)
def test_long_records_of_short_periods(rate_hz: float, duration: float, period: float) -> None:
    """The spectrum of a long window still reaches 8 Hz (1,024 block means of 120 s stopped at 2.1 Hz)."""
    trial = gyro_trial(11, period=period, zeta=0.0003, rate_hz=rate_hz, duration=duration)
    fit = fit_period(trial.samples, sample_rate_hz=rate_hz)
    assert fit.valid, fit.flags
    assert abs(fit.period - period) < 4 * fit.period_sigma, (fit.period, fit.period_sigma)
    # whole cycles of the spectrum's guess (within about 2e-4 of the fit over hundreds of cycles)
    assert fit.n_cycles == pytest.approx(round(fit.n_cycles), abs=max(0.05, 3e-4 * fit.n_cycles))


@pytest.mark.parametrize(("span", "period"), [(29.0, 0.152), (29.0, 1.5), (300.0, 0.152), (3600.0, 0.3)])
def test_the_drift_models_knots_are_whole_cycles_apart_and_at_most_129(span: float, period: float) -> None:
    cycles = max(2, math.ceil(span / (MAX_OFFSET_INTERVALS * period)))  # 2, unless that makes over 128
    knot = cycles * period
    tb = np.union1d(np.linspace(0.0, span, 2001), [knot, 2 * knot])
    hats = offset_hats(tb, 0.0, span, period)
    assert hats.shape[0] - 1 == max(1, int(span / knot + 0.5)) <= MAX_OFFSET_INTERVALS
    assert np.allclose(hats.sum(axis=0), 1.0)
    for j, t in ((1, knot), (2, 2 * knot)):  # hat j peaks at knot j: j whole spacings of ``cycles`` cycles
        assert hats[j, np.searchsorted(tb, t)] == pytest.approx(1.0)


def test_noise_free_fit_is_exact_and_predict_reproduces_the_samples() -> None:
    t = np.arange(20000) / 1000.0
    y = damped_oscillation(t, 1.5, -0.3, 0.7, 0.004, 3.3)
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.period == pytest.approx(damped_period(0.004, 3.3), rel=1e-10)
    assert (fit.zeta, fit.omega) == pytest.approx((0.004, 3.3), rel=1e-8)
    start, stop = fit.window
    assert fit.t_ref == pytest.approx(t[start])
    assert fit.predict(t[start:stop]) == pytest.approx(y[start:stop], abs=1e-10)
    # Eq 23's B, C refer to t_ref: the curve's value and slope there
    assert fit.A + fit.C == pytest.approx(y[start], abs=1e-10)
    assert fit.residual_rms < 1e-10 and fit.r2 == pytest.approx(1.0, abs=1e-12)


def test_jittered_timestamps() -> None:
    rng = np.random.default_rng(11)
    # a DAQ clock 0.3 % slower than nominal, and ±0.2 ms of jitter
    times = np.arange(30000) / 1000.0 * 1.003 + rng.uniform(-2e-4, 2e-4, 30000)
    trial = gyro_trial(11, period=1.3, times=times)
    fit = fit_period(trial.samples, times=times)
    assert fit.clean, fit.flags
    assert abs(fit.period - 1.3) < 4 * fit.period_sigma
    # the nominal rate would be 0.3 % off: the timestamps are what the fit uses
    naive = fit_period(trial.samples, sample_rate_hz=1000.0)
    assert naive.period == pytest.approx(1.3 / 1.003, rel=1e-4)


def test_gappy_timestamps() -> None:
    times = np.arange(30000) / 1000.0
    keep = np.ones(times.size, dtype=bool)
    for start in (4000, 9500, 17000, 23000):  # four gaps of 0.3–0.9 s
        keep[start : start + 300 + start // 30] = False
    trial = gyro_trial(5, period=1.7, times=times[keep])
    fit = fit_period(trial.samples, times=times[keep])
    assert fit.clean, fit.flags
    assert abs(fit.period - 1.7) < 4 * fit.period_sigma
    assert any("4 gaps" in note for note in fit.notes)


def test_timestamps_with_an_offset_and_variable_rate() -> None:
    # an epoch-like time origin and a slowly varying sample rate
    k = np.arange(20000)
    times = 1.7e9 + k / 800.0 + 2e-7 * k**1.5
    t = times - times[0]
    y = damped_oscillation(t, 0.1, 0.2, 0.3, 0.002, 2 * math.pi / 1.1)
    fit = fit_period(y, times=times)
    assert fit.period == pytest.approx(damped_period(0.002, 2 * math.pi / 1.1), rel=1e-9)
    assert fit.t_ref == pytest.approx(times[fit.window[0]], abs=1e-6)


def test_nan_samples_are_left_out_and_flagged() -> None:
    trial = gyro_trial(2)
    y = trial.samples.copy()
    y[[5000, 5001, 12000]] = np.nan
    y[20000] = np.inf
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.valid and fit.has_flag(FlagCode.NON_FINITE)
    assert "4 of 30000 samples" in fit.flags[0].reason
    assert abs(fit.period - trial.period) < 4 * fit.period_sigma


# ---------------------------------------------------------------- windows


def test_default_window_is_the_record_minus_a_lead_in_in_whole_cycles() -> None:
    fit = fit_period(gyro_trial(3, period=1.5).samples, sample_rate_hz=1000.0)
    assert fit.window_policy == DEFAULT_WINDOW
    assert DEFAULT_WINDOW.kind is WindowKind.LEAD_IN and DEFAULT_WINDOW.lead_in_s == 1.0
    assert fit.window[0] == 1000
    assert fit.window[1] == pytest.approx(1000 + 19 * 1500, abs=15)  # 19 whole cycles of 1.5 s (to 1 %)
    assert fit.n_samples == fit.window[1] - fit.window[0]


def test_span_and_envelope_windows() -> None:
    trial = gyro_trial(3, period=1.5, zeta=0.02, drift=0.0)
    span = fit_period(trial.samples, 1000.0, window=WindowPolicy.span(2.0, 20.0, whole_cycles=False))
    assert span.window == (2000, 20000) and span.window_policy.kind is WindowKind.SPAN
    assert abs(span.period - 1.5) < 4 * span.period_sigma
    envelope = fit_period(trial.samples, 1000.0, window=WindowPolicy.envelope(0.3))
    start, stop = envelope.window
    assert start < 1500  # the largest swing is at the start
    # BicycleParameters' rule: stop where the swing has decayed to 30 %: exp(−ζω t) = 0.3
    t_decay = math.log(1 / 0.3) / (0.02 * 2 * math.pi / 1.5)
    assert stop / 1000.0 == pytest.approx(t_decay, abs=1.6)  # within a cycle (peaks) and its trim
    assert abs(envelope.period - 1.5) < 4 * envelope.period_sigma
    assert "envelope" in envelope.window_policy.describe()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"lead_in_s": -1.0}, "lead-in"),
        ({"kind": WindowKind.SPAN, "start_s": 5.0, "stop_s": 2.0}, "after start"),
        ({"kind": WindowKind.ENVELOPE, "fraction": 1.5}, "fraction"),
    ],
)
def test_window_policy_rejects_nonsense(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        WindowPolicy(**kwargs)  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(
    rate=st.floats(0.5, 20000.0),
    n=st.integers(1, 3000),
    x=st.floats(-1.0, 5000.0),
)
def test_even_window_search_matches_searchsorted(rate: float, n: int, x: float) -> None:
    t = np.arange(n, dtype=float) * (1.0 / rate)
    assert first_at_or_after(x, 1.0 / rate, n) == int(np.searchsorted(t, x))
    on_sample = float(t[n // 2])
    assert first_at_or_after(on_sample, 1.0 / rate, n) == int(np.searchsorted(t, on_sample))


def test_huge_and_tiny_sample_values() -> None:
    trial = gyro_trial(12, period=1.3)
    reference = fit_period(trial.samples, 1000.0)
    for factor in (1e200, 1e-200, -3e150):
        fit = fit_period(trial.samples * factor, 1000.0)
        assert fit.clean, fit.flags
        assert fit.period == pytest.approx(reference.period, rel=1e-9)
        assert fit.period_sigma == pytest.approx(reference.period_sigma, rel=1e-6)
        assert fit.A == pytest.approx(reference.A * factor, rel=1e-6)


def test_window_with_too_few_samples_is_invalid() -> None:
    fit = fit_period(gyro_trial(1).samples, 1000.0, window=WindowPolicy.span(29.995))
    assert not fit.valid and fit.flag_codes == ("empty",)
    assert "5 samples in the window" in fit.flags[0].reason


# ---------------------------------------------------------------- the caller's mistakes raise


def test_exactly_one_of_rate_and_times() -> None:
    y = np.zeros(10)
    with pytest.raises(ValueError, match="exactly one"):
        fit_period(y)
    with pytest.raises(ValueError, match="exactly one"):
        fit_period(y, sample_rate_hz=100.0, times=np.arange(10.0))
    for rate in (0.0, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="positive"):
            fit_period(y, sample_rate_hz=rate)


# ---------------------------------------------------------------- bad data never raise

rng = np.random.default_rng(0)
t1k = np.arange(30000) / 1000.0


@pytest.mark.parametrize(
    ("samples", "code", "reason"),
    [
        (np.array([]), FlagCode.EMPTY, "no samples"),
        (np.full(5000, 0.37), FlagCode.CONSTANT, "equal 0.37"),
        (np.full(5000, np.nan), FlagCode.NON_FINITE, "all 5000"),
        (rng.standard_normal(30000), FlagCode.NO_OSCILLATION, "no oscillation"),
        (np.sin(2 * np.pi * t1k[:3000] / 1.6), FlagCode.TOO_FEW_CYCLES, "cycles of 1.6"),  # 1.25 cycles
        (np.sin(2 * np.pi * t1k[:5000] / 4.0), FlagCode.TOO_FEW_CYCLES, "at least 2"),  # one cycle
        (np.ones((20, 20)), FlagCode.EMPTY, "one series"),
        (np.array(["1.0", "2.0"]), FlagCode.EMPTY, "not real numbers"),
        (np.ones(100) * (1 + 1j), FlagCode.EMPTY, "not real numbers"),
        ([[1.0, 2.0], [3.0]], FlagCode.EMPTY, "not an array"),
    ],
)
def test_bad_data_give_an_invalid_result_with_the_reason(samples: object, code: FlagCode, reason: str) -> None:
    fit = fit_period(samples, sample_rate_hz=1000.0)  # type: ignore[arg-type]
    assert not fit.valid
    assert fit.has_flag(code), fit.flags
    assert any(reason in f.reason for f in fit.flags), fit.flags
    assert math.isnan(fit.period) and math.isnan(fit.period_sigma)
    assert np.all(np.isnan(fit.predict(np.arange(3.0))))


def test_bad_timestamps_give_an_invalid_result() -> None:
    y = gyro_trial(1).samples
    fit = fit_period(y, times=t1k[:100])
    assert not fit.valid and fit.has_flag(FlagCode.BAD_TIMES) and "100 timestamps for 30000" in fit.flags[0].reason
    backwards = t1k.copy()
    backwards[777] = backwards[775]
    fit = fit_period(y, times=backwards)
    assert not fit.valid and "do not increase at sample 777" in fit.flags[0].reason


def test_random_walk_without_oscillation_is_invalid() -> None:
    walk = np.cumsum(np.random.default_rng(4).standard_normal(30000))
    fit = fit_period(walk, sample_rate_hz=1000.0)
    assert not fit.valid
    assert fit.has_flag(FlagCode.NO_OSCILLATION) or fit.has_flag(FlagCode.TOO_FEW_CYCLES)


finite_or_not = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    samples=hnp.arrays(np.float64, st.integers(0, 3000), elements=finite_or_not),
    rate=st.sampled_from([1.0, 100.0, 1000.0, 1e-3, 1e9]),
)
def test_arbitrary_arrays_never_raise(samples: np.ndarray, rate: float) -> None:
    fit = fit_period(samples, sample_rate_hz=rate)
    _check_invariants(fit, samples.size)


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 5000),
    scale=st.floats(1e-300, 1e300),
    nan_fraction=st.floats(0.0, 1.0),
)
def test_arbitrary_oscillations_never_raise(seed: int, n: int, scale: float, nan_fraction: float) -> None:
    r = np.random.default_rng(seed)
    t = np.sort(r.uniform(0.0, 40.0, n))
    y = scale * (np.sin(r.uniform(0.5, 20.0) * t) + r.uniform(0.0, 2.0) * r.standard_normal(n))
    y[r.random(n) < nan_fraction] = np.nan
    fit = fit_period(y, times=t)
    _check_invariants(fit, n)


def _check_invariants(fit: PeriodFit, n: int) -> None:
    assert isinstance(fit, PeriodFit)
    start, stop = fit.window
    assert 0 <= start <= stop <= n
    if fit.valid:
        assert fit.period > 0 and math.isfinite(fit.period)
        assert 0 < fit.period_sigma < 0.05 * fit.period
        assert fit.n_cycles >= 1.95 and fit.n_samples >= 16
    else:
        assert fit.flags, "an invalid result must say why"
        assert math.isnan(fit.period)
    assert all(f.reason for f in fit.flags)


# ---------------------------------------------------------------- quality flags


def test_clean_quantised_trial_carries_no_flag() -> None:
    fit = fit_period(gyro_trial(9, amplitude=0.03).samples, sample_rate_hz=1000.0)  # 35 LSB: long plateaus
    assert fit.clean, fit.flags


def test_clipping_is_detected() -> None:
    trial = gyro_trial(9, amplitude=0.05, bits=None)
    clipped = quantise(np.clip(trial.samples, -0.03, 0.04))
    fit = fit_period(clipped, sample_rate_hz=1000.0)
    assert fit.valid and fit.has_flag(FlagCode.CLIPPED), fit.flags
    reason = next(f.reason for f in fit.flags if f.code is FlagCode.CLIPPED)
    assert "maximum" in reason and "minimum" in reason
    # saturation of the ADC itself: a swing beyond ±100 °/s
    big = gyro_trial(9, amplitude=2.0)
    assert fit_period(big.samples, sample_rate_hz=1000.0).has_flag(FlagCode.CLIPPED)


def test_held_samples_are_detected() -> None:
    y = gyro_trial(8).samples.copy()
    y[7000:7060] = y[6999]  # a DAQ filling a 60 ms gap with the last value
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.valid and fit.has_flag(FlagCode.GAP_FILLED), fit.flags
    assert "61 samples at t = 6.999 s" in str(fit.flags)  # the last good sample, held 60 more


def test_a_sensor_that_stops_is_cut_off_and_flagged() -> None:
    """A gyro holding one value from 12 s on: the fit keeps the 12 s before, and says why."""
    trial = gyro_trial(8)
    y = trial.samples.copy()
    y[12000:] = y[12000]
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.valid and fit.has_flag(FlagCode.GAP_FILLED), fit.flags
    reason = str(fit.flags)
    assert "(18 s from t = 1" in reason and "the sensor or its link stopped" in reason
    assert 5.0 <= fit.n_cycles <= 8.0 and abs(fit.period - trial.period) < 4 * fit.period_sigma
    stamped = fit_period(y, times=np.arange(y.size) / 1000.0)  # the same with timestamps
    assert stamped.has_flag(FlagCode.GAP_FILLED) and abs(stamped.period - fit.period) < 0.1 * fit.period_sigma


def test_a_swing_that_died_into_the_resolution_is_cut_off_with_a_note() -> None:
    y = gyro_trial(8).samples.copy()  # a 12-bit gyro
    y[20000:] = y[20000]  # the last 10 s hold one value after a second within one ADC step
    y[19000:20000] = y[20000] + (np.arange(1000) % 2) * LSB
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert not fit.has_flag(FlagCode.GAP_FILLED), fit.flags
    assert any("died into the sensor's resolution" in n for n in fit.notes), fit.notes


def test_drift_dominating_is_flagged() -> None:
    trial = gyro_trial(6, amplitude=0.02, drift=0.05)
    fit = fit_period(trial.samples, sample_rate_hz=1000.0)
    assert fit.has_flag(FlagCode.DRIFT), fit.flags
    assert fit.drift > 0.5


def test_poor_fit_is_flagged() -> None:
    trial = gyro_trial(6, amplitude=0.004, noise=0.004, bits=None)  # noise as large as the swing
    fit = fit_period(trial.samples, sample_rate_hz=1000.0)
    assert fit.valid and fit.has_flag(FlagCode.POOR_FIT) and fit.r2 < 0.9


def test_too_few_cycles_is_flagged_and_below_two_invalid() -> None:
    few = fit_period(gyro_trial(6, period=3.5, duration=14.0).samples, 1000.0)  # 13 s: 3 whole cycles
    assert few.valid and few.has_flag(FlagCode.TOO_FEW_CYCLES) and few.n_cycles == pytest.approx(3, abs=0.05)
    assert fit_period(gyro_trial(6, period=3.5, duration=14.0).samples, 1000.0, min_cycles=3).clean
    assert not fit_period(gyro_trial(6, period=3.5, duration=7.5).samples, 1000.0).valid


def test_flags_are_readable() -> None:
    y = gyro_trial(8).samples.copy()
    y[100] = np.nan
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert str(fit.flags[0]).startswith("non_finite: 1 of 30000 samples")
    assert fit.flag_codes == ("non_finite",) and not fit.clean
