"""The driver node as a real process on the run's own domain.

A simulated session, a CAN gyro (simulated inside the driver's process: python-can's virtual
bus does not cross processes)
driven through the StartTrial/StopTrial services, a recorded bag; and bad parameters, which end
the process with one line and status 2.

The test process watches the topics with an rclpy node of its own (:class:`Probe`, its own
context, the same domain, LOCALHOST discovery) and waits for messages, never for time.
"""

from __future__ import annotations

import math
import subprocess
import uuid
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.config.topics import GYRO, START_TRIAL, STOP_TRIAL, TRIAL_EVENTS
from bike_rig.messages import sample_batch_from_msg, trial_event_from_msg
from bike_rig.pipeline.fit import fit_trial
from bike_rig.pipeline.resend import batch_samples
from test.support.probe import ABORT, START, STEP_TIMEOUT_S, STOP, Probe, msgs, node_command, srvs
from test.support.processes import RosProcess
from test.support.recorded import RATE as BAG_RATE
from test.support.recorded import recorded_session
from test.support.small_sessions import small_session

pytestmark = pytest.mark.ros


START_S = 1_700_000_000.0


def stamp_ns(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def by_trial(batches: list[Any]) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for b in batches:
        out.setdefault(b.trial_id, []).append(b)
    return out


def wait_exit(proc: RosProcess, timeout: float = STEP_TIMEOUT_S) -> int:
    try:
        return proc.proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        raise AssertionError(f"{proc.name} did not exit within {timeout} s\n{proc.describe()}") from None


def test_sim_session_is_published_trial_by_trial_in_rig_time(
    probe: Probe, ros_env: dict[str, str], tmp_path: Path
) -> None:
    session, path = small_session(tmp_path)
    events = probe.subscribe(TRIAL_EVENTS, msgs.TrialEvent)
    batches = probe.subscribe(GYRO, msgs.GyroBatch)
    pause = 0.1
    cmd = node_command(
        "bike_rig.ros.nodes.driver",
        "source:=sim",
        f"session:={path}",
        "time_scale:=50.0",
        f"pause_between_trials_s:={pause}",
        f"start_time_s:={START_S}",
        "wait_for_subscribers:=1",
        "exit_when_done:=true",
        params_file=str(config_file("driver.yaml")),
    )
    n_trials = len(session.trials)
    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        probe.spin_until(
            lambda: sum(e.kind == STOP for e in events) == n_trials,
            STEP_TIMEOUT_S,
            "STOP of every trial",
            driver.describe,
        )
        total = sum(t.rate.size for t in session.trials)
        probe.spin_until(
            lambda: sum(len(b.rates) for b in batches) == total, STEP_TIMEOUT_S, "every sample", driver.describe
        )
        assert wait_exit(driver) == 0, driver.describe()  # exit_when_done, after the acks
    log = driver.stderr_path.read_text()
    assert f"plan finished: {n_trials} trials, {total} samples published; exiting" in log

    starts = [e for e in events if e.kind == START]
    stops = [e for e in events if e.kind == STOP]
    assert [e.trial_id for e in starts] == [e.trial_id for e in stops] == [t.name for t in session.trials]
    grouped = by_trial(batches)
    expected_start = round(START_S * 1e9)
    for start, stop, truth in zip(starts, stops, session.trials):
        n = truth.rate.size
        assert start.measurement_key == stop.measurement_key == truth.key
        assert start.sample_rate_hz == 1000.0 and start.sample_count == 0 and stop.sample_count == n
        assert stamp_ns(start) == expected_start
        assert stamp_ns(stop) == expected_start + round(n * 1e6)
        got = grouped[truth.name]
        size = batch_samples(50, 50.0)  # (samples_per_batch at real time, times the time scale)
        assert size == 2500 and [b.first_index for b in got] == list(range(0, n, size))
        assert all(len(b.rates) == min(size, n - b.first_index) and b.sample_rate_hz == 1000.0 for b in got)
        assert [stamp_ns(b) for b in got] == [expected_start + round(i * 1e6) for i in range(0, n, size)]
        assert np.array_equal(np.concatenate([np.asarray(b.rates) for b in got]), truth.rate)  # bit for bit
        assert np.array_equal(np.concatenate([np.asarray(b.raw_volts) for b in got]), truth.volts)
        expected_start = stamp_ns(stop) + round(pause * 1e9)


def test_can_gyro_trials_through_the_services(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    events = probe.subscribe(TRIAL_EVENTS, msgs.TrialEvent)
    batches = probe.subscribe(GYRO, msgs.GyroBatch)
    period = 0.8
    cmd = node_command(
        "bike_rig.ros.nodes.driver",
        "source:=can",
        "can_interface:=virtual",
        f"can_channel:=test-{uuid.uuid4().hex[:8]}",
        "can_id:=42",
        "sample_format:=int16",
        "byte_order:=big",
        "samples_per_frame:=4",
        "scale:=1.0e-5",
        "sample_rate_hz:=1000.0",
        f"can_simulated_gyro_period_s:={period}",
        "time_scale:=10.0",
    )
    start_client = probe.node.create_client(srvs.StartTrial, START_TRIAL)
    stop_client = probe.node.create_client(srvs.StopTrial, STOP_TRIAL)

    def start(duration_s: float, orientation: int = 1) -> Any:
        request = srvs.StartTrial.Request(
            part="fork", pendulum="torsional", orientation=orientation, duration_s=duration_s, note="test"
        )
        return probe.call(start_client, request)

    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        first = start(8.0)
        assert first.accepted and first.trial_id == "fork_torsional_o1_t1", first.message
        probe.spin_until(lambda: any(e.kind == STOP for e in events), STEP_TIMEOUT_S, "the STOP", driver.describe)
        second = start(0.0, orientation=2)  # until stopped
        assert second.accepted and second.trial_id == "fork_torsional_o2_t1"
        # (refused against the trial that runs until stopped: a timed one may end before the request)
        busy = start(1.0, orientation=1)
        assert not busy.accepted and "fork_torsional_o2_t1 is running" in busy.message
        probe.spin_until(lambda: any(b.trial_id == second.trial_id for b in batches), STEP_TIMEOUT_S, "samples")
        stopped = probe.call(stop_client, srvs.StopTrial.Request(trial_id=second.trial_id, abort=True))
        assert stopped.accepted and "aborted" in stopped.message
        probe.spin_until(lambda: any(e.kind == ABORT for e in events), STEP_TIMEOUT_S, "the ABORT")
        aborted = next(e for e in events if e.kind == ABORT).sample_count

        def received() -> int:
            return sum(len(b.rates) for b in batches if b.trial_id == second.trial_id)

        # the gyro topic is not ordered with the events': batches sent before the ABORT may come after it
        probe.spin_until(lambda: received() >= aborted, STEP_TIMEOUT_S, f"the aborted trial's {aborted} samples")
        again = probe.call(stop_client, srvs.StopTrial.Request(trial_id="", abort=False))
        assert not again.accepted and "no trial is running" in again.message
        assert driver.proc.poll() is None
    assert driver.proc.returncode == 0, driver.describe()

    start_ev = next(e for e in events if e.kind == START and e.trial_id == first.trial_id)
    stop_ev = next(e for e in events if e.kind == STOP)
    assert (start_ev.measurement_key, start_ev.note, stop_ev.sample_count) == ("TtH1", "test", 8000)
    mine = [b for b in batches if b.trial_id == first.trial_id]
    result = fit_trial(
        [sample_batch_from_msg(b) for b in mine], trial_event_from_msg(start_ev), trial_event_from_msg(stop_ev)
    )
    truth = period / math.sqrt(1 - 0.001**2)
    assert result.n_samples == 8000 and result.flags == ()
    assert abs(result.period - truth) < 3 * result.period_sigma, (result.period, truth, result.period_sigma)
    abort_ev = next(e for e in events if e.kind == ABORT)
    assert abort_ev.sample_count == sum(len(b.rates) for b in batches if b.trial_id == second.trial_id) > 0


def test_bag_replay_publishes_the_recorded_trials(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    bag, a, b = recorded_session(tmp_path)
    events = probe.subscribe(TRIAL_EVENTS, msgs.TrialEvent)
    batches = probe.subscribe(GYRO, msgs.GyroBatch)
    cmd = node_command(
        "bike_rig.ros.nodes.driver", "source:=bag", f"bag:={bag}", "time_scale:=100.0", "wait_for_subscribers:=1"
    )
    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        probe.spin_until(
            lambda: len(events) == 4 and sum(len(x.rates) for x in batches) == 180,
            STEP_TIMEOUT_S,
            "the recorded trials",
            driver.describe,
        )
        probe.spin_until(lambda: "plan finished" in driver.stderr_path.read_text(), STEP_TIMEOUT_S, "the end")
        assert driver.proc.poll() is None  # still serving the history
    assert driver.proc.returncode == 0, driver.describe()
    assert [(e.kind, e.trial_id, e.sample_count) for e in events] == [
        (0, "t1", 0),
        (1, "t1", 123),
        (0, "t2", 0),
        (2, "t2", 60),
    ]
    grouped = by_trial(batches)
    # (at 100 times real time a batch holds 100 × 50 samples: the trial's 120 in one)
    assert [(x.first_index, len(x.rates)) for x in grouped["t1"]] == [(0, 120)]
    assert np.array_equal(np.concatenate([np.asarray(x.rates) for x in grouped["t1"]]), a)
    assert np.array_equal(np.concatenate([np.asarray(x.rates) for x in grouped["t2"]]), b)
    assert np.array_equal(np.concatenate([np.asarray(x.raw_volts) for x in grouped["t2"]]), 2.5 + b / 3)
    assert all(x.sample_rate_hz == BAG_RATE for x in batches)


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        (["source:=nope"], "driver: error: parameter 'source' = 'nope': expected one of sim, can, bag, daq"),
        (
            ["source:=sim", "session:=/nowhere/session.yaml"],
            "driver: error: sim source: parameter 'session' = '/nowhere/session.yaml': no such file",
        ),
        (["source:=sim", "time_scale:=20"], "driver: error: parameter 'time_scale': expected a double (e.g. 20.0)"),
        (["source:=sim", "time_scale:=5000.0"], "driver: error: parameter 'time_scale': must be within [0.001, 1000]"),
        (
            ["source:=can", "samples_per_frame:=8"],
            "driver: error: can source: parameter 'samples_per_frame' = 8: 16 bytes of int16 exceed a classic "
            "frame's 8 (set can_fd)",
        ),
        (["source:=daq"], "driver: error: daq source: parameter 'source' = 'daq': the daq source needs the 'nidaqmx'"),
    ],
)
def test_bad_parameters_end_in_one_line(parameters: list[str], message: str, ros_env: dict[str, str]) -> None:
    cmd = node_command("bike_rig.ros.nodes.driver", *parameters, params_file=str(config_file("driver.yaml")))
    done = subprocess.run(["timeout", "-k", "5", "60", *cmd], env=ros_env, capture_output=True, text=True, timeout=90)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), done.stderr
    assert "Traceback" not in done.stderr
