"""A whole simulated session: what it contains, its noise, its reproducibility, its beating."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bike_rig.core.measurements import REQUIRED_KEYS, validate
from bike_rig.core.sim.gyro import angular_rate
from bike_rig.core.sim.rig import CoupledSwing, RigConfig
from bike_rig.core.sim.session import SimulatedSession, reading_sigma, simulate_session
from bike_rig.core.units import DEGREE

MEASUREMENTS = (
    "rear_wheel_compound", "rear_wheel_torsional", "front_wheel_compound", "front_wheel_torsional",
    "frame_compound", "frame_torsional_o1", "frame_torsional_o2", "frame_torsional_o3",
    "fork_compound", "fork_torsional_o1", "fork_torsional_o2", "fork_torsional_o3",
    "calibration_rod_torsional",
)  # fmt: skip


def _short(rig: RigConfig, duration: float = 0.5, swing: CoupledSwing | None = None) -> RigConfig:
    """The rig with short trials, for tests of everything but the trials' length."""
    return replace(rig, trials=replace(rig.trials, durations=(duration,)), coupled_swing=swing)


def test_a_session_holds_every_reading_and_three_trials_of_every_period(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    s = simulate_session(browser_truth, rig, seed, "Browser")
    names = [t.name for t in s.trials]
    assert names == [f"{m}_t{i}" for m in MEASUREMENTS for i in (1, 2, 3)]
    assert [m.key for m in s.plan] == [
        "TcR1", "TtR1", "TcF1", "TtF1", "TcB1", "TtB1", "TtB2", "TtB3", "TcH1", "TtH1", "TtH2", "TtH3", "TtP1"
    ]  # fmt: skip
    assert [t.key for t in s.trials_of("TtB2")] == ["TtB2"] * 3
    for t in s.trials:
        data = t.samples()
        assert data.dtype == np.float64 and data.shape == (30_000, 2)
        assert np.array_equal(data[:, 0], np.arange(30_000) / 1000.0) and np.array_equal(data[:, 1], t.rate)
        assert t.true_period == s.truth.periods[t.key]
        assert sum(m.amplitude for m in t.modes) < 0.9 * DEGREE + 1e-15
        assert 0.2 * DEGREE <= sum(m.amplitude for m in t.modes)
    # the static readings and the periods make a complete, valid measurement set
    m = s.measurements({k: (T, 1e-5) for k, T in s.truth.periods.items()})
    validate(m)
    assert set(REQUIRED_KEYS) <= set(m.readings)
    assert m.readings["nR"].value == 13.0 and m.readings["nR"].sigma == 0.0


def test_the_stored_rate_is_the_motion_through_gyro_and_adc(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """Without drift and scale error, the stored rate's error is bias, white noise and quantisation.

    The stored rate minus the true rate is a constant bias plus white noise and quantisation:
    σ² = σ_n² + (LSB / s)² / 12. Over 13 × 30 000 samples the pooled σ misses ±3 % of it with
    probability < 1e-30 (χ²).
    """
    gyro = replace(rig.gyro, bias_drift=0.0, scale_factor_tolerance=0.0)
    quiet = replace(rig, gyro=gyro, trials=replace(rig.trials, per_measurement=1), coupled_swing=None)
    s = simulate_session(browser_truth, quiet, seed)
    residuals = []
    for t in s.trials:
        error = t.rate - angular_rate(t.time, t.modes)
        assert abs(np.mean(error)) < 6 * 0.02  # the turn-on bias, σ = 0.02 rad/s
        residuals.append(error - np.mean(error))
    expected = np.sqrt(gyro.noise_sigma(1000.0) ** 2 + (quiet.adc.lsb / gyro.scale_factor) ** 2 / 12)
    assert np.std(np.concatenate(residuals)) == pytest.approx(expected, rel=0.03)


def test_same_seed_same_session_other_seed_other_session(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    a = simulate_session(browser_truth, rig, seed, "Browser")
    b = simulate_session(browser_truth, rig, seed, "Browser")
    c = simulate_session(browser_truth, rig, seed + 1, "Browser")
    assert a.readings == b.readings and a.truth == b.truth
    assert all(np.array_equal(x.volts, y.volts) and x.modes == y.modes for x, y in zip(a.trials, b.trials))
    assert a.readings != c.readings
    assert not any(np.array_equal(x.volts, y.volts) for x, y in zip(a.trials, c.trials))


def _sessions(rig: RigConfig, truth: dict[str, float], seed: int, n: int) -> list[SimulatedSession]:
    return [simulate_session(truth, rig, seed * 1000 + i) for i in range(n)]


def test_static_readings_scatter_with_their_stated_sigma(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """Pooled over 100 sessions × 27 noisy readings (2 700 independent z-scores).

    Their mean leaves ±5/√2700 with probability 6e-7, their σ leaves [0.9, 1.1] with probability
    1e-7 (χ²).
    """
    short = _short(rig)
    z = []
    for s in _sessions(short, browser_truth, seed, 100):
        for key, r in s.readings.items():
            assert r.sigma == reading_sigma(key, rig.sigma)
            if r.sigma == 0:
                assert r.value == s.truth.static[key]
            else:
                z.append((r.value - s.truth.static[key]) / r.sigma)
    z_ = np.array(z)
    assert len(z_) == 2700
    assert abs(np.mean(z_)) < 5 / np.sqrt(len(z_))
    assert 0.9 < np.std(z_) < 1.1


def test_beating_trials_are_where_configured(rig: RigConfig, browser_truth: dict[str, float], seed: int) -> None:
    swing = CoupledSwing(0.0, ("frame_torsional_o2_t3", "rear_wheel_compound_t1"), (0.05, 0.15), (0.4, 0.9))
    s = simulate_session(browser_truth, replace(rig, coupled_swing=swing), seed)
    assert {t.name for t in s.trials if t.beating} == {"frame_torsional_o2_t3", "rear_wheel_compound_t1"}
    every = replace(swing, probability=1.0, trials=())
    s = simulate_session(browser_truth, _short(rig, swing=every), seed)
    assert {t.name for t in s.trials if t.beating} == {
        f"{part}_torsional_o{o}_t{i}" for part in ("frame", "fork") for o in (1, 2, 3) for i in (1, 2, 3)
    }
    s = simulate_session(browser_truth, _short(rig, swing=None), seed)
    assert not any(t.beating for t in s.trials)


def test_beating_is_a_second_close_mode_in_the_signal(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """A beating trial's stored rate holds both modes with weight 1.

    Least squares of a beating trial's stored rate on [pendulum mode, second mode, bias,
    drift] gives both modes with weight 1 (the gyro's scale error aside): each weight is
    within 6 of its standard errors (≤ 0.05) of 1; the 4 checks fail with probability 8e-9.
    """
    swing = CoupledSwing(0.0, ("frame_torsional_o1_t1", "fork_torsional_o2_t2"), (0.05, 0.15), (0.4, 0.9))
    s = simulate_session(browser_truth, replace(rig, coupled_swing=swing), seed)
    scale = s.truth.scale_factor / rig.gyro.scale_factor
    for name in swing.trials:
        t = next(t for t in s.trials if t.name == name)
        first, second = t.modes
        assert 0.05 <= abs(first.period / second.period - 1) <= 0.15
        assert 0.4 <= second.amplitude / first.amplitude <= 0.9
        A = np.column_stack(
            [
                scale * angular_rate(t.time, (first,)),
                scale * angular_rate(t.time, (second,)),
                np.ones_like(t.time),
                t.time,
            ]
        )
        coef, res, *_ = np.linalg.lstsq(A, t.rate, rcond=None)
        sigma = np.sqrt(res[0] / (len(t.time) - 4) * np.diag(np.linalg.inv(A.T @ A)))
        assert sigma[1] < 0.05
        assert np.all(np.abs(coef[:2] - 1.0) < 6 * sigma[:2])
