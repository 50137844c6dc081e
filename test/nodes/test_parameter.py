"""The parameter node as a real process over DDS.

Static readings latched on start, period estimates in, the complete (or incomplete) parameter
set out, equal to the offline core.

The test's own end of the graph is a :class:`Probe`: an rclpy context of its own in the test
process, on the run's domain with LOCALHOST discovery. It is also used by test_model.py.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor

from bike_rig import topics
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements, load_static_readings
from bike_rig.messages import fill_period_estimate, session_parameters_from_msg, static_readings_from_msg
from bike_rig.paths import config_file
from bike_rig.pipeline.assemble import SessionParameters, assemble
from bike_rig.pipeline.fit import TrialFit
from bike_rig.rosqos import profile
from test.ros.processes import RosProcess

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
BROWSER = config_file("bicycles/browser.yaml")
STEP_TIMEOUT_S = 30.0
#: A service request not answered within this long is sent again (see Probe.call), s.
RESEND_S = 2.0
BROWSER_KEYS = (
    "TtP1", "TcR1", "TtR1", "TcF1", "TtF1", "TcB1", "TtB1", "TtB2", "TtB3", "TcH1", "TtH1", "TtH2", "TtH3",
)  # fmt: skip
_ENV_KEYS = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION")


class Probe:
    """The test's DDS participant: its own rclpy context on the run's domain (LOCALHOST).

    Publishes and listens on bike_rig topics with their contract QoS and calls services; every
    wait has a deadline.
    """

    def __init__(self, env: Mapping[str, str]) -> None:
        self._saved = {k: os.environ.get(k) for k in _ENV_KEYS}
        os.environ.update({k: env[k] for k in _ENV_KEYS})  # read by rcl when the context starts
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=int(env["ROS_DOMAIN_ID"]))
        self.node = rclpy.create_node(f"test_probe_{os.getpid()}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.inbox: dict[str, list[Any]] = {}
        self._publishers: dict[str, Any] = {}
        self._clients: dict[str, Any] = {}

    def listen(self, topic: topics.Topic, msg_type: Any) -> list[Any]:
        """Subscribe with the topic's QoS; the returned list fills as messages arrive."""
        box = self.inbox.setdefault(topic.name, [])
        self.node.create_subscription(msg_type, topic.name, box.append, profile(topic))
        return box

    def publisher(self, topic: topics.Topic, msg_type: Any, matched: bool = False) -> Any:
        """The probe's publisher on ``topic`` (one per topic) with the topic's QoS.

        Args:
            topic: The rig topic to publish on (its name and QoS).
            msg_type: The message class of the topic.
            matched: Wait until a subscription has matched: a live delivery. (Data published
                before the match reaches a transient-local subscriber too, as a late joiner,
                but only with the writer's next heartbeat, up to 3 s later with Fast DDS.)
        """
        if topic.name not in self._publishers:
            self._publishers[topic.name] = self.node.create_publisher(msg_type, topic.name, profile(topic))
        pub = self._publishers[topic.name]
        if matched:
            self.wait_for(lambda: pub.get_subscription_count() > 0, f"a subscriber of {topic.name}")
        return pub

    def wait_for(self, condition: Callable[[], bool], what: str, timeout: float = STEP_TIMEOUT_S) -> None:
        """Spin until ``condition()``; fail after ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def wait_message(
        self, topic: topics.Topic, condition: Callable[[Any], bool], what: str, processes: Sequence[RosProcess] = ()
    ) -> Any:
        """The first message on ``topic`` (listened to before) for which ``condition`` holds."""
        box = self.inbox[topic.name]
        try:
            self.wait_for(lambda: any(condition(m) for m in box), what)
        except AssertionError as exc:
            raise AssertionError(f"{exc}\n" + "\n".join(p.describe() for p in processes)) from None
        return next(m for m in box if condition(m))

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = STEP_TIMEOUT_S) -> Any:
        """Call an (idempotent) service and return its response.

        ``service_is_ready()`` only means the request path is matched: the server's response
        writer may not have matched this client's reader yet, and DDS then drops the response
        (volatile). So a request not answered within ``RESEND_S`` is sent again, until
        ``timeout``.
        """
        client = self._clients.get(name)
        if client is None:
            client = self._clients[name] = self.node.create_client(srv_type, name)
        self.wait_for(lambda: client.service_is_ready(), f"service {name}", timeout)
        deadline = time.monotonic() + timeout
        while True:
            future = client.call_async(request)
            try:
                wait = min(RESEND_S, max(0.0, deadline - time.monotonic()))
                self.wait_for(future.done, f"a response from {name}", wait)
            except AssertionError:
                client.remove_pending_request(future)
                if time.monotonic() >= deadline:
                    raise AssertionError(f"timed out after {timeout} s waiting for a response from {name}") from None
                continue
            return future.result()

    def __enter__(self) -> Probe:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)
        for key, value in self._saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def node_environment(ros_env: Mapping[str, str]) -> dict[str, str]:
    """The nodes' environment: the run's ROS environment, this checkout first on the path."""
    env = dict(ros_env)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    return env



def start_node(module: str, name: str, env: Mapping[str, str], log_dir: Path, *ros_args: str) -> RosProcess:
    """``python -m bike_rig.nodes.<module> --ros-args ...`` as a child process."""
    argv = [sys.executable, "-m", f"bike_rig.nodes.{module}", "--ros-args", *ros_args]
    return RosProcess(name, argv, env, log_dir)


def browser_trials() -> list[TrialFit]:
    """One trial per key with the Browser file's own period and σ."""
    full = load_measurements(BROWSER)
    return [TrialFit.from_period(f"{k}_t1", k, full.value(k), full.readings[k].sigma, True, stamp_ns=i) for i, k in
            enumerate(BROWSER_KEYS)]  # fmt: skip


def publish_trials(probe: Probe, trials: Sequence[TrialFit], matched: bool = False) -> None:
    """Publish period estimates (transient local: later subscribers get them too)."""
    from bike_rig_msgs.msg import PeriodEstimate

    pub = probe.publisher(topics.PERIODS, PeriodEstimate, matched)
    for t in trials:
        pub.publish(fill_period_estimate(PeriodEstimate(), t))


def assert_equal_sets(msg: Any, expected: SessionParameters) -> None:
    got = session_parameters_from_msg(msg)
    assert (got.bicycle, got.com_method, got.periods, got.missing) == (
        expected.bicycle, expected.com_method, expected.periods, expected.missing,
    )  # fmt: skip
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


def test_incomplete_session_reports_what_is_missing(
    probe: Probe, node_env: dict[str, str], tmp_path: Path
) -> None:
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
    argv = [sys.executable, "-m", "bike_rig.nodes.parameter", "--ros-args", "-p", f"measurements:={bad}"]
    done = subprocess.run(argv, env=node_env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "bad.yaml:" in lines[0] and "frame.mass" in lines[0] and "must be positive" in lines[0]
    assert "Traceback" not in done.stderr
