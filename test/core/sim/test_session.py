"""A whole simulated session: its contents, noise, reproducibility, beating, dry friction and finite swing."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from bike_rig.config.paths import config_file
from bike_rig.core.measurements import REQUIRED_KEYS, validate
from bike_rig.core.sim.errors import SimulationError
from bike_rig.core.sim.gyro import adc_quantise, angular_rate, gyro_volts
from bike_rig.core.sim.pendulum import small_swing_factor
from bike_rig.core.sim.rig import CoupledSwing, RigConfig, load_rig
from bike_rig.core.sim.session import SimulatedSession, motion_rate, reading_sigma, simulate_session
from bike_rig.core.units import DEGREE

MEASUREMENTS = (
    "rear_wheel_compound",
    "rear_wheel_torsional",
    "front_wheel_compound",
    "front_wheel_torsional",
    "frame_compound",
    "frame_torsional_o1",
    "frame_torsional_o2",
    "frame_torsional_o3",
    "fork_compound",
    "fork_torsional_o1",
    "fork_torsional_o2",
    "fork_torsional_o3",
    "calibration_rod_torsional",
)


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
        "TcR1",
        "TtR1",
        "TcF1",
        "TtF1",
        "TcB1",
        "TtB1",
        "TtB2",
        "TtB3",
        "TcH1",
        "TtH1",
        "TtH2",
        "TtH3",
        "TtP1",
    ]
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


# --- dry friction and finite swing (trials.dry_friction, trials.finite_swing) ---------------


def _pendulum_rig(
    rig: RigConfig,
    *,
    friction: tuple[float, float] = (0.0, 0.0),
    finite: bool = False,
    zeta: float = 0.0,
    duration: float = 30.0,
    amplitude_deg: tuple[float, float] | None = None,
    swing: CoupledSwing | None = None,
) -> RigConfig:
    """The rig with one trial per measurement, its friction, swing and damping, no beating by default."""
    trials = replace(
        rig.trials,
        per_measurement=1,
        durations=(duration,),
        damping_ratio=zeta,
        dry_friction=friction,
        finite_swing=finite,
        amplitude_deg=amplitude_deg or rig.trials.amplitude_deg,
    )
    return replace(rig, trials=trials, coupled_swing=swing)


def _rate_zeros(rate: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Times where the rate changes sign (turning points), linearly interpolated, s."""
    i = np.nonzero((rate[:-1] != 0) & (rate[1:] != 0) & (np.signbit(rate[:-1]) != np.signbit(rate[1:])))[0]
    return t[i] - rate[i] * (t[i + 1] - t[i]) / (rate[i + 1] - rate[i])


def test_without_friction_or_finite_swing_every_trial_is_the_analytic_motion(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """The shipped rig (both keys present and off) draws and computes its trials as before they existed.

    Every trial is rebuilt here from its own random streams: the motion stream's first draws
    are the amplitude and the phase (one duration, so none for it), and the volts are the
    analytic rate of the modes through the gyro (the sensor stream) and the ADC, bit for bit.
    """
    s = simulate_session(browser_truth, rig, seed)
    trial_seeds = np.random.SeedSequence(seed).spawn(3)[2].spawn(len(s.trials))
    for t, trial_ss in zip(s.trials, trial_seeds):
        assert (t.dry_friction, t.dry_friction_fraction, t.finite_swing) == (0.0, 0.0, False)
        motion_ss, sensor_ss = trial_ss.spawn(2)
        motion = np.random.default_rng(motion_ss)
        amplitude = float(motion.uniform(*rig.trials.amplitude_deg)) * DEGREE
        assert sum(m.amplitude for m in t.modes) == pytest.approx(amplitude, rel=1e-15)
        assert t.modes[0].phase == float(motion.uniform(0.0, 2.0 * np.pi))
        analytic = angular_rate(t.time, t.modes)
        assert np.array_equal(t.true_rate(), analytic)
        sensor = np.random.default_rng(sensor_ss)
        volts = adc_quantise(gyro_volts(analytic, rig.gyro, 1000.0, s.truth.scale_factor, sensor), rig.adc)
        assert np.array_equal(t.volts, volts), t.name


def test_the_keys_absent_or_off_give_the_same_session_and_friction_keeps_every_draw(
    rig: RigConfig, browser_truth: dict[str, float], seed: int, tmp_path: Path
) -> None:
    """A rig file without the two keys, with them off, and with friction on: the same draws.

    Friction is drawn last of a trial's motion stream and only when the rig has any, so a rig
    with friction keeps every amplitude, phase, beating mode, noise and static reading of its
    seed; only the motion differs.
    """
    text = config_file("rig.yaml").read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    kept = [line for line in lines if "dry_friction" not in line and "finite_swing" not in line]
    kept = [line for line in kept if not (line.startswith(" ") and line.lstrip().startswith("#"))]
    path = tmp_path / "rig.yaml"
    path.write_text("".join(kept), encoding="utf-8")
    absent = load_rig(path)
    assert absent.trials == rig.trials
    swing = replace(rig.coupled_swing, trials=("frame_torsional_o1_t2",)) if rig.coupled_swing else None
    a = simulate_session(
        browser_truth, replace(absent, trials=replace(absent.trials, durations=(3.0,)), coupled_swing=swing), seed
    )
    short = replace(rig, trials=replace(rig.trials, durations=(3.0,)), coupled_swing=swing)
    b = simulate_session(browser_truth, short, seed)
    rubbing = replace(short, trials=replace(short.trials, dry_friction=(0.01, 0.02), finite_swing=True))
    c = simulate_session(browser_truth, rubbing, seed)
    assert a.readings == b.readings == c.readings and a.truth == b.truth == c.truth
    for x, y, z in zip(a.trials, b.trials, c.trials):
        assert np.array_equal(x.volts, y.volts) and x.modes == y.modes == z.modes
        if not z.beating:
            assert 0.01 <= z.dry_friction_fraction <= 0.02
            assert not np.array_equal(x.volts, z.volts)


def test_dry_friction_decays_the_swing_linearly_until_it_stops_and_keeps_the_period(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """5 % of the initial swing lost per cycle, no viscous damping: the paper's linear envelope.

    Each half swing from θ to −(θ − 2μ/ω₀²) about the shifted centre ±μ/ω₀² has the peak rate
    ω₀ (θ − μ/ω₀²), so the peak falls by 2μ/ω₀ every half cycle; the turning points stay T/2
    apart, and after 1/0.05 = 20 cycles the swing stops for good.
    """
    s = simulate_session(browser_truth, _pendulum_rig(rig, friction=(0.05, 0.05)), seed)
    scale = s.truth.scale_factor / rig.gyro.scale_factor
    for t in s.trials:
        mode = t.modes[0]
        w0 = 2.0 * np.pi / mode.period
        mu = 0.05 * mode.amplitude * w0**2 / 4.0
        assert t.dry_friction_fraction == 0.05 and t.dry_friction == pytest.approx(mu, rel=1e-14)
        assert not t.finite_swing
        rate = t.true_rate()
        zeros = _rate_zeros(rate, t.time)
        # the peak rate of each whole half swing falls by the same 2μ/ω₀
        peaks = np.array([np.max(np.abs(rate[(t.time > a) & (t.time < b)])) for a, b in zip(zeros, zeros[1:])])
        assert len(peaks) >= 15
        assert np.diff(peaks) == pytest.approx(-2.0 * mu / w0, rel=2e-3), t.name
        # the period is unchanged: the first half of the turning points (where the swing is still
        # large enough for interpolation across the friction's kink to be exact to 1e-5 s)
        half = len(zeros) // 2
        assert (zeros[half] - zeros[0]) / half == pytest.approx(mode.period / 2.0, rel=1e-5), t.name
        # stopped for good 20 cycles after the turning point the motion starts from
        stop = 20.0 * mode.period - mode.phase / w0
        if stop < t.time[-1] - 0.01:
            assert np.all(rate[t.time > stop + 0.002] == 0.0) and np.any(rate[t.time > stop - 0.5] != 0.0)
        else:
            assert np.any(rate[-100:] != 0.0)
        # the stored rate is this motion through the gyro: weight 1 (the scale error aside)
        design = np.column_stack((scale * rate, np.ones_like(rate), t.time))
        coef, *_ = np.linalg.lstsq(design, t.rate, rcond=None)
        assert coef[0] == pytest.approx(1.0, abs=0.02)


def test_a_finite_swing_lengthens_the_compound_period_only(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """At 20–30° of swing, compound periods are T₀ · 2K(sin(θ₀/2))/π (+0.8 to 1.7 %), torsional ones T₀.

    Noise-free rates from each trial's truth; the turning points of 10 s are interpolated to
    better than 1e-9 s, so the mean period is checked to 1e-6 relative.
    """
    big = _pendulum_rig(rig, finite=True, duration=10.0, amplitude_deg=(20.0, 30.0))
    s = simulate_session(browser_truth, big, seed)
    assert {t.name for t in s.trials if t.finite_swing} == {
        f"{part}_compound_t1" for part in ("rear_wheel", "front_wheel", "frame", "fork")
    }
    for t in s.trials:
        mode = t.modes[0]
        assert t.dry_friction == 0.0 and 20.0 * DEGREE <= mode.amplitude <= 30.0 * DEGREE
        zeros = _rate_zeros(t.true_rate(), t.time)
        period = 2.0 * (zeros[-1] - zeros[0]) / (len(zeros) - 1)
        factor = small_swing_factor(mode.amplitude) if t.finite_swing else 1.0
        assert period == pytest.approx(mode.period * factor, rel=1e-6), t.name
        if t.finite_swing:
            assert factor > 1.007 and period != pytest.approx(mode.period, rel=1e-3)
            assert np.max(np.abs(t.true_rate())) == pytest.approx(
                2.0 * np.sin(mode.amplitude / 2.0) * 2.0 * np.pi / mode.period, rel=1e-5
            )  # the pendulum's energy: θ'max = 2 ω₀ sin(θ₀/2) (sampled at 1 kHz: < 3e-6 low)
        else:
            assert np.array_equal(t.true_rate(), angular_rate(t.time, t.modes))


def test_the_integrated_motion_starts_from_the_drawn_phase(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    """With vanishing friction (1e-9 of the swing per cycle) the integrator gives the analytic trial.

    Same amplitude, phase and viscous damping (the shipped ζ = 0.001): the integration starts
    from the analytic motion's turning point before t = 0, so the two agree to the integrator's
    tolerance: within 1e-7 of the peak rate over 3 s (5e-9 seen over 20 seeds).
    """
    s = simulate_session(browser_truth, _pendulum_rig(rig, friction=(1e-9, 1e-9), zeta=0.001, duration=3.0), seed)
    for t in s.trials:
        assert t.dry_friction > 0.0
        analytic = angular_rate(t.time, t.modes)
        assert np.max(np.abs(t.true_rate() - analytic)) < 1e-7 * np.max(np.abs(analytic)), t.name


def test_beating_trials_stay_analytic_without_friction_or_finite_swing(
    rig: RigConfig, browser_truth: dict[str, float], seed: int
) -> None:
    swing = CoupledSwing(0.0, ("frame_torsional_o2_t1", "rear_wheel_compound_t1"), (0.05, 0.15), (0.4, 0.9))
    rubbing = _pendulum_rig(rig, friction=(0.01, 0.03), finite=True, duration=2.0, swing=swing)
    s = simulate_session(browser_truth, rubbing, seed)
    for t in s.trials:
        if t.beating:
            assert t.name in swing.trials
            assert (t.dry_friction, t.dry_friction_fraction, t.finite_swing) == (0.0, 0.0, False)
            assert np.array_equal(t.true_rate(), angular_rate(t.time, t.modes))
        else:
            assert 0.01 <= t.dry_friction_fraction <= 0.03 and t.dry_friction > 0.0
    fractions = {t.dry_friction_fraction for t in s.trials if not t.beating}
    assert len(fractions) == len(s.trials) - 2  # drawn per trial
    assert {t.name for t in s.trials if t.finite_swing} == {
        f"{part}_compound_t1" for part in ("front_wheel", "frame", "fork")
    }
    with pytest.raises(SimulationError, match="one mode only"):
        motion_rate(s.trials[0].time, next(t for t in s.trials if t.beating).modes, 1e-3, False)
