"""``predicted_weave`` with a digital assist (the feedback's ``rate_hz``): the sampled loop's eigenvalue."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import cont2discrete

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.pipeline.ride import SampledLoopError, predicted_weave

SPEEDS = np.array([1.5, 3.0, 4.5, 6.5])


def _sampled_truth(ms: object, v: float, gains: np.ndarray, rate: float) -> np.ndarray:
    """``ln eig(Φ − Γ_δ K) · rate`` from ``cont2discrete`` (independent of the code under test) [1/s]."""
    a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, v, ms.g))  # type: ignore[attr-defined]
    ad, bd, *_ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), 1.0 / rate, method="zoh")
    return np.log(np.linalg.eigvals(ad - np.outer(bd[:, 1], gains)).astype(complex)) * rate


@pytest.mark.parametrize("name", ["browser", "yellow"])
def test_a_rate_gives_the_sampled_loops_eigenvalue_with_the_continuous_sigma(name: str) -> None:
    ps = add_rider(_parameters(str(config_file(f"bicycles/{name}.yaml")), "centroid"), PAPER_RIDER)
    ms = canonical_with_sigma(ps)
    fb = load_feedback(config_file("feedback/balance_assist.yaml"))
    cont = predicted_weave(ps, SPEEDS, fb)
    samp = predicted_weave(ps, SPEEDS, replace(fb, rate_hz=100.0))
    moved = 0
    for i, v in enumerate(SPEEDS):
        if not np.isfinite(cont.real[i]):
            assert not np.isfinite(samp.real[i])
            continue
        truth = _sampled_truth(ms, float(v), fb.gains(v), 100.0)
        got = complex(samp.real[i], samp.imag[i])
        nearest = truth[np.argmin(np.abs(truth - got))]
        assert abs(nearest - got) < 1e-8 * abs(got)
        assert abs(got - complex(cont.real[i], cont.imag[i])) < 0.05 * abs(got)  # the same mode, shifted a little
        moved += abs(got - complex(cont.real[i], cont.imag[i])) > 1e-3
    assert moved >= 2  # the hold shows where the assist acts
    np.testing.assert_array_equal(samp.real_sigma, cont.real_sigma)
    np.testing.assert_array_equal(samp.imag_sigma, cont.imag_sigma)
    assert samp.sigma_method == cont.sigma_method and samp.branches == cont.branches
    note = next(n for n in samp.notes if "100 Hz" in n)
    assert "zero-order hold" in note and "σ is the continuous loop's" in note
    assert not any("Hz" in n for n in cont.notes)


def test_a_controller_too_slow_for_the_weave_is_refused() -> None:
    ps = add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    fb = replace(load_feedback(config_file("feedback/balance_assist.yaml")), rate_hz=2.0)
    with pytest.raises(SampledLoopError, match=r"controller at 2 Hz is too slow for the mode at .* m/s"):
        predicted_weave(ps, SPEEDS, fb)
