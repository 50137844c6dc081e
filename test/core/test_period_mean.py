"""The default period is the mean period over the window, and its σ covers what the record shows.

A pendulum record simulated with its phase known exactly: dry friction (the swing falls by the
same angle every half swing, a linear envelope), a finite swing (T = T₀ (1 + θ²/16) at the
swing θ of each half swing), a rate gyro's noise, random-walk bias and 12-bit ADC, and
optionally an unexplained late change of the period. The truth is the window's length over the
cycles in it. ``python -m test.core.test_period_mean --seeds 1000`` runs a larger campaign.
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray
from scipy.optimize import least_squares

from bike_rig.config.paths import config_file
from bike_rig.core.period import FlagCode, PeriodFit, WindowPolicy, damped_oscillation, damped_period, fit_period
from bike_rig.core.period.advice import flag_advice
from bike_rig.core.period.damping import mean_period, mean_swing_square, swing_stop
from bike_rig.core.period.sigma import jackknife_windows, sandwich, window_sandwich
from bike_rig.core.sim import TrialSimulator, load_rig, load_true_parameters
from test.support.signals import LSB, gyro_trial, quantise

RATE_HZ = 1000.0
T0 = 1.5848  # the small-swing period of the fork, s


@dataclass(frozen=True)
class SwingRecord:
    """A simulated record and its phase: piecewise linear between the rate's zeros.

    Attributes:
        samples: The gyro's samples at ``RATE_HZ``, rad/s.
        knots: Times of the rate's zeros (the turning points), s.
        phases: The phase there, rad (a multiple of π, the first excepted).
        omegas: The angular frequency from each knot to the next, rad/s.
        small_swing_period: T₀, s.
    """

    samples: NDArray[np.float64]
    knots: NDArray[np.float64]
    phases: NDArray[np.float64]
    omegas: NDArray[np.float64]
    small_swing_period: float

    def phase(self, t: float) -> float:
        """The phase at time t, rad."""
        i = int(np.searchsorted(self.knots, t, side="right")) - 1
        return float(self.phases[i] + self.omegas[i] * (t - self.knots[i]))

    def mean_period(self, window: tuple[int, int]) -> float:
        """The true mean period over the samples [a, b): their span over the cycles in it, s."""
        start, stop = (window[0] - 0.5) / RATE_HZ, (window[1] - 0.5) / RATE_HZ
        return 2 * math.pi * (stop - start) / (self.phase(stop) - self.phase(start))


def swing_record(
    seed: int,
    swing_deg: float = 13.0,
    loss_per_cycle: float = 0.032,
    late: tuple[float, float] | None = None,
    rate_amplitude: float = 0.27,
    noise: float = 3 * LSB,
    drift: float = 10 * LSB,
    duration: float = 30.0,
) -> SwingRecord:
    """A compound pendulum with dry friction through the test gyro.

    Args:
        seed: Seed of the noise and the starting phase.
        swing_deg: The swing at the start, degrees (the issue's fork: 13°, 9° at the centre).
        loss_per_cycle: Swing lost per cycle, a fraction of the starting swing.
        late: (from t [s], ΔT [s]): the period changes linearly by ΔT from then to the end.
        rate_amplitude: The rate's amplitude at the start, rad/s.
        noise: White noise σ, rad/s.
        drift: σ of the bias random walk at the end, rad/s.
        duration: Record length, s.
    """
    rng = np.random.default_rng(seed)
    swing = math.radians(swing_deg)
    phase = float(rng.uniform(0, 2 * math.pi))
    half = math.floor(phase / math.pi)
    t, angle = 0.0, swing
    knots, phases, omegas, angles = [t], [phase], [], []
    while t < duration + T0:
        half += 1
        period = T0 * (1 + angle**2 / 16)
        if late is not None and t > late[0]:
            period += late[1] * (t - late[0]) / (duration - late[0])
        omega = 2 * math.pi / period
        t += (half * math.pi - phase) / omega
        phase = half * math.pi
        knots.append(t)
        phases.append(phase)
        omegas.append(omega)
        angles.append(angle)
        angle -= 0.5 * loss_per_cycle * swing
    knots_a, phases_a, omegas_a = np.array(knots), np.array(phases), np.array(omegas)
    ts = np.arange(round(duration * RATE_HZ)) / RATE_HZ
    i = np.searchsorted(knots_a, ts, side="right") - 1
    rate = -np.array(angles)[i] * omegas_a[i] * np.sin(phases_a[i] + omegas_a[i] * (ts - knots_a[i]))
    y = rate * (rate_amplitude / (swing * omegas_a[0])) + 0.01 + noise * rng.standard_normal(ts.size)
    y += np.cumsum(rng.standard_normal(ts.size)) * (drift / math.sqrt(ts.size))
    return SwingRecord(quantise(y), knots_a, phases_a, omegas_a, T0)


def _errors(fits: list[PeriodFit], records: list[SwingRecord]) -> NDArray[np.float64]:
    """(T − T̄_true) / σ per record."""
    return np.array([(f.period - r.mean_period(f.window)) / f.period_sigma for f, r in zip(fits, records, strict=True)])


def _eq23(samples: NDArray[np.float64], fit: PeriodFit) -> float:
    """The period of Eq 23 fitted to every sample of ``fit``'s window (the paper's least squares), s."""
    a, b = fit.window
    t = np.arange(a, b) / RATE_HZ - fit.t_ref
    y = samples[a:b]
    found = least_squares(
        lambda p: damped_oscillation(t, *p) - y,
        [fit.A, fit.B, fit.C, fit.zeta, fit.omega],
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    return damped_period(found.x[3], found.x[4])


# ---------------------------------------------------------------- the mean over the window


def test_the_mean_square_of_an_envelope_over_a_window() -> None:
    # a linear envelope E = 1 − γτ over (−W/2, W/2): ⟨E²⟩ − 1 = γ²W²/12
    assert mean_swing_square(0.0, 0.02, -15.0, 15.0) == pytest.approx(0.02**2 * 30**2 / 12, rel=1e-4)
    # an exponential one: ⟨e^(−2ατ)⟩ − 1 = sinh(αW)/(αW) − 1
    x = 0.03 * 30
    assert mean_swing_square(0.03, 0.0, -15.0, 15.0) == pytest.approx(math.sinh(x) / x - 1, rel=1e-4)
    # once the swing has stopped (τ = 1/γ = 10 s) there is no frequency to average
    assert swing_stop(0.0, 0.1) == pytest.approx(10.0) and swing_stop(0.05, 0.0) == math.inf
    assert mean_swing_square(0.0, 0.1, -5.0, 20.0) == pytest.approx(mean_swing_square(0.0, 0.1, -5.0, 10.0))
    # Eq 25 over the window: the centre's period without a swing term, longer than it with one
    assert mean_period(4.0, 0.0, 0.0, 0.02, (-15.0, 15.0)) == 2 * math.pi / 4.0
    assert mean_period(4.0, -0.002, 0.0, 0.02, (-15.0, 15.0)) > 2 * math.pi / 4.0


def test_the_default_period_is_the_mean_over_the_window_and_its_sigma_covers_it() -> None:
    # the fork: dry friction, a 13° → 5° compound swing, a 12-bit ADC; 200 seeds
    records = [swing_record(seed) for seed in range(200)]
    fits = [fit_period(r.samples, RATE_HZ) for r in records]
    assert Counter(f.damping_model for f in fits)["dry"] >= 190 and all(f.swing_kappa < 0 for f in fits)
    z = _errors(fits, records)
    assert 0.60 <= np.mean(np.abs(z) <= 1.0) <= 0.90, np.mean(np.abs(z) <= 1.0)  # (the ends widen a third)
    assert abs(np.mean(z)) < 0.2, np.mean(z)
    assert all(f.clean and f.period == f.mean_period for f in fits)
    # the period at the window centre's swing (the old default) is a different quantity
    # (in units of the model's own σ: the ends' check widens some)
    centre = np.array(
        [
            (f.centre_period - r.mean_period(f.window)) / (f.period_sigma / f.sigma_widening)
            for f, r in zip(fits, records)
        ]
    )
    assert np.mean(np.abs(centre) <= 1.0) < 0.1 and np.all(centre < 0)
    # the small-swing period keeps its own σ honest
    small = np.array([(f.small_swing_period - T0) / f.small_swing_period_sigma for f in fits])
    assert 0.60 <= np.mean(np.abs(small) <= 1.0) <= 0.85, np.mean(np.abs(small) <= 1.0)


def test_the_default_period_is_eq_23s_where_eq_23_fits() -> None:
    # the fit of the block means against the paper's least squares on every sample
    for seed in range(10):
        trial = gyro_trial(seed, period=1.5, zeta=0.003)
        fit = fit_period(trial.samples, RATE_HZ)
        assert fit.damping_model == "viscous" and fit.period == fit.mean_period
        eq23 = _eq23(trial.samples, fit)
        assert abs(fit.period - eq23) < min(0.1 * fit.period_sigma, 2.5e-6 * eq23)


def test_the_small_swing_period_is_an_option_and_agrees_with_itself_over_windows() -> None:
    record = swing_record(7)
    spans = [(1.0, None), (1.0, 20.0), (10.0, None)]
    fits = [
        fit_period(record.samples, RATE_HZ, window=WindowPolicy.span(*span), small_swing_period=True) for span in spans
    ]
    for fit in fits:
        assert fit.period == fit.small_swing_period and fit.mean_period > fit.period
        assert abs(fit.period - T0) < 3 * fit.period_sigma
    for i, a in enumerate(fits):
        for b in fits[i + 1 :]:
            assert abs(a.period - b.period) < 2 * math.hypot(a.period_sigma, b.period_sigma)


# ---------------------------------------------------------------- what the model does not explain


def test_a_late_period_change_the_swing_does_not_explain_is_flagged_and_covered() -> None:
    # the record: the period drops by 7 ms in the last 7 s, the swing hardly changing
    records = [swing_record(seed, late=(23.0, -0.007), noise=LSB, drift=3 * LSB) for seed in range(20)]
    fits = [fit_period(r.samples, RATE_HZ) for r in records]
    z = _errors(fits, records)
    assert np.mean(np.abs(z) <= 1.0) >= 0.6 and np.all(np.abs(z) < 3), z
    for fit in fits:
        assert fit.has_flag(FlagCode.PERIOD_DRIFT) and fit.sigma_widening > 1
        assert any("the mean period is the windows'" in note for note in fit.notes)
        reason = next(f.reason for f in fit.flags if f.code is FlagCode.PERIOD_DRIFT)
        assert "beyond the swing" in reason and "× its σ" in reason
    assert "clamp" in flag_advice(FlagCode.PERIOD_DRIFT)
    # the small-swing period depends on the window: its σ is widened, or the trial flagged
    fit = fit_period(records[0].samples, RATE_HZ, window=WindowPolicy.span(1.0, 20.0))
    assert not fit.has_flag(FlagCode.PERIOD_DRIFT)
    assert abs(fit.small_swing_period - fits[0].small_swing_period) > 2 * fit.small_swing_period_sigma


def test_a_small_unexplained_step_is_flagged_without_a_fixed_limit() -> None:
    # a clamp slipping: the period steps by 0.3 % half way (the old limit was 2 %)
    rng = np.random.default_rng(5)
    t = np.arange(30000) / RATE_HZ
    phase = 2 * math.pi * np.where(t < 15, t / 1.5, 15 / 1.5 + (t - 15) / 1.5045)
    y = quantise(0.05 * np.exp(-0.003 * 4.2 * t) * np.sin(phase) + LSB * rng.standard_normal(t.size))
    fit = fit_period(y, RATE_HZ)
    assert fit.has_flag(FlagCode.PERIOD_DRIFT) and fit.sigma_widening > 1
    truth = 2 * math.pi * ((fit.window[1] - fit.window[0]) / RATE_HZ)
    truth /= np.interp((fit.window[1] - 0.5) / RATE_HZ, t, phase) - np.interp((fit.window[0] - 0.5) / RATE_HZ, t, phase)
    assert abs(fit.period - truth) < 2 * fit.period_sigma


def test_steady_records_are_not_flagged_and_widened_only_where_their_ends_depart_by_chance() -> None:
    fits = [fit_period(gyro_trial(seed, period=1.5, zeta=0.003).samples, RATE_HZ) for seed in range(60)]
    assert not any(f.has_flag(FlagCode.PERIOD_DRIFT) for f in fits)
    assert sum(f.period != f.mean_period for f in fits) == 0
    # the windowed test widens at its 5 %; the ends' check where |ΔT| > σ_ΔT (about a third)
    widened = [f for f in fits if f.sigma_widening > 1]
    assert 5 <= len(widened) <= 30, len(widened)
    for f in widened:
        distance = abs(f.ends_period - f.period)
        assert distance > 0 and f.period_sigma >= distance  # (the ends' distance is inside σ)
    assert np.median([f.sigma_widening for f in fits]) == 1.0


def test_the_rig_simulators_clean_trials_are_not_flagged_and_their_sigma_covers(tmp_path: Path) -> None:
    # the short rig of the live tests: 15 s per trial, 8-18 cycles; seed 4's front wheel has two
    # windows 6.8 σ apart by chance (p = 3e-4): its σ carries it, the trial is not sent to be redone
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, "duration": 15})
    data["coupled_swing"].update({"probability": 0.0, "trials": []})
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(data), encoding="utf-8")
    rig = load_rig(tmp_path / "rig.yaml")
    name, params = load_true_parameters(config_file("bicycles/browser.yaml"))
    z, moved = [], 0
    for seed in range(8):
        sim = TrialSimulator.create(params, rig, seed, name)
        for counter, m in enumerate(sim.plan):
            trial = sim.simulate(m, counter, 1)
            fit = fit_period(trial.volts, sample_rate_hz=trial.sample_rate)
            assert fit.valid and not fit.has_flag(FlagCode.PERIOD_DRIFT), (seed, m.key, fit.flags)
            assert fit.period_sigma >= fit.period_sigma_white, (seed, m.key)  # (8-10 cycles: Eq 27 a floor)
            z.append((fit.period - sim.damped_period(m.key)) / fit.period_sigma)
            moved += any("the period moves beyond" in note for note in fit.notes)
    assert moved >= 1  # (seed 4's front wheel: said in a note, carried by the σ)
    assert 0.58 <= np.mean(np.abs(z) <= 1.0) <= 0.9, z


def test_the_window_jackknife_takes_about_sqrt_cycles_windows_of_two_cycles_or_more() -> None:
    assert jackknife_windows(3) is None and list(jackknife_windows(4)) == [0, 2]  # type: ignore[arg-type]
    for cycles in range(4, 60):
        starts = jackknife_windows(cycles)
        assert starts is not None and np.all(np.diff(np.append(starts, cycles)) >= 2)
        assert abs(starts.size - math.sqrt(cycles)) <= 1


def test_the_window_jackknife_gathers_what_cycles_share_and_agrees_with_the_cycles_otherwise() -> None:
    # one parameter, influence h per cycle: the sandwich over cycles vs over windows of cycles
    rng = np.random.default_rng(3)
    cycles = 25
    G, v, e = np.eye(1) * 1e-6, np.zeros((1, cycles)), np.ones(cycles)
    independent = [window_sandwich(G, rng.standard_normal((1, cycles)), v, e, first=0) for _ in range(400)]
    assert np.mean([c[0, 0] for c in independent if c is not None]) == pytest.approx(cycles * 1e-12, rel=0.1)
    shared = np.repeat(rng.choice([-1.0, 1.0], 5), 5)[None, :] + 0.1 * rng.standard_normal((1, cycles))
    cycle_cov, _ = sandwich(G, shared, v, e, first=0)
    window_cov = window_sandwich(G, shared, v, e, first=0)
    assert cycle_cov is not None and window_cov is not None and window_cov[0, 0] > 3 * cycle_cov[0, 0]


# ---------------------------------------------------------------- a larger campaign


def _campaign(seeds: int) -> None:  # pragma: no cover - run by hand
    """Coverage of ±σ, widening and flags over ``seeds`` records of each kind; prints a table."""
    kinds: dict[str, dict[str, object]] = {
        "dry + swing": {},
        "dry + swing, late −3 ms": {"late": (23.0, -0.003)},
        "dry + swing, late −7 ms": {"late": (23.0, -0.007)},
        "dry + swing, late −7 ms, quiet gyro": {"late": (23.0, -0.007), "noise": LSB, "drift": 3 * LSB},
    }
    print(f"{'records':40s} {'±σ covers':>9s} {'mean z':>7s} {'widened':>8s} {'flagged':>8s} {'T₀ ±σ':>6s}")
    for name, kw in kinds.items():
        start = time.perf_counter()
        records = [swing_record(seed, **kw) for seed in range(seeds)]  # type: ignore[arg-type]
        fits = [fit_period(r.samples, RATE_HZ) for r in records]
        z = _errors(fits, records)
        small = np.mean([abs(f.small_swing_period - T0) <= f.small_swing_period_sigma for f in fits])
        widened = np.mean([f.sigma_widening > 1 for f in fits])
        flagged = np.mean([f.has_flag(FlagCode.PERIOD_DRIFT) for f in fits])
        took = time.perf_counter() - start
        print(
            f"{name:40s} {np.mean(np.abs(z) <= 1):9.3f} {np.mean(z):7.2f} {widened:8.3f} {flagged:8.3f} "
            f"{small:6.3f}  ({took:.1f} s)"
        )
    eq23 = [
        (f.period - _eq23(t.samples, f)) / f.period_sigma
        for t in (gyro_trial(seed, period=1.5, zeta=0.003) for seed in range(min(seeds, 200)))
        for f in [fit_period(t.samples, RATE_HZ)]
    ]
    z23 = np.abs(eq23)
    print(f"Eq 23 records: (default − Eq 23) / σ: median |z| {np.median(z23):.2g}, largest {np.max(z23):.2g}")


if __name__ == "__main__":  # pragma: no cover
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1000)
    _campaign(parser.parse_args().seeds)
