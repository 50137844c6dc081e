"""The model node as a real process over DDS.

Matrices and eigen sweep from each complete parameter set, equal to the offline core; the
state-space service; a late-started model node still gets the parameter node's set (transient
local).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.config import topics
from bike_rig.core.benchmark import ComMethod, ParameterSet
from bike_rig.core.feedback import load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.core.whipple import eigenvalues, state_space
from bike_rig.messages import session_parameters_from_msg
from bike_rig.pipeline.model import compute_model
from test.support.nodes import (
    ASSIST,
    BROWSER,
    REPO,
    STAMP_NS,
    browser_trials,
    offline_set,
    publish_set,
    publish_trials,
    stamp_of,
    start_node,
    state_space_request,
)
from test.support.probe import Probe
from test.support.processes import RosProcess

pytestmark = pytest.mark.ros


def assert_model_equals_core(
    matrices: Any, sweep: Any, ps: ParameterSet, rider: str, convention: SigmaConvention, speeds: np.ndarray
) -> None:
    """The published model equals the core's chain on the same parameter set, bit for bit."""
    full = add_rider(ps, PAPER_RIDER) if rider == "paper" else ps
    ms = canonical_with_sigma(full, convention)
    assert (matrices.bicycle, matrices.rider, matrices.sigma_convention) == ("Browser", rider, convention.value)
    assert matrices.g == ms.g
    for field, name in (("m", "M"), ("c1", "C1"), ("k0", "K0"), ("k2", "K2")):
        assert np.array_equal(np.asarray(getattr(matrices, field)), getattr(ms.matrices, name).ravel())
        assert np.array_equal(np.asarray(getattr(matrices, f"{field}_sigma")), getattr(ms.sigma, name).ravel())
    eig = eigenvalues(ms.matrices, ms.g, speeds)
    assert np.array_equal(np.asarray(sweep.speeds), speeds)
    assert np.array_equal(np.asarray(sweep.eigenvalues_real), eig.eigenvalues.real.ravel())
    assert np.array_equal(np.asarray(sweep.eigenvalues_imag), eig.eigenvalues.imag.ravel())
    assert list(sweep.mode_labels) == ["weave", "weave", "capsize", "caster"]
    cs = critical_speeds_with_sigma(full, convention)
    assert cs.weave is not None and cs.capsize is not None
    assert (sweep.has_weave, sweep.weave_speed, sweep.weave_speed_sigma) == (True, cs.weave.speed, cs.weave.sigma)
    assert (sweep.has_capsize, sweep.capsize_speed, sweep.capsize_speed_sigma) == (
        True,
        cs.capsize.speed,
        cs.capsize.sigma,
    )


def test_model_from_published_sets_and_state_space(probe: Probe, node_env: dict[str, str], tmp_path: Path) -> None:
    from bike_rig_msgs.msg import CanonicalMatrices, EigenSweep
    from bike_rig_msgs.srv import StateSpace

    probe.listen(topics.MATRICES, CanonicalMatrices)
    probe.listen(topics.EIGEN_SWEEP, EigenSweep)
    args = ("--params-file", str(REPO / "config" / "model.yaml"))
    with start_node("model", "model", node_env, tmp_path, *args) as node:
        # before any parameter set: a clear refusal
        early = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(5.0, ""))
        assert not early.ok and "no parameter set yet" in early.message

        publish_set(probe, ComMethod.CENTROID, STAMP_NS)
        matrices = probe.wait_message(topics.MATRICES, lambda m: stamp_of(m) == STAMP_NS, "matrices", [node])
        sweep = probe.wait_message(topics.EIGEN_SWEEP, lambda m: stamp_of(m) == STAMP_NS, "eigen sweep", [node])
        ps = offline_set()
        speeds = np.linspace(0.0, 10.0, 201)
        assert_model_equals_core(matrices, sweep, ps, "", SigmaConvention.CORRELATED, speeds)

        # the state space at a speed, for the default rider and the paper's
        for rider, full in (("", ps), ("none", ps), ("paper", add_rider(ps, PAPER_RIDER))):
            got = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(5.0, rider))
            assert got.ok, got.message
            ms = canonical_with_sigma(full)
            a, b = state_space(ms.matrices, 5.0, ms.g)
            assert np.array_equal(np.asarray(got.a), a.ravel()) and np.array_equal(np.asarray(got.b), b.ravel())
            eig = eigenvalues(ms.matrices, ms.g, [5.0]).eigenvalues[0]
            assert np.array_equal(np.asarray(got.eigenvalues_real), eig.real)
            assert np.array_equal(np.asarray(got.eigenvalues_imag), eig.imag)
            assert list(got.mode_labels) == ["weave", "weave", "capsize", "caster"]
        for speed, rider, reason in (
            (-1.0, "", "speed must be"),
            (math.nan, "", "speed must be"),
            (3.0, "tall", "unknown rider 'tall'"),
        ):
            refused = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(speed, rider))
            assert not refused.ok and reason in refused.message

        # every new complete set gives a new model
        publish_set(probe, ComMethod.LEAST_SQUARES, STAMP_NS + 1)
        matrices2 = probe.wait_message(topics.MATRICES, lambda m: stamp_of(m) == STAMP_NS + 1, "new matrices", [node])
        sweep2 = probe.wait_message(topics.EIGEN_SWEEP, lambda m: stamp_of(m) == STAMP_NS + 1, "new sweep", [node])
        lstsq = offline_set(ComMethod.LEAST_SQUARES)
        assert_model_equals_core(matrices2, sweep2, lstsq, "", SigmaConvention.CORRELATED, speeds)
        code = node.stop()
    assert code == 0, node.describe()


def test_late_model_node_gets_the_parameter_nodes_set(probe: Probe, node_env: dict[str, str], tmp_path: Path) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters, CanonicalMatrices, EigenSweep

    probe.listen(topics.PARAMETERS, BenchmarkParameters)
    with start_node("parameter", "parameter", node_env, tmp_path, "-p", f"measurements:={BROWSER}") as parameter:
        publish_trials(probe, browser_trials(), matched=True)
        params = probe.wait_message(topics.PARAMETERS, lambda m: m.complete, "a complete set", [parameter])
        # the model node starts only now, after the set was published
        probe.listen(topics.MATRICES, CanonicalMatrices)
        probe.listen(topics.EIGEN_SWEEP, EigenSweep)
        model_args = (
            "-p",
            "rider:=paper",
            "-p",
            "sigma_convention:=paper",
            "-p",
            "speed_max:=5.0",
            "-p",
            "speed_count:=11",
        )
        with start_node("model", "model_late", node_env, tmp_path, *model_args) as model:
            nodes: list[RosProcess] = [parameter, model]
            matrices = probe.wait_message(topics.MATRICES, lambda m: True, "matrices from the late model", nodes)
            sweep = probe.wait_message(topics.EIGEN_SWEEP, lambda m: True, "eigen sweep from the late model", nodes)
            assert stamp_of(matrices) == stamp_of(sweep) == stamp_of(params)
            ps = session_parameters_from_msg(params).complete_parameters()
            assert np.array_equal(ps.parameters.values, offline_set().parameters.values)
            speeds = np.linspace(0.0, 5.0, 11)
            assert_model_equals_core(matrices, sweep, ps, "paper", SigmaConvention.PAPER, speeds)
            model_code = model.stop()
        parameter_code = parameter.stop()
    assert (model_code, parameter_code) == (0, 0), model.describe() + parameter.describe()


def test_bad_model_parameter_is_one_error_line_and_status_2(node_env: dict[str, str]) -> None:
    argv = [
        sys.executable,
        "-m",
        "bike_rig.ros.nodes.model",
        "--ros-args",
        "-p",
        "speed_min:=5.0",
        "-p",
        "speed_max:=1.0",
    ]
    done = subprocess.run(argv, env=node_env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["model: error: parameters 'speed_min' 5.0 > 'speed_max' 1.0"]


def test_model_node_with_feedback_publishes_the_closed_loop(
    probe: Probe, node_env: dict[str, str], tmp_path: Path
) -> None:
    """``feedback``: the sweep and speeds are the closed loop's (as compute_model), the service gives A − B K."""
    from bike_rig_msgs.msg import EigenSweep
    from bike_rig_msgs.srv import StateSpace

    probe.listen(topics.EIGEN_SWEEP, EigenSweep)
    args = ("-p", f"feedback:={ASSIST}", "-p", "speed_count:=21")
    with start_node("model", "model_feedback", node_env, tmp_path, *args) as node:
        publish_set(probe, ComMethod.CENTROID, STAMP_NS)
        sweep = probe.wait_message(topics.EIGEN_SWEEP, lambda m: stamp_of(m) == STAMP_NS, "eigen sweep", [node])
        speeds = np.linspace(0.0, 10.0, 21)
        _, expected = compute_model(offline_set(), speeds, feedback=str(ASSIST))
        assert np.array_equal(np.asarray(sweep.eigenvalues_real), expected.sweep.eigenvalues.real.ravel())
        assert expected.weave is not None and (sweep.weave_speed, sweep.has_weave) == (expected.weave.speed, True)
        got = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(2.0, ""))
        assert got.ok and "closed loop (balance assist)" in got.message
        ms = canonical_with_sigma(offline_set())
        a, b = state_space(ms.matrices, 2.0, ms.g)
        k = np.zeros((2, 4))
        k[1] = load_feedback(ASSIST).gains(2.0)
        a_cl = np.asarray(got.a).reshape(4, 4)
        np.testing.assert_allclose(a_cl, a - b @ k, rtol=1e-13, atol=1e-12)
        ours = np.asarray(got.eigenvalues_real) + 1j * np.asarray(got.eigenvalues_imag)
        ref = np.linalg.eigvals(a - b @ k)
        assert np.abs(ours[:, None] - ref[None, :]).min(axis=1).max() < 1e-9
        assert ref.real.max() < 0.0  # the assist makes 2 m/s stable
        code = node.stop()
    assert code == 0, node.describe()


def test_bad_feedback_parameter_is_one_error_line(node_env: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-feedback/1\nk_phi: .nan\n")
    argv = [sys.executable, "-m", "bike_rig.ros.nodes.model", "--ros-args", "-p", f"feedback:={bad}"]
    done = subprocess.run(argv, env=node_env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("model: error: parameter 'feedback'")
    assert f"{bad}:2: key 'k_phi': a gain is a finite number" in lines[0]
