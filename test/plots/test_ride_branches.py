"""The ride validation figure marks where the model curve kinks or changes to another mode.

The balance-assist feedback's gains change slope at 5 m/s (roll-rate gain fades out, roll gain
comes in), so the closed loop's weave pair has a kink there: the figure marks it. Where the
curve leaves its eigenvalue for another (a real pair turning complex), a second marker says so.
"""

from __future__ import annotations

import numpy as np

from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.offline.subjects import load_parameters
from bike_rig.pipeline.ride import RideComparison, predicted_weave
from bike_rig.plots.ride import branch_changes, ride_validation

SPEEDS = np.linspace(0.5, 10.0, 39)
NO_RIDE = RideComparison((), (), float("nan"), ())


def _gids(fig) -> list[str]:  # type: ignore[no-untyped-def]
    return [str(line.get_gid()) for ax in fig.axes for line in ax.get_lines()]


def _legend(fig) -> list[str]:  # type: ignore[no-untyped-def]
    legend = fig.axes[0].get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend is not None else []


def test_the_feedback_kink_is_marked_with_a_legend_line() -> None:
    fb = resolve_feedback("balance_assist")
    assert fb is not None
    ps = add_rider(load_parameters("browser"), PAPER_RIDER)
    curve = predicted_weave(ps, SPEEDS, fb)
    fig = ride_validation(NO_RIDE, curve, "", fb)
    marks = [g for g in _gids(fig) if g.startswith("gains-")]
    assert sorted(marks) == ["gains-im:0", "gains-re:0"]  # 5 m/s; 0 and 15 m/s are outside 0.5–10
    assert "feedback gains change slope (model kinks)" in _legend(fig)
    line = next(ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid() == "gains-re:0")
    assert float(np.asarray(line.get_xdata())[0]) == 5.0
    # the steepest step of the drawn curve is next to the marked speed
    steps = np.hypot(np.diff(curve.real), np.diff(curve.imag))
    k = int(np.nanargmax(steps))
    assert SPEEDS[k] <= 5.0 <= SPEEDS[k + 1]


def test_a_real_pair_turning_complex_is_marked_as_a_change_of_mode() -> None:
    curve = predicted_weave(load_parameters("browser"), SPEEDS)
    changes = branch_changes(curve)
    assert len(changes) == 1
    k = int(np.searchsorted(SPEEDS, changes[0]))
    assert abs(curve.real[k] - curve.real[k - 1]) > 1.0  # Re λ jumps there: a different eigenvalue
    fig = ride_validation(NO_RIDE, curve)
    assert "model switches to another mode" in _legend(fig)
    assert not [g for g in _gids(fig) if g.startswith("gains-")]


def test_a_curve_on_one_mode_has_no_marker() -> None:
    assert branch_changes(predicted_weave(load_parameters("browser"), np.linspace(6.0, 10.0, 9))) == []
