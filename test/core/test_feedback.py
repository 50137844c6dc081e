"""Steer-torque state feedback: the feedback file, and the closed loop against ``eig(A − B K)``.

The closed-loop eigenvalues (closed-form quartic of ``det P_cl``), critical speeds and stable
speed ranges are checked against ``numpy.linalg.eigvals`` of ``A − B K`` built here
independently from ``state_space`` and the gains, for every bicycle under
``../shared/data/bicycleparameters``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from bike_rig.core.feedback import (
    Feedback,
    FeedbackError,
    GainSchedule,
    feedback_key,
    load_feedback,
    resolve_feedback,
)
from bike_rig.core.io_bp import read_bp_parameters
from bike_rig.core.whipple import (
    WhippleMatrices,
    canonical_matrices,
    critical_speeds,
    eigenvalues,
    stable_speed_range,
    state_space,
)
from bike_rig.core.whipple.closed_loop import (
    closed_loop_critical_speeds,
    closed_loop_stable_range,
    closed_loop_state_space,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "config" / "feedback" / "balance_assist.yaml"
SPEEDS = np.linspace(0.0, 12.0, 601)

#: A constant controller and a scheduled one (tables of different breakpoints, one single-point).
CONSTANT = Feedback("constant", *(GainSchedule.constant(k) for k in (-3.0, 1.5, -20.0, 0.8)))
SCHEDULED = Feedback(
    "scheduled",
    k_phi=GainSchedule((3.0, 7.0, 9.5), (0.0, -6.0, 2.0)),
    k_delta=GainSchedule((4.0,), (0.7,)),
    k_phidot=GainSchedule((0.0, 5.0), (-40.0, 0.0)),
    k_deltadot=GainSchedule((1.0, 2.0, 8.0), (0.5, -0.2, 0.3)),
)


def _bicycles(shared: Path) -> list[tuple[str, WhippleMatrices, float]]:
    """``(name, matrices, g)`` of every parameter file under ``data/bicycleparameters``."""
    out = []
    for path in sorted((shared / "data" / "bicycleparameters").glob("*/Parameters/*Benchmark.txt")):
        values = read_bp_parameters(path).parameters.as_dict()
        out.append((path.parent.parent.name, canonical_matrices(values), values["g"]))
    assert len(out) >= 8, "the shared data holds the paper's bicycles"
    return out


def _reference_eigenvalues(
    m: WhippleMatrices, g: float, v: NDArray[np.float64], gains: NDArray[np.float64]
) -> NDArray[np.complex128]:
    """``numpy.linalg.eigvals(A − B K)`` with ``K = [[0, 0, 0, 0], gains]`` (built here)."""
    a, b = state_space(m, v, g)
    k = np.zeros(v.shape + (2, 4))
    k[..., 1, :] = gains
    return np.asarray(np.linalg.eigvals(a - b @ k))


def _max_mismatch(ours: NDArray[np.complex128], ref: NDArray[np.complex128]) -> float:
    """Largest distance from one of our eigenvalues to the nearest reference one, relative."""
    d = np.abs(ours[:, :, None] - ref[:, None, :]).min(axis=2)
    scale = np.maximum(1.0, np.abs(ref).max(axis=1))
    return float((d / scale[:, None]).max())


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "fb.yaml"
    path.write_text("format: bike_rig-feedback/1\n" + text)
    return path


# --------------------------------------------------------------------------------------------
# The file
# --------------------------------------------------------------------------------------------


def test_example_file_and_interpolation() -> None:
    """The shipped balance assist reads as two tables; gains interpolate and hold outside."""
    fb = load_feedback(EXAMPLE)
    assert fb.name == "balance assist" and fb.source == str(EXAMPLE)
    assert fb.k_delta.is_zero and fb.k_deltadot.is_zero
    assert fb.breakpoints == (0.0, 5.0, 15.0)
    k = fb.gains([-1.0, 0.0, 2.5, 5.0, 10.0, 15.0, 40.0])
    np.testing.assert_array_equal(k[:, 2], [-50.0, -50.0, -25.0, 0.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(k[:, 0], [0.0, 0.0, 0.0, 0.0, -2.5, -5.0, -5.0])
    assert fb.gains_at(3.0).shape == (1, 4)
    assert fb.gains_at(SPEEDS).shape == SPEEDS.shape + (1, 4)


def test_missing_keys_are_zero_and_names(tmp_path: Path) -> None:
    """Missing gains are zero; none / "" mean no feedback; a file's record name is its path."""
    fb = load_feedback(_write(tmp_path, "k_delta: 2\n"))
    np.testing.assert_array_equal(fb.gains([0.0, 9.0]), [[0.0, 2.0, 0.0, 0.0]] * 2)
    assert fb.name == "fb"
    for spec in (None, "", "none"):
        assert resolve_feedback(spec) is None and feedback_key(spec) == ""
    assert resolve_feedback(str(EXAMPLE)) == load_feedback(EXAMPLE)
    assert feedback_key(EXAMPLE) == str(EXAMPLE)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("k_roll: 1\n", r":2: key 'k_roll': unknown key"),
        (
            "k_phi: {speeds: [0, 2, 2], values: [1, 2, 3]}\n",
            r":2: key 'k_phi.speeds\[2\]': speeds must increase strictly \(2 then 2 m/s\)",
        ),
        ("k_phi:\n  speeds: [0, 1]\n  values: [1, 2, 3]\n", r":4: key 'k_phi.values': 3 values for 2 speeds"),
        (
            "k_phidot:\n  speeds: [0, 1]\n  values: [1, .nan]\n",
            r":4: key 'k_phidot.values\[1\]': needs a finite number",
        ),
        ("k_delta: .inf\n", r":2: key 'k_delta': a gain is a finite number"),
        ("k_delta: true\n", r":2: key 'k_delta': a gain is a finite number"),
        ("k_delta: [1, 0.1, 2]\n", r":2: key 'k_delta': a gain is a finite number, \[value, sigma\]"),
        ("k_delta: [1, -0.1]\n", r":2: key 'k_delta': a σ must be >= 0 \(-0.1 given\)"),
        ("k_delta: {speeds: [1]}\n", r":2: key 'k_delta': a gain table has the keys speeds"),
        ("k_delta: {speeds: [1, 2], values: [1, 2], sigmas: [0.1]}\n", r":2: key 'k_delta.sigmas': 1 sigmas for 2"),
        ("k_delta: {speeds: [1, 2], values: [1, 2], sigmas: [0.1, -1]}\n", r":2: key 'k_delta.sigmas\[1\]': a σ"),
        ("k_delta: {speeds: [], values: []}\n", r":2: key 'k_delta.speeds': expected a non-empty list"),
        ("k_phi: 1\nrate_hz: 0\n", r":3: key 'rate_hz': the controller's rate is a finite number > 0 Hz \(0 given\)"),
        ("rate_hz: -100\n", r":2: key 'rate_hz': the controller's rate is a finite number > 0 Hz \(-100 given\)"),
        ("rate_hz: .inf\n", r":2: key 'rate_hz': the controller's rate is a finite number > 0 Hz \(inf given\)"),
        ("rate_hz: .nan\n", r":2: key 'rate_hz': the controller's rate is a finite number > 0 Hz"),
        ("rate_hz: true\n", r":2: key 'rate_hz': the controller's rate is a finite number > 0 Hz \(True given\)"),
        ("rate_hz: 100 Hz\n", r":2: key 'rate_hz': .*\('100 Hz' given\); leave it out for a continuous controller"),
        ("rate_hz: [100]\n", r":2: key 'rate_hz': the controller's rate is a finite number > 0 Hz"),
        ("rate: 100\n", r":2: key 'rate': unknown key \(a feedback file has .*rate_hz\)"),
    ],
)
def test_bad_files_name_file_key_and_line(tmp_path: Path, text: str, message: str) -> None:
    """Each mistake is one error naming the file, the line and the key."""
    path = _write(tmp_path, text)
    with pytest.raises(FeedbackError, match="^" + str(path).replace(".", r"\.") + message):
        load_feedback(path)


def test_controller_rate_is_optional(tmp_path: Path) -> None:
    """``rate_hz`` gives a digital controller's period; without it the controller is continuous."""
    assert load_feedback(EXAMPLE).rate_hz is None and load_feedback(EXAMPLE).period is None
    fb = load_feedback(_write(tmp_path, "k_phidot: -20\nrate_hz: 250\n"))
    assert fb.rate_hz == 250.0 and fb.period == pytest.approx(0.004)
    np.testing.assert_array_equal(fb.gains(3.0), [0.0, 0.0, -20.0, 0.0])  # the gains are unchanged


def test_gains_with_sigma(tmp_path: Path) -> None:
    """``[value, sigma]`` and a table's ``sigmas`` make uncertain inputs; their Jacobian is the interpolation's."""
    fb = load_feedback(
        _write(
            tmp_path, "k_phi: [2.0, 0.5]\nk_delta: 1.0\nk_phidot: {speeds: [0, 4], values: [-20, 0], sigmas: [2, 0]}\n"
        )
    )
    assert fb.uncertain_knots() == ((0, 0, 0.5, "k_phi"), (2, 0, 2.0, "k_phidot.values[0]"))
    assert fb.k_phi.describe() == "2 ± 0.5" and fb.k_delta.describe() == "1"
    assert fb.k_phidot.describe() == "-20 ± 2 at 0 m/s, 0 at 4 m/s (linear between, held outside)"
    v = np.array([-1.0, 1.0, 3.0, 6.0])
    jac = fb.knot_jacobian(v)
    assert jac.shape == (4, 2, 4)
    h = 1e-6
    for n, (i, j, _, _) in enumerate(fb.uncertain_knots()):
        s = fb.schedules[i]
        up = list(s.values)
        up[j] += h
        moved = GainSchedule(s.speeds, tuple(up))
        np.testing.assert_allclose(jac[:, n, i], (moved.at(v) - s.at(v)) / h, rtol=1e-6, atol=1e-9)
        assert np.count_nonzero(jac[:, n, :] != 0, axis=1).max() == 1  # one gain per value
    assert Feedback("exact", GainSchedule.constant(3.0)).uncertain_knots() == ()


def test_bad_format_and_missing_file(tmp_path: Path) -> None:
    """The format line is required; a missing file is a FeedbackError too."""
    path = tmp_path / "x.yaml"
    path.write_text("format: bike_rig-rider/1\nk_phi: 1\n")
    with pytest.raises(FeedbackError, match=r"x\.yaml:1: key 'format': expected format: bike_rig-feedback/1"):
        load_feedback(path)
    with pytest.raises(FeedbackError, match="cannot read"):
        resolve_feedback(tmp_path / "absent.yaml")


# --------------------------------------------------------------------------------------------
# The closed loop against eig(A − B K)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fb", [CONSTANT, SCHEDULED], ids=lambda f: f.name)
def test_closed_loop_eigenvalues_match_eig(shared_dir: Path, fb: Feedback) -> None:
    """Closed-form closed-loop eigenvalues equal ``eigvals(A − B K)`` at 601 speeds, every bicycle."""
    for name, m, g in _bicycles(shared_dir):
        gains = fb.gains(SPEEDS)
        sweep = eigenvalues(m, g, SPEEDS, gains=gains, vectors=True)
        assert _max_mismatch(sweep.eigenvalues, _reference_eigenvalues(m, g, SPEEDS, gains)) < 1e-9, name
        a_cl, _ = closed_loop_state_space(m, SPEEDS, g, gains)
        assert sweep.eigenvectors is not None
        residual = a_cl @ sweep.eigenvectors - sweep.eigenvectors * sweep.eigenvalues[:, None, :]
        assert np.abs(residual).max() < 1e-8, name
        # The speeds in any order give the same eigenvalues (the gains follow their speeds).
        shuffled = np.random.default_rng(1).permutation(SPEEDS.size)
        again = eigenvalues(m, g, SPEEDS[shuffled], gains=gains[shuffled])
        np.testing.assert_allclose(again.eigenvalues, sweep.eigenvalues[shuffled], rtol=0, atol=1e-9)


def test_closed_loop_state_space_is_a_minus_bk(shared_dir: Path) -> None:
    """``A − B K`` changes only the steer-acceleration row, by ``−M⁻¹[:, 1] K``."""
    _, m, g = _bicycles(shared_dir)[0]
    gains = SCHEDULED.gains(SPEEDS)
    a_cl, b = closed_loop_state_space(m, SPEEDS, g, gains)
    a, _ = state_space(m, SPEEDS, g)
    m_inv = np.linalg.inv(m.M)
    expected = a.copy()
    expected[:, 2:, :] -= m_inv[:, 1][None, :, None] * gains[:, None, :]
    np.testing.assert_allclose(a_cl, expected, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(b[..., 2:, :], m_inv, rtol=1e-14)


def test_zero_feedback_is_the_open_loop(shared_dir: Path) -> None:
    """With zero gains the closed-loop speeds and ranges are the open loop's (closed form)."""
    zero = Feedback("zero")
    for name, m, g in _bicycles(shared_dir):
        open_cs, closed_cs = critical_speeds(m, g), closed_loop_critical_speeds(m, g, zero)
        for a, b in ((open_cs.weave, closed_cs.weave), (open_cs.capsize, closed_cs.capsize)):
            assert (a is None) == (b is None), name
            if a is not None and b is not None:
                assert b == pytest.approx(a, rel=1e-12), name
        ranges = closed_loop_stable_range(m, g, zero)
        expected = stable_speed_range(m, g)
        assert len(ranges) == len(expected), name
        np.testing.assert_allclose(np.array(ranges), np.array(expected), rtol=1e-12)


def _max_real(m: WhippleMatrices, g: float, fb: Feedback, v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(_reference_eigenvalues(m, g, v, fb.gains(v)).real.max(axis=-1))


@pytest.mark.parametrize("fb", [CONSTANT, SCHEDULED, load_feedback(EXAMPLE)], ids=lambda f: f.name)
def test_closed_loop_stability_matches_eig(shared_dir: Path, fb: Feedback) -> None:
    """Stable ranges agree with ``max Re eig(A − B K)`` on a fine grid; each crossing is a sign change."""
    grid = np.linspace(1e-3, 30.0, 6001)
    for name, m, g in _bicycles(shared_dir):
        ranges = closed_loop_stable_range(m, g, fb, v_max=30.0)
        inside = np.zeros(grid.shape, dtype=bool)
        for lo, hi in ranges:
            inside |= (grid > lo) & (grid <= hi)
        edges = np.array([x for r in ranges for x in r if 0.0 < x < 30.0])
        far = np.ones(grid.shape, dtype=bool) if edges.size == 0 else np.abs(grid[:, None] - edges).min(axis=1) > 1e-3
        stable = _max_real(m, g, fb, grid) < 0.0
        assert np.array_equal(stable[far], inside[far]), name
        cs = closed_loop_critical_speeds(m, g, fb, v_max=30.0)
        for c in cs.crossings:
            lo, hi = _reference_eigenvalues(
                m, g, np.array([c.speed - 1e-6, c.speed + 1e-6]), fb.gains([c.speed - 1e-6, c.speed + 1e-6])
            )
            near = lambda z: z[np.argmin(np.abs(z.real))]  # noqa: E731  the root crossing the axis
            assert abs(near(lo).real) < 1e-4 and abs(near(hi).real) < 1e-4, name
            assert math.copysign(1.0, near(hi).real - near(lo).real) == math.copysign(1.0, c.rate), name
            if c.kind == "oscillatory":
                assert abs(near(lo).imag) == pytest.approx(c.frequency, rel=1e-4), name


def test_balance_assist_stabilises_low_speed(shared_dir: Path) -> None:
    """The shipped balance assist: at 2 m/s every bicycle's open loop is unstable, its closed loop stable.

    The file's roll-rate gain ``kφ̇ = −10 (5 − v)`` below 5 m/s is meant for the 2–4 m/s an
    assist covers; the check is by ``eig(A − B K)`` (and the same from our stable ranges).
    """
    fb = load_feedback(EXAMPLE)
    v = np.array([2.0])
    for name, m, g in _bicycles(shared_dir):
        assert _max_real(m, g, Feedback("open"), v)[0] > 0.0, name
        assert _max_real(m, g, fb, v)[0] < 0.0, name
        assert any(lo < 2.0 < hi for lo, hi in closed_loop_stable_range(m, g, fb)), name
        assert not any(lo < 2.0 < hi for lo, hi in stable_speed_range(m, g)), name


def _random_feedback(rng: np.random.Generator) -> Feedback:
    """Constant or tabled gains (1–4 random speeds in 0–15 m/s) of typical size per gain."""
    schedules = []
    for scale in (20.0, 5.0, 20.0, 2.0):
        if rng.random() < 0.4:
            schedules.append(GainSchedule.constant(float(rng.normal() * scale)))
        else:
            n = int(rng.integers(1, 5))
            speeds = np.sort(rng.uniform(0.0, 15.0, n))
            schedules.append(GainSchedule(tuple(speeds.tolist()), tuple((rng.normal(size=n) * scale).tolist())))
    return Feedback("random", *schedules)


def test_random_schedules_match_eig(shared_dir: Path) -> None:
    """60 random schedules: stable ranges equal ``max Re eig(A − B K) < 0`` on a grid; crossings are sign changes."""
    rng = np.random.default_rng(20261126)
    bikes = _bicycles(shared_dir)
    grid = np.linspace(1e-3, 20.0, 2001)
    for trial in range(60):
        name, m, g = bikes[trial % len(bikes)]
        fb = _random_feedback(rng)
        ranges = closed_loop_stable_range(m, g, fb, v_max=20.0)
        inside = np.zeros(grid.shape, dtype=bool)
        for lo, hi in ranges:
            inside |= (grid > lo) & (grid <= hi)
        edges = np.array([x for r in ranges for x in r if 0.0 < x < 20.0])
        far = np.ones(grid.shape, dtype=bool) if edges.size == 0 else np.abs(grid[:, None] - edges).min(axis=1) > 1e-3
        stable = _max_real(m, g, fb, grid) < 0.0
        assert np.array_equal(stable[far], inside[far]), (trial, name, fb)
        for c in closed_loop_critical_speeds(m, g, fb, v_max=20.0).crossings:
            around = np.array([c.speed - 1e-6, c.speed + 1e-6])
            z = _reference_eigenvalues(m, g, around, fb.gains(around))
            nearest = z[np.arange(2), np.argmin(np.abs(z.real), axis=1)]
            assert np.sign(nearest[1].real - nearest[0].real) == np.sign(c.rate), (trial, name, c)
