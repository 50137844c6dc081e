"""Simulated rides: the segment fit recovers the model's weave eigenvalue within its σ, calibrated.

Short free decays (1.2–2 cycles at 100 Hz, as labs store them) of the linear model after a
steer-torque kick, with white roll-rate noise only: the measured eigenvalues' parts lie within
±1σ of the simulated A's weave eigenvalue at least 68 % of the time (a little more: the σ allow
for a rider's drive that these records do not have, :mod:`bike_rig.core.ride.noise`), and
segments that hold only noise, or less than a cycle, are flagged. Two bicycles: the Browser
with the paper's rider and the balance assist (closed loop), and the Meijaard benchmark
bicycle open loop. Then realistic rides (:mod:`bike_rig.core.ride.ridesim`: the rider's
steering, a saturating assist motor, a push): the segments at one speed scatter about their
weighted mean as their σ say (pooled χ²/dof within [0.5, 2]).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.calibration import measure_calibration
from bike_rig.core.ride.eigen import FLAG_SEGMENT_CYCLES, fit_segment
from bike_rig.core.ride.ridesim import RideConditions
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride import Kick, RideSimulation, simulate_ride
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

#: Settling after the kick's end before the segment starts, s (the caster mode dies out).
SETTLE_S = 0.3


@functools.cache
def _cases() -> tuple[tuple[object, float, np.ndarray | None], ...]:
    """(bicycle, speed m/s, assist gains or None) of each simulated case, built once for the file."""
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    assist = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert assist is not None
    bench = canonical_with_sigma(_parameters(str(config_file("bicycles/benchmark.yaml")), "centroid"))
    cases: list[tuple[object, float, np.ndarray | None]] = []
    for v in (2.5, 3.5, 4.5):
        cases.append((browser, v, assist.gains(v)))
    for v in (4.5, 5.5):
        cases.append((bench, v, None))
    return tuple(cases)


#: The weave eigenvalue of each of :func:`_cases`, by (id of its bicycle, speed), 1/s.
_WEAVES: dict[tuple[int, float], complex] = {}


def _weave(ms: object, v: float, gains: np.ndarray | None) -> complex:
    """The weave eigenvalue of one of :func:`_cases`, 1/s (the model probed once per case)."""
    key = (id(ms), v)
    if key not in _WEAVES:
        probe = simulate_ride(ms.matrices, ms.g, RideSimulation(v, 0.1), gains=gains)  # type: ignore[attr-defined]
        lam = probe.eigenvalues
        _WEAVES[key] = complex(lam[np.argmax(lam.imag)])
    return _WEAVES[key]


def _segment(ms: object, v: float, gains: np.ndarray | None, cycles: float, seed: int, noise: float = 0.01):
    """(times, roll rate, true weave eigenvalue) of one simulated short segment."""
    weave = _weave(ms, v, gains)
    length = cycles * 2 * math.pi / weave.imag
    start = 0.6 + SETTLE_S
    sim = RideSimulation(v, start + length + 0.05, kicks=(Kick(0.5, 0.1, 0.0, 5.0),), noise_roll_rate=noise, seed=seed)
    ride = simulate_ride(ms.matrices, ms.g, sim, gains=gains)  # type: ignore[attr-defined]
    inside = (ride.times >= start) & (ride.times < start + length)
    return ride.times[inside], ride.roll_rate[inside], weave


def test_short_segments_cover_the_weave_eigenvalue_68_percent() -> None:
    rng = np.random.default_rng(14)
    z_re, z_im = [], []
    n_invalid = 0
    for case, (ms, v, gains) in enumerate(_cases()):
        for k in range(24):
            cycles = float(rng.uniform(1.2, 2.0))
            t, y, weave = _segment(ms, v, gains, cycles, seed=1000 * case + k)
            m = fit_segment(t, y, speed=v)
            if not m.valid:
                n_invalid += 1
                continue
            assert m.imag > 0
            z_re.append((m.real - weave.real) / m.real_sigma)
            z_im.append((m.imag - weave.imag) / m.imag_sigma)
    n = len(z_re)
    assert n >= 100 and n_invalid <= 0.05 * (n + n_invalid)
    for z in (np.array(z_re), np.array(z_im)):
        within = float(np.mean(np.abs(z) < 1.0))
        assert 0.62 <= within <= 0.92, within  # measured 88 % and 86 %: no rider here, the drive's bound widens σ
        assert abs(float(np.mean(z))) < 0.35  # no bias beyond the σ (the capsize mode's trend is fitted)


def test_about_one_cycle_gives_a_flagged_eigenvalue_within_its_sigma() -> None:
    """0.85–1.2 cycles: the trial fitter's spectrum cannot resolve them, the frequency search does."""
    rng = np.random.default_rng(41)
    z: list[float] = []
    n_invalid = 0
    for case, (ms, v, gains) in enumerate(_cases()):
        for k in range(12):
            t, y, weave = _segment(ms, v, gains, float(rng.uniform(0.85, 1.2)), seed=500 + 100 * case + k)
            m = fit_segment(t, y, speed=v)
            if not m.valid:
                n_invalid += 1
                continue
            if m.n_cycles < FLAG_SEGMENT_CYCLES - 0.05:  # (the trial fitter's cycle tolerance)
                assert not m.clean and any(f.startswith("too_few_cycles") for f in m.flags)  # out of the means
            z += [(m.real - weave.real) / m.real_sigma, (m.imag - weave.imag) / m.imag_sigma]
    assert n_invalid <= 3
    within = float(np.mean(np.abs(np.array(z)) < 1.0))
    assert 0.5 <= within <= 0.9, within  # measured 84 %


def test_eq23_alone_is_biased_on_short_segments() -> None:
    """The documented reason for the refinement: Eq 23 alone (or a trend) misses a fast capsize mode's decay."""
    ms, v, gains = _cases()[3]  # the benchmark bicycle at 4.5 m/s: capsize at −0.73 1/s
    z: dict[str, list[tuple[float, float]]] = {"eq23": [], "eq23_trend": [], "auto": []}
    for seed in range(20):
        t, y, weave = _segment(ms, v, gains, 1.6, seed)
        for model, zs in z.items():
            m = fit_segment(t, y, speed=v, model=model)
            assert m.valid
            zs.append(((m.real - weave.real) / m.real_sigma, (m.imag - weave.imag) / m.imag_sigma))
    worst_bias = {model: float(np.max(np.abs(np.mean(np.array(zs), axis=0)))) for model, zs in z.items()}
    # measured: Eq 23 alone 12.8σ, with a trend 4.4σ, auto 0.08σ (it keeps the real mode): a documented
    # expectation, the calibration tests cover the rest
    assert worst_bias["eq23"] > 5.0 and worst_bias["eq23_trend"] > 2.5
    assert worst_bias["auto"] < 0.5


def test_noise_only_and_too_short_segments_are_flagged() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(200) / 100.0
    noise = fit_segment(t, rng.normal(0.0, 0.01, t.size), speed=3.0)
    assert not noise.valid
    assert any(f.startswith(("no_oscillation", "too_few_cycles")) for f in noise.flags)
    ms, v, gains = _cases()[2]
    t, y, _ = _segment(ms, v, gains, 0.6, seed=5)
    short = fit_segment(t, y, speed=v)
    assert not short.valid and any(f.startswith("too_few_cycles") for f in short.flags)
    assert math.isnan(short.real) and math.isnan(short.imag_sigma)
    flagged = [fit_segment(*_segment(ms, v, gains, 1.1, seed=s)[:2], speed=v) for s in range(5)]
    assert all(
        not m.clean and any(f.startswith(("too_few_cycles", "no_oscillation")) for f in m.flags) for m in flagged
    )


@pytest.mark.parametrize("model", ["auto", "eq23_trend", "eq23_real", "eq23"])
def test_noise_free_segment_gives_the_eigenvalue(model: str) -> None:
    ms, v, gains = _cases()[1]
    sim = RideSimulation(v, 4.0, kicks=(Kick(0.5, 0.1, 0.0, 5.0),), noise_roll_rate=1e-5, seed=1)
    ride = simulate_ride(ms.matrices, ms.g, sim, gains=gains)  # type: ignore[attr-defined]
    weave = _weave(ms, v, gains)
    inside = ride.times >= 1.5
    m = fit_segment(ride.times[inside], ride.roll_rate[inside], speed=v, model=model)
    tol = 0.02 if model == "eq23" else 2e-3  # Eq 23 alone: the capsize mode's bias
    assert m.valid and abs(m.imag - weave.imag) < tol * weave.imag and abs(m.real - weave.real) < 5 * tol


def test_realistic_rides_scatter_as_their_sigma_say() -> None:
    """Rider steering 0.05 and 0.2 N m (σ, 0.3 s correlation), motor saturating at 5 N m, 90 N m pushes."""
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    assist = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert assist is not None

    def gains(v: float) -> np.ndarray:  # twice the shipped roll-rate gain: a decaying weave at 6–15 km/h
        return assist.gains(v) * np.array([1.0, 1.0, 2.0, 1.0])

    runs = [
        measure_calibration(
            browser.matrices, browser.g, gains, (2.5, 4.2), RideConditions(rider_torque=rider), 8, seed=seed
        )
        for rider, seed in ((0.05, 3), (0.2, 4))
    ]
    dof = sum(c.dof for c in runs)
    assert dof >= 50 and all(c.clean >= 0.8 * c.segments for c in runs)
    for part in ("chi2_real", "chi2_imag"):
        pooled = sum(getattr(c, part) * c.dof for c in runs) / dof
        assert 0.5 <= pooled <= 2.0, (part, pooled, runs)


def test_shipped_gains_with_a_steering_rider_scatter_as_their_sigma_say() -> None:
    """The shipped assist (a weave near neutral at 2.5–3.5 m/s), a rider steering 0.2 N m, saturating or not.

    The residuals' moment estimate of the drive came out 2–5 times low here (χ²/dof 1.8–3.5);
    the shared drive is raised where the segments at one speed scatter beyond their σ (in a
    record that does so beyond chance). The errors against the simulated weave, which that does
    not see, must then be about 1 σ.
    """
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    assist = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert assist is not None
    runs = [
        measure_calibration(
            browser.matrices, browser.g, assist.gains, (2.5, 3.0, 3.5), RideConditions(saturation=sat), 8, seed=seed
        )
        for sat, seed in ((5.0, 21), (math.inf, 22))
    ]
    dof = sum(c.dof for c in runs)
    clean = sum(c.clean for c in runs)
    assert dof >= 50
    for part in ("chi2_real", "chi2_imag"):
        pooled = sum(getattr(c, part) * c.dof for c in runs) / dof
        assert 0.5 <= pooled <= 2.0, (part, pooled, runs)
    for part in ("z_real", "z_imag"):
        rms = math.sqrt(sum(getattr(c, part) ** 2 * c.clean for c in runs) / clean)
        assert 0.7 <= rms <= 1.3, (part, rms, runs)  # measured 1.10, 1.30 (no raise: 1.44; raising always: 1.17)
