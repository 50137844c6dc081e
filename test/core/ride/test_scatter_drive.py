"""The drive shared at one speed: raised only where the segments scatter beyond their σ, then to match it."""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.core.ride.noise import scatter_drive


def _chi2(x: np.ndarray, v: np.ndarray, q: float) -> float:
    out = 0.0
    for part in (0, 1):
        w = 1.0 / (v[:, 2 * part] + q * v[:, 2 * part + 1])
        m = np.sum(w * x[:, part]) / np.sum(w)
        out += float(np.sum(w * (x[:, part] - m) ** 2))
    return out


def test_segments_within_their_sigma_keep_the_drive() -> None:
    x = np.array([[-0.50, 7.00], [-0.52, 7.01], [-0.49, 6.99]])
    v = np.tile([1e-3, 1.0, 1e-3, 1.0], (3, 1))
    assert scatter_drive(x, v, 2e-4) == 2e-4
    assert scatter_drive(x[:1], v[:1], 2e-4) == 2e-4  # one segment: no scatter to see


def test_segments_scattering_beyond_their_sigma_get_the_drive_that_explains_it() -> None:
    rng = np.random.default_rng(4)
    x = np.column_stack([-0.5 + rng.normal(0, 0.3, 4), 7.0 + rng.normal(0, 0.3, 4)])
    v = np.column_stack([np.full(4, 1e-3), rng.uniform(50, 150, 4), np.full(4, 1e-3), rng.uniform(50, 150, 4)])
    assert _chi2(x, v, 1e-5) > 6.0  # beyond its 2 (n − 1) = 6
    q = scatter_drive(x, v, 1e-5)
    assert q > 1e-5 and _chi2(x, v, q) == pytest.approx(6.0, rel=1e-6)
