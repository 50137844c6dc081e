"""Dropouts (a connector that drops: the samples read 0 V or a rail) are left out of the period fit and flagged."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.core.period import FlagCode, PeriodFit, fit_period
from test.support.signals import gyro_trial

#: The paper's gyro: volts per rad/s about 2.5 V.
SCALE, CENTRE = 1.1459156, 2.5
#: (bits, low, high) of two ADCs: the rig's 12-bit ±5 V (2.44 mV) and a 10-bit 0-5.2 V (5.08 mV).
ADCS = {"12-bit ±5 V": (12, -5.0, 5.0), "10-bit 0-5.2 V": (10, 0.0, 5.2)}


def volts(rate: np.ndarray, adc: str = "12-bit ±5 V") -> np.ndarray:
    """A rate [rad/s] as the ADC reads the gyro's output [V]: quantised, clipped at its rails."""
    bits, low, high = ADCS[adc]
    lsb = (high - low) / 2**bits
    return low + lsb * np.clip(np.round((CENTRE + SCALE * rate - low) / lsb), 0, 2**bits - 1)


def rail(adc: str, side: str) -> float:
    bits, low, high = ADCS[adc]
    return low if side == "low" else low + (2**bits - 1) * (high - low) / 2**bits


def dropout_reasons(fit: PeriodFit) -> list[str]:
    return [f.reason for f in fit.flags if f.code is FlagCode.GAP_FILLED and "dropout" in f.reason]


def test_a_dropout_to_zero_volts_is_left_out_and_said_where() -> None:
    trial = gyro_trial(3, bits=None)
    y = volts(trial.samples)
    clean = fit_period(y, sample_rate_hz=1000.0)
    y[12310:12520] = 0.0
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.valid and not fit.has_flag(FlagCode.POOR_FIT), fit.flags
    (reason,) = dropout_reasons(fit)
    assert "read 0 from 12.310 s to 12.520 s (0.21 s, 210 samples)" in reason, reason
    assert abs(fit.period - trial.period) < 4 * fit.period_sigma
    assert abs(fit.period - clean.period) < fit.period_sigma
    assert fit.r2 > 0.99 and not clean.flags


@pytest.mark.parametrize("adc", ADCS)
@pytest.mark.parametrize(("rate_hz", "duration"), [(100.0, 20.0), (1000.0, 30.0), (2000.0, 8.0)])
@pytest.mark.parametrize("where", ["start", "middle", "end"])
@pytest.mark.parametrize("level", ["0 V", "low", "high"])
def test_dropouts_anywhere_at_any_rate_and_scale(
    adc: str, rate_hz: float, duration: float, where: str, level: str
) -> None:
    trial = gyro_trial(7, rate_hz=rate_hz, duration=duration, bits=None)
    y = volts(trial.samples, adc)
    n, length = y.size, int(0.3 * rate_hz)  # 0.3 s
    a = {"start": 0, "middle": n // 2, "end": n - length}[where]
    y[a : a + length] = 0.0 if level == "0 V" else rail(adc, level)
    fit = fit_period(y, sample_rate_hz=rate_hz)
    assert fit.valid and not fit.has_flag(FlagCode.POOR_FIT), fit.flags
    # (one in the lead-in, before the window, is said in a note: nothing the fit uses)
    said = dropout_reasons(fit) if where != "start" else [n for n in fit.notes if "before the window" in n]
    assert len(said) == 1 and (where != "start" or not fit.has_flag(FlagCode.GAP_FILLED)), (fit.flags, fit.notes)
    assert f"from {a / rate_hz:.3f} s to {(a + length) / rate_hz:.3f} s" in said[0]
    assert abs(fit.period - trial.period) < 4 * fit.period_sigma


def test_a_dropout_in_the_lead_in_is_noted_and_changes_nothing() -> None:
    trial = gyro_trial(3, bits=None)
    y = volts(trial.samples)
    clean = fit_period(y, sample_rate_hz=1000.0)
    y[200:700] = 0.0  # within the 1 s lead-in
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert fit.valid and not fit.flags and fit.window == clean.window, (fit.flags, fit.window, clean.window)
    # (the same window's samples, though no longer evenly spaced from the record's start: the fit
    # refines on the samples themselves, as for time-stamped records, within a fraction of σ)
    assert abs(fit.period - clean.period) < 0.5 * clean.period_sigma
    assert fit.period_sigma == pytest.approx(clean.period_sigma, rel=0.1)
    assert any("read 0 from 0.200 s to 0.700 s" in n and "before the window" in n for n in fit.notes), fit.notes
    y[5000:5300] = 0.0  # and one inside the window: flagged, both said
    (reason,) = dropout_reasons(fit_period(y, sample_rate_hz=1000.0))
    assert "dropped out 2 times" in reason, reason


def test_several_dropouts_make_one_flag_and_timestamps_agree() -> None:
    trial = gyro_trial(11, bits=None)
    y = volts(trial.samples)
    for a, length in ((4000, 40), (9500, 600), (17000, 120), (23000, 1000)):
        y[a : a + length] = 0.0
    fit = fit_period(y, sample_rate_hz=1000.0)
    (reason,) = dropout_reasons(fit)
    assert "dropped out 4 times (1.76 s of 30 s, 1760 samples)" in reason and "and 1 more" in reason, reason
    assert fit.valid and abs(fit.period - trial.period) < 4 * fit.period_sigma
    stamped = fit_period(y, times=np.arange(y.size) / 1000.0)
    assert dropout_reasons(stamped) == [reason]
    assert abs(stamped.period - fit.period) < 0.1 * fit.period_sigma


@pytest.mark.parametrize("level", [-5.0, 0.0])
@pytest.mark.parametrize("share", [0.2, 0.5])
def test_a_reading_that_toggles_by_one_step_is_one_dropout(level: float, share: float) -> None:
    """The lowest code, now and then the next; or 0 V, now and then a code either side."""
    trial = gyro_trial(12, bits=None)
    y = volts(trial.samples)
    lsb = 10.0 / 2**12
    rng = np.random.default_rng(1)
    toggles = rng.random(500) < share
    y[8000:8500] = level + lsb * toggles * (1 if level == -5.0 else rng.choice([-1, 1], 500))
    fit = fit_period(y, sample_rate_hz=1000.0)
    (reason,) = dropout_reasons(fit)
    assert "from 8.000 s to 8.500 s" in reason and fit.valid, reason


def test_a_dropout_at_the_edge_of_the_swing_counts_when_longer_than_a_period() -> None:
    trial = gyro_trial(13, bits=None)
    y = volts(trial.samples)
    edge = float(np.min(y))  # the record's own lowest value: a rail it touches
    y[10000:12000] = edge  # 2 s, longer than the 1.5 s period
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert len(dropout_reasons(fit)) == 1 and fit.valid, fit.flags
    assert abs(fit.period - trial.period) < 4 * fit.period_sigma


def test_a_dropout_that_leaves_too_little_is_refused_with_reasons() -> None:
    trial = gyro_trial(14, bits=None)
    y = volts(trial.samples)
    y[2500:] = 0.0  # only 2.5 s left: 1.5 s after the lead-in, one cycle
    fit = fit_period(y, sample_rate_hz=1000.0)
    assert not fit.valid and math.isnan(fit.period)
    assert fit.has_flag(FlagCode.GAP_FILLED) and len(fit.flags) >= 2, fit.flags
    assert any(f.code in (FlagCode.TOO_FEW_CYCLES, FlagCode.EMPTY) for f in fit.flags), fit.flags


def test_a_rate_signal_held_at_zero_is_not_a_dropout() -> None:
    """A rad/s signal crosses 0: a hold there is no dropout (it is the held-samples check's business)."""
    y = gyro_trial(15, bias=0.0).samples.copy()
    clean = fit_period(y, sample_rate_hz=1000.0)
    for a in range(2000, 28000, 1000):  # at every phase of the swing
        held = y.copy()
        held[a : a + 200] = 0.0
        fit = fit_period(held, sample_rate_hz=1000.0)
        assert not dropout_reasons(fit), (a, fit.flags)
        assert fit.window[0] == clean.window[0] and fit.n_samples == fit.window[1] - fit.window[0]  # none left out


def test_clipping_is_still_clipping() -> None:
    big = gyro_trial(9, amplitude=2.0)  # beyond the ±100 °/s range: the ADC saturates every half cycle
    fit = fit_period(big.samples, sample_rate_hz=1000.0)
    assert fit.has_flag(FlagCode.CLIPPED) and not dropout_reasons(fit), fit.flags
    saturated = fit_period(volts(0.3 * np.sin(2 * np.pi * np.arange(20_000) / 1500.0) * 20), sample_rate_hz=1000.0)
    assert not dropout_reasons(saturated), saturated.flags


@pytest.mark.parametrize(("rate_hz", "duration"), [(100.0, 20.0), (1000.0, 30.0), (2000.0, 8.0)])
def test_clean_records_never_carry_the_flag(rate_hz: float, duration: float) -> None:
    for seed in range(8):
        for amplitude in (0.005, 0.05, 0.5):
            trial = gyro_trial(seed, amplitude=amplitude, rate_hz=rate_hz, duration=duration, bits=None)
            for y in (volts(trial.samples), volts(trial.samples, "10-bit 0-5.2 V"), trial.samples):
                fit = fit_period(y, sample_rate_hz=rate_hz)
                assert not dropout_reasons(fit), (seed, amplitude, fit.flags)


def test_two_samples_at_100_hz_are_a_dropout() -> None:
    trial = gyro_trial(16, rate_hz=100.0, duration=20.0, bits=None)
    y = volts(trial.samples)
    y[1000:1002] = 0.0  # 20 ms
    fit = fit_period(y, sample_rate_hz=100.0)
    (reason,) = dropout_reasons(fit)
    assert "from 10.000 s to 10.020 s (0.02 s, 2 samples)" in reason and fit.valid, reason
