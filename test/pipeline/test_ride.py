"""The predicted weave eigenvalue with σ (pipeline/ride.py) on every reference bicycle, and the comparison."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bike_rig.config.paths import config_dir
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.loader import load_input
from bike_rig.core.ride.eigen import MeasuredEigenvalue
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.core.whipple.closed_loop import closed_loop_state_space
from bike_rig.pipeline.ride import compare_ride, normalised_deviation, predicted_weave

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "bicycleparameters"
REFERENCE = sorted(p for p in SHARED.glob("*/Parameters/*Benchmark.txt") if p.parent.parent.name != "riders")
SPEEDS = np.array([2.0, 3.5, 5.0, 6.5, 8.0])


@pytest.mark.skipif(not REFERENCE, reason="../shared reference data not present")
@pytest.mark.parametrize("path", REFERENCE, ids=lambda p: p.parent.parent.name)
@pytest.mark.parametrize("closed", [False, True], ids=["open", "assist"])
def test_prediction_is_an_eigenvalue_of_the_state_space(path: Path, closed: bool) -> None:
    ps = load_input(path)
    fb = resolve_feedback(str(config_dir() / "feedback" / "balance_assist.yaml")) if closed else None
    ms = canonical_with_sigma(ps)
    pred = predicted_weave(ps, SPEEDS, fb)
    has_sigma = any(ps.parameters.sigma(k) > 0 for k in ps.parameters.names)
    for i, v in enumerate(SPEEDS):
        a, _ = (
            state_space(ms.matrices, v, ms.g)
            if fb is None
            else closed_loop_state_space(ms.matrices, v, ms.g, fb.gains(v))
        )
        lam = np.linalg.eigvals(np.asarray(a, dtype=float))
        complex_ = lam[lam.imag > 1e-9]
        if not complex_.size:
            assert math.isnan(pred.real[i])
            continue
        got = complex(pred.real[i], pred.imag[i])
        assert np.min(np.abs(complex_ - got)) < 1e-8 * max(1.0, abs(got))
        assert pred.imag[i] > 0
        if math.isfinite(pred.real_sigma[i]):  # (NaN near a branch point)
            if has_sigma:
                assert pred.real_sigma[i] > 0 and pred.imag_sigma[i] > 0
            else:  # the Meijaard benchmark's parameters are exact
                assert pred.real_sigma[i] == 0 and pred.imag_sigma[i] == 0


def test_comparison_normalises_by_both_sigmas() -> None:
    ps = load_input(config_dir() / "bicycles" / "benchmark.yaml")
    if not hasattr(ps, "parameters"):
        from bike_rig.core.benchmark import compute_parameters

        ps = compute_parameters(ps)
    pred = predicted_weave(ps, [5.0])
    fit = None
    seg = MeasuredEigenvalue(
        "x", 1, 0.0, 2.0, 5.0, float(pred.real[0]) + 0.1, 0.05, float(pred.imag[0]) - 0.2, 0.1, True, (), 2.0, fit
    )  # type: ignore[arg-type]
    cmp = compare_ride(ps, [seg, seg])
    row = cmp.segments[0]
    assert row.z_real == pytest.approx(0.1 / math.hypot(0.05, float(pred.real_sigma[0])))
    assert row.z_imag == pytest.approx(-0.2 / math.hypot(0.1, float(pred.imag_sigma[0])))
    assert cmp.overall == pytest.approx(math.sqrt((row.z_real**2 + row.z_imag**2) / 2))
    assert len(cmp.speeds) == 1 and cmp.speeds[0].combined.n_used == 2
    assert normalised_deviation(1.0, 0.0, 0.0, 0.0) != normalised_deviation(1.0, 0.0, 0.0, 0.0)  # NaN without σ
