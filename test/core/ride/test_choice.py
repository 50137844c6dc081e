"""The segment model: never a decaying record made unstable, cycles counted independently, non-free decays flagged."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import bike_rig.core.ride.choice as choice
from bike_rig.core.ride.eigen import combine_eigenvalues, fit_segment
from bike_rig.core.ride.realmode import RealModeFit

OMEGA = 8.7  # rad/s, the weave
DT = 0.01


def _decay(cycles: float, alpha: float = 1.2, seed: int = 0, noise: float = 0.005) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, cycles * 2 * math.pi / OMEGA, DT)
    rng = np.random.default_rng(seed)
    return t, 0.3 * np.exp(-alpha * t) * np.sin(OMEGA * t + 0.4) + rng.normal(0.0, noise, t.size)


def test_a_refinement_that_makes_a_decaying_record_unstable_is_left_out(monkeypatch: pytest.MonkeyPatch) -> None:
    """The issue's 1.3-cycle segment: a real mode at +1.49 ± 0.72 + 11.8i against Eq 23's −1.2 + 8.7i."""
    original = choice.fit_with_real_mode

    def unstable_real_mode(*args: object, **kwargs: object) -> RealModeFit:
        fit = original(*args, **kwargs)  # type: ignore[arg-type]
        if kwargs.get("free_mu"):  # better by far in SSE, and unstable
            return dataclasses.replace(fit, alpha=-1.49, omega_d=11.8, sse=0.1 * fit.sse)
        return fit

    monkeypatch.setattr(choice, "fit_with_real_mode", unstable_real_mode)
    t, y = _decay(1.3)
    m = fit_segment(t, y, speed=2.0)
    assert m.valid and m.model == "eq23" and m.real < 0
    assert m.real == pytest.approx(-1.2, abs=0.15) and m.imag == pytest.approx(OMEGA, abs=0.15)
    assert any(n.startswith("eq23_real left out") for n in m.notes)


def test_the_cycle_count_does_not_follow_the_refined_frequency(monkeypatch: pytest.MonkeyPatch) -> None:
    original = choice.choose_model

    def inflated(*args: object, **kwargs: object) -> choice.ModelChoice:
        c = original(*args, **kwargs)  # type: ignore[arg-type]
        return dataclasses.replace(c, imag=1.36 * c.imag)  # 8.7 → 11.8 rad/s

    monkeypatch.setattr(choice, "choose_model", inflated)
    monkeypatch.setattr("bike_rig.core.ride.eigen.choose_model", inflated)
    t, y = _decay(1.1, alpha=0.5)
    m = fit_segment(t, y, speed=2.0)
    assert m.imag > 11.0  # the (inflated) refinement is reported ...
    assert m.n_cycles == pytest.approx(1.1, abs=0.05)  # ... but the cycles are Eq 23's
    assert any(f.startswith("too_few_cycles") for f in m.flags) and not m.clean


@pytest.mark.parametrize(
    ("peaks", "why"),
    [
        ((0.20, 0.28, 0.20, 0.14, 0.10), "the second peak above the first"),
        ((0.25, 0.12, 0.20, 0.14, 0.10), "a dip and a bump"),
        ((0.30, 0.22, 0.30, 0.16, 0.12), "a bump on a decay"),
    ],
)
def test_non_free_decays_are_flagged_and_left_out_of_the_means(peaks: tuple[float, ...], why: str) -> None:
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 2.6 * 2 * math.pi / OMEGA, DT)
    at = 0.05 + (np.arange(len(peaks)) + 0.5) * math.pi / OMEGA  # the half-cycles' peaks (cut 0.05 s early)
    y = np.interp(t, at, peaks) * np.sin(OMEGA * (t - 0.05)) + rng.normal(0.0, 0.005, t.size)
    bad = fit_segment(t, y, speed=3.0, index=1)
    assert any(f.startswith("not_free_decay") for f in bad.flags), (why, bad.flags)
    good = [fit_segment(*_decay(2.2, alpha=0.8, seed=s), speed=3.0, index=2 + s) for s in range(2)]
    assert all(g.clean for g in good)
    (combined,) = combine_eigenvalues([bad, *good])
    assert combined.n_used == 2 and combined.n_left_out == 1


def test_free_decays_growing_or_decaying_are_not_flagged() -> None:
    for alpha in (1.2, 0.3, -0.3):
        for seed in range(5):
            m = fit_segment(*_decay(2.0, alpha=alpha, seed=seed), speed=3.0)
            assert m.clean, (alpha, seed, m.flags)
            assert math.copysign(1.0, m.real) == math.copysign(1.0, -alpha)
