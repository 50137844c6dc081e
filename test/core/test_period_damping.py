"""Damping models: a real pendulum's dry friction and finite swing (the pendulum integrator's records).

Records of :mod:`bike_rig.core.sim.pendulum` (viscous, dry, combined damping; a compound
pendulum's finite swing) through the test gyro (noise, random-walk drift, 12-bit ADC). The fit
chooses the damping model the data support, keeps its period's σ honest, and does not call a
linear envelope or a steadily moving period beating.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from bike_rig.core.period import FlagCode, fit_period
from bike_rig.core.period.damping import envelope, half_cycle_times
from test.support.signals import LSB, RATE_HZ, gyro_trial, pendulum_trial, pendulum_trials, quantise


def _fits(n: int, **kw: float) -> list:
    samples, _ = pendulum_trials(range(n), **kw)  # type: ignore[arg-type]
    return [fit_period(y, RATE_HZ) for y in samples]


def test_a_campaign_s_records_are_each_seed_s_own_record() -> None:
    # (the campaigns integrate the shared motion once: each seed's record must not see the others)
    kw = {"loss_per_cycle": 0.04, "compound": True, "swing": math.radians(16.0), "rate_amplitude": 0.5}
    batch, _ = pendulum_trials([5, 1, 3], **kw)  # type: ignore[arg-type]
    for seed, samples in zip([5, 1, 3], batch, strict=True):
        assert np.array_equal(samples, pendulum_trial(seed, **kw)[0])  # type: ignore[arg-type]


def test_the_envelope_is_exponential_linear_or_both_and_ends_at_rest() -> None:
    tau = np.linspace(-10.0, 10.0, 201)
    e, de_da, phi = envelope(tau, 0.02, 0.0)
    assert np.allclose(e, np.exp(-0.02 * tau)) and np.allclose(phi, np.expm1(-0.02 * tau) / 0.02)
    e, _, phi = envelope(tau, 0.0, 0.03)
    assert np.allclose(e, 1 - 0.03 * tau) and np.allclose(phi, -tau)
    e, _, _ = envelope(tau, 0.0, 0.2)  # the swing stops at τ = 5 s and stays stopped
    assert np.all(e[tau >= 5.0] == 0.0) and np.all(e[tau < 5.0] > 0)
    # (series and closed form agree where they meet)
    below, above = envelope(tau, 0.999e-5, 0.03), envelope(tau, 1.001e-5, 0.03)  # |α τ| 1e-4: the switch
    for series, closed in zip(below, above, strict=True):
        assert np.allclose(series, closed, rtol=1e-6, atol=1e-9)
    # dry friction's amplitude steps where the rate crosses zero: half-cycle peaks
    held = half_cycle_times(np.array([0.1, 0.3, 0.9]), 2 * math.pi, 0.0)
    assert held.tolist() == pytest.approx([0.0, 0.5, 1.0])


@pytest.mark.parametrize(
    ("truth", "kw"),
    [
        ("viscous", {"zeta": 0.003}),
        ("dry", {"loss_per_cycle": 0.04}),
        ("combined", {"zeta": 0.004, "loss_per_cycle": 0.02}),
    ],
)
def test_the_damping_model_the_data_support_is_chosen_and_its_period_is_honest(truth: str, kw: dict) -> None:
    n = 40
    fits = _fits(n, **kw)
    chosen = Counter(f.damping_model for f in fits)
    assert chosen[truth] >= 0.95 * n, chosen
    true_period = 1.6 / math.sqrt(1 - kw.get("zeta", 0.0) ** 2)
    z = np.array([(f.period - true_period) / f.period_sigma for f in fits])
    assert abs(np.mean(z)) < 0.5 and 0.5 < np.mean(np.abs(z) < 1.0) <= 0.95, z  # ±σ covers ≈ 68-85 %
    assert not any(f.has_flag(FlagCode.BEATING) for f in fits)
    assert all(f.clean for f in fits), [f.flag_codes for f in fits if not f.clean]
    if truth != "viscous":
        friction = np.array([f.friction for f in fits if f.damping_model == truth])
        assert np.all(friction > 0)
        assert all(any(f"damping {truth}" in note for note in f.notes) for f in fits if f.damping_model == truth)


@pytest.mark.parametrize(
    ("kw", "model"), [({"loss_per_cycle": 0.04}, "dry"), ({"zeta": 0.004, "loss_per_cycle": 0.02}, "combined")]
)
def test_the_chosen_model_is_what_is_drawn(kw: dict, model: str) -> None:
    samples, _ = pendulum_trial(3, **kw)
    fit = fit_period(samples, RATE_HZ)
    assert fit.damping_model == model and fit.r2 > 0.99
    t = np.arange(samples.size) / RATE_HZ
    a, b = fit.window
    residual = samples[a:b] - fit.predict(t[a:b])
    assert np.sqrt(np.mean(residual**2)) == pytest.approx(fit.residual_rms, rel=1e-9)
    assert a / RATE_HZ < fit.damping_origin < b / RATE_HZ


def test_viscous_trials_keep_eq_23() -> None:
    fits = [fit_period(gyro_trial(seed, period=1.5, zeta=0.003).samples, RATE_HZ) for seed in range(60)]
    assert Counter(f.damping_model for f in fits)["viscous"] >= 57


def test_a_dry_friction_record_is_not_beating_but_a_coupled_swing_still_is() -> None:
    # the real fork: 0.040 of the initial amplitude lost per 1.6 s period, 30 s
    fit = fit_period(pendulum_trial(11, loss_per_cycle=0.04)[0], RATE_HZ)
    assert fit.valid and not fit.has_flag(FlagCode.BEATING) and fit.damping_model == "dry"


@pytest.mark.parametrize("swing_deg", [10.0, 20.0])
def test_a_finite_swing_is_not_beating(swing_deg: float) -> None:
    fits = _fits(20, zeta=0.003, compound=True, swing=math.radians(swing_deg), rate_amplitude=0.5)
    assert not any(f.has_flag(FlagCode.BEATING) for f in fits), [f.flag_codes for f in fits]
    assert all(f.valid for f in fits)


@pytest.mark.parametrize(("kw", "model"), [({"zeta": 0.003}, "viscous"), ({"loss_per_cycle": 0.04}, "dry")])
def test_a_finite_swing_gives_the_small_swing_period_of_the_integrated_pendulum(kw: dict, model: str) -> None:
    # a compound pendulum swinging 16°: its period shortens by 0.5 % as the swing decays; the
    # fit follows the period with the swing (κ) and reports the period of a vanishing swing
    swing = math.radians(16.0)
    fits = _fits(20, compound=True, swing=swing, rate_amplitude=0.5, **kw)
    # (with a swing, dry friction's loss per half swing depends on the swing: the envelope of
    # the nonlinear pendulum is not quite linear, and some fits keep a small viscous term)
    models = Counter(f.damping_model for f in fits)
    assert models[model] >= 0.85 * len(fits) and set(models) <= {model, "combined"}, models
    assert all(f.valid and f.swing_kappa < 0 for f in fits)
    t0 = 1.6 / math.sqrt(1 - kw.get("zeta", 0.0) ** 2)
    z = np.array([(f.small_swing_period - t0) / f.small_swing_period_sigma for f in fits])
    assert np.all(np.abs(z) < 4) and abs(np.mean(z)) < 1.0, z
    # the first-order swing law: κ ≈ −θ²/16 at the window centre's swing
    assert all(0.1 * swing**2 / 16 < -f.swing_kappa < swing**2 / 16 for f in fits)
    assert all(any("the period follows the swing" in note for note in f.notes) for f in fits)
    # the period at the centre's swing is longer than the small-swing one
    assert all(f.period > f.small_swing_period for f in fits)


def test_a_torsional_pendulum_has_no_swing_term() -> None:
    fits = _fits(20, zeta=0.003, compound=False, swing=math.radians(20.0), rate_amplitude=0.5)
    assert all(math.isnan(f.small_swing_period) and f.swing_kappa == 0.0 for f in fits)


def test_every_fit_reports_its_period_along_the_record() -> None:
    # steady records: the windows agree within their σ (χ² about its 3 degrees of freedom)
    chi2 = []
    for seed in range(40):
        fit = fit_period(gyro_trial(seed, period=1.5, zeta=0.003).samples, RATE_HZ)
        assert len(fit.window_periods) == 4 and len(fit.window_period_sigmas) == 4
        p, s = np.array(fit.window_periods), np.array(fit.window_period_sigmas)
        chi2.append(np.sum(((p - np.sum(p / s**2) / np.sum(1 / s**2)) / s) ** 2))
    assert 1.5 < np.mean(chi2) < 5.0, chi2
    # a 16° compound swing with dry friction: the period shortens along the record, beyond σ
    # (a note, no flag: 0.25 % is far from making the period meaningless)
    fit = fit_period(
        pendulum_trial(4, loss_per_cycle=0.04, compound=True, swing=math.radians(16.0), rate_amplitude=0.5)[0], RATE_HZ
    )
    assert fit.window_periods[0] > fit.window_periods[-1] + 3 * max(fit.window_period_sigmas)
    assert any("the period along the record" in n and "moves beyond its σ" in n for n in fit.notes)
    assert not fit.has_flag(FlagCode.PERIOD_DRIFT) and fit.clean


def test_a_period_that_moves_by_percents_is_flagged() -> None:
    # a clamp slipping: the period steps by 3 % half way through the record
    rng = np.random.default_rng(5)
    t = np.arange(30000) / RATE_HZ
    phase = 2 * math.pi * np.where(t < 15, t / 1.5, 15 / 1.5 + (t - 15) / 1.545)
    y = quantise(0.05 * np.exp(-0.003 * 4.2 * t) * np.sin(phase) + LSB * rng.standard_normal(t.size))
    fit = fit_period(y, RATE_HZ)
    flag = next(f for f in fit.flags if f.code is FlagCode.PERIOD_DRIFT)
    assert "the period moves along the record" in flag.reason and "beyond a constant period" in flag.reason
