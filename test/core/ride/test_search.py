"""The short-segment frequency search finds a free decay that falls into the noise within the segment."""

from __future__ import annotations

import math

import numpy as np
import pytest

import bike_rig.core.ride.realmode as realmode
from bike_rig.core.ride.eigen import fit_segment


def _fast_decay(seed: int, cycles: float = 1.6, drop: float = 3.5) -> tuple[np.ndarray, np.ndarray, complex]:
    """A weave at 8 rad/s whose envelope falls by e^(−drop) over the segment, a drift and white noise."""
    rng = np.random.default_rng(seed)
    w = 8.0
    t = np.arange(0.0, cycles * 2.0 * math.pi / w, 0.01)
    alpha = drop / t[-1]
    y = 0.2 * np.exp(-alpha * t) * np.cos(w * t + rng.uniform(0, 2 * math.pi)) + 0.01 * t
    return t, y + rng.normal(0.0, 0.01, t.size), complex(-alpha, w)


@pytest.mark.parametrize("seed", range(6))
def test_the_search_finds_a_fast_decays_frequency(seed: int) -> None:
    t, y, weave = _fast_decay(seed)
    search = realmode.search_frequency(t, y)
    assert search.found
    assert abs(search.omega_d / weave.imag - 1.0) < 0.08
    assert search.alpha > 0


def test_an_undamped_search_alone_misses_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """Why the decays are searched: the best undamped sinusoid lies far from a fast decay's frequency."""
    monkeypatch.setattr(realmode, "SEARCH_DECAYS", (0.0,))
    errors = []
    for seed in range(6):
        t, y, weave = _fast_decay(seed)
        errors.append(abs(realmode.search_frequency(t, y).omega_d / weave.imag - 1.0))
    assert max(errors) > 0.08


def test_noise_alone_finds_no_oscillation() -> None:
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 1.5, 0.01)
    assert not any(realmode.search_frequency(t, rng.normal(0.0, 0.01, t.size)).found for _ in range(20))


def test_fast_decays_are_not_left_out_for_their_sigma() -> None:
    """A fast decay's own σ is larger: a tight bound on it would keep the slow draws only (a biased mean)."""
    fits = [fit_segment(*_fast_decay(seed)[:2], speed=3.0) for seed in range(6)]
    assert sum(m.valid for m in fits) >= 5
    for m, seed in zip(fits, range(6), strict=True):
        if m.valid:
            weave = _fast_decay(seed)[2]
            assert m.real < 0 and abs(m.imag - weave.imag) < 3.0 * m.imag_sigma
