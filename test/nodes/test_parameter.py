"""The parameter node as a real process over DDS.

Static readings latched on start, period estimates in, the complete (or incomplete) parameter
set out, equal to the offline core.

The test's own end of the graph is a :class:`Probe`: an rclpy context of its own in the test
process, on the run's domain with LOCALHOST discovery. It is also used by test_model.py.
"""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.config import topics
from bike_rig.core.benchmark import ComMethod, compute_parameters
from bike_rig.core.loader import load_measurements, load_static_readings
from bike_rig.messages import session_parameters_from_msg, static_readings_from_msg
from bike_rig.pipeline.assemble import SessionParameters, assemble
from bike_rig.pipeline.fit import TrialFit
from test.support.nodes import BROWSER, BROWSER_KEYS, REPO, browser_trials, publish_trials, start_node
from test.support.probe import Probe

pytestmark = pytest.mark.ros


def assert_equal_sets(msg: Any, expected: SessionParameters) -> None:
    got = session_parameters_from_msg(msg)
    assert (got.bicycle, got.com_method, got.periods, got.missing) == (
        expected.bicycle,
        expected.com_method,
        expected.periods,
        expected.missing,
    )
    assert expected.parameters is not None and got.parameters is not None
    assert got.parameters.parameters.names == expected.parameters.parameters.names
    assert np.array_equal(got.parameters.parameters.values, expected.parameters.parameters.values)
    assert np.array_equal(got.parameters.parameters.covariance, expected.parameters.parameters.covariance)


def test_late_parameter_node_assembles_the_browser_set(probe: Probe, node_env: dict[str, str], tmp_path: Path) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters, StaticReadings

    full = load_measurements(BROWSER)
    clean = browser_trials()
    noise = [
        TrialFit.from_period("TtB1_t2", "TtB1", 2.6, 1e-5, True, ("beating",), ("envelope modulation",)),  # flagged
        TrialFit.from_period("TcH1_t2", "TcH1", float("nan"), float("nan"), False, ("no_oscillation",), ("flat",)),
        TrialFit.from_period("TtR1_t1", "TtR1", 0.9, 1e-6, True),  # replaced by the clean TtR1_t1 below
    ]
    # the estimates are out before the node starts: it must get them all (transient local)
    publish_trials(probe, [*noise, *clean])
    static_box = probe.listen(topics.STATIC_READINGS, StaticReadings)
    probe.listen(topics.PARAMETERS, BenchmarkParameters)
    with start_node("parameter", "parameter", node_env, tmp_path, "-p", f"measurements:={BROWSER}") as node:
        static_msg = probe.wait_message(topics.STATIC_READINGS, lambda m: True, "static readings", [node])
        first = probe.wait_message(topics.PARAMETERS, lambda m: m.complete, "a complete parameter set", [node])

        # static readings: exactly the file's, latched, with the document
        static = load_static_readings(BROWSER)
        back = static_readings_from_msg(static_msg)
        assert [(k, r.value, r.sigma) for k, r in back.readings.items()] == [
            (k, r.value, r.sigma) for k, r in static.readings.items()
        ]
        assert static_msg.document == BROWSER.read_text() and static_msg.bicycle == "Browser"
        assert len(static_box) == 1

        # the complete set equals the offline core bit for bit
        reference = compute_parameters(full)
        assert list(first.names) == list(reference.parameters.names)
        assert np.array_equal(np.asarray(first.values), reference.parameters.values)
        assert np.array_equal(np.asarray(first.covariance).reshape(26, 26), reference.parameters.covariance)
        assert np.array_equal(np.asarray(first.sigmas), reference.parameters.sigmas)
        assert list(first.period_keys) == list(BROWSER_KEYS) and list(first.missing) == []
        assert list(first.period_values) == [full.value(k) for k in BROWSER_KEYS]
        assert list(first.trial_ids) == [f"{k}:{k}_t1" for k in BROWSER_KEYS]
        assert first.com_method == "centroid"

        # a better trial arrives: a new set with the combined period, as offline
        better = TrialFit.from_period("TcR1_t2", "TcR1", full.value("TcR1") + 2e-6, 2e-6, True)
        publish_trials(probe, [better], matched=True)
        second = probe.wait_message(
            topics.PARAMETERS, lambda m: m.complete and "TcR1:TcR1_t2" in m.trial_ids, "the improved set", [node]
        )
        assert_equal_sets(second, assemble(static, [*noise, *clean, better]))
        code = node.stop()
    assert code == 0, node.describe()


def test_incomplete_session_reports_what_is_missing(probe: Probe, node_env: dict[str, str], tmp_path: Path) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters

    probe.listen(topics.PARAMETERS, BenchmarkParameters)
    params_file = REPO / "config" / "parameter.yaml"
    args = ("--params-file", str(params_file), "-p", "com_method:=lstsq")
    with start_node("parameter", "parameter_incomplete", node_env, tmp_path, *args) as node:
        start = probe.wait_message(topics.PARAMETERS, lambda m: True, "the first status", [node])
        assert not start.complete and tuple(start.missing) == BROWSER_KEYS and len(start.values) == 0
        assert start.com_method == "lstsq" and start.bicycle == "Browser"

        have = [t for t in browser_trials() if t.measurement_key not in ("TtB3", "TcH1")]
        flagged = TrialFit.from_period("TtB3_t1", "TtB3", 1.84, 1e-5, True, ("drift",), ("offset drift",))
        publish_trials(probe, [*have, flagged], matched=True)
        status = probe.wait_message(
            topics.PARAMETERS, lambda m: len(m.missing) == 2, "the status with two keys missing", [node]
        )
        assert list(status.missing) == ["TtB3", "TcH1"] and not status.complete
        assert list(status.period_keys) == [k for k in BROWSER_KEYS if k not in ("TtB3", "TcH1")]
        assert len(status.names) == len(status.values) == len(status.covariance) == 0
        code = node.stop()
    assert code == 0, node.describe()


def test_bad_measurement_file_is_one_error_line_and_status_2(node_env: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(BROWSER.read_text().replace("mass: [9.86, 0.02]", "mass: [-9.86, 0.02]"))
    argv = [sys.executable, "-m", "bike_rig.ros.nodes.parameter", "--ros-args", "-p", f"measurements:={bad}"]
    done = subprocess.run(argv, env=node_env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "bad.yaml:" in lines[0] and "frame.mass" in lines[0] and "must be positive" in lines[0]
    assert "Traceback" not in done.stderr


def test_fit_details_keep_the_small_swing_systematic_whole(
    probe: Probe, node_env: dict[str, str], tmp_path: Path
) -> None:
    """The node joins each estimate's fit details: a small-swing systematic the trials share is not averaged down."""
    from bike_rig.messages import fill_fit_details
    from bike_rig.pipeline.fit_details import FitDetails
    from bike_rig_msgs.msg import BenchmarkParameters
    from bike_rig_msgs.msg import FitDetails as FitDetailsMsg

    static = load_static_readings(BROWSER)
    period = load_measurements(BROWSER).value("TcR1")
    s_random, s_shared = 2e-5, 1e-4
    tcr1 = [
        TrialFit.from_period(f"TcR1_t{i}", "TcR1", period + d, math.hypot(s_random, s_shared), True, stamp_ns=100 + i)
        for i, d in enumerate((-1e-5, 0.0, 1e-5))
    ]
    details = [  # the small-swing period chosen (the option), its systematic shared by the key's trials
        replace(FitDetails.of(t), small_swing_period=t.period, small_swing_systematic=s_shared) for t in tcr1
    ]
    others = [t for t in browser_trials() if t.measurement_key != "TcR1"]
    joined = assemble(static, [*others, *(d.apply(t) for d, t in zip(details, tcr1))], ComMethod.CENTROID)
    plain = assemble(static, [*others, *tcr1], ComMethod.CENTROID)

    def tcr1_sigma(session: SessionParameters) -> float:
        return next(p.sigma for p in session.periods if p.key == "TcR1")

    expected = tcr1_sigma(joined)
    assert expected > 1.5 * tcr1_sigma(plain)  # the systematic whole, not over √3 (the test can fail)
    publish_trials(probe, [*others, *tcr1])
    pub = probe.publisher(topics.FIT_DETAILS, FitDetailsMsg)
    for d in details:
        pub.publish(fill_fit_details(FitDetailsMsg(), d))
    probe.listen(topics.PARAMETERS, BenchmarkParameters)
    with start_node("parameter", "parameter", node_env, tmp_path, "-p", f"measurements:={BROWSER}") as node:
        msg = probe.wait_message(
            topics.PARAMETERS,
            lambda m: m.complete and math.isclose(tcr1_sigma(session_parameters_from_msg(m)), expected, rel_tol=1e-9),
            "a complete set with TcR1's systematic whole",
            [node],
        )
    got = session_parameters_from_msg(msg)
    assert got.parameters is not None and joined.parameters is not None
    assert np.allclose(got.parameters.parameters.covariance, joined.parameters.parameters.covariance, rtol=1e-9)
