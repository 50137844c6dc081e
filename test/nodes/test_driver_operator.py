"""The driver as a real process, trials requested by an operator through its services.

* ``source:=sim mode:=operator``: nothing streams until StartTrial; a request outside the plan
  is refused with the reason; an accepted one answers with the trial's id, and its START,
  samples and STOP follow (the period is the physics'); ABORT on request; ids never reused.
* ``source:=can`` on python-can's virtual bus with nothing sending: a requested trial gets the
  driver's silence warning after 1 s, and it stops and aborts at once with 0 samples.

The test process calls the services and watches the topics with its own rclpy node (the probe
of test_driver.py), and waits for messages or log lines, never for time.
"""

from __future__ import annotations

import time
import uuid
from pathlib import Path
from typing import Any

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.sim import TrialSimulator, load_rig, load_true_parameters
from bike_rig.messages import sample_batch_from_msg, trial_event_from_msg
from bike_rig.pipeline.fit import fit_trial
from test.support.operator import Operator
from test.support.probe import ABORT, START, STEP_TIMEOUT_S, STOP, Probe, node_command
from test.support.processes import RosProcess
from test.support.small_sessions import BICYCLE, small_rig

pytestmark = pytest.mark.ros

msgs: Any = pytest.importorskip("bike_rig_msgs.msg")
srvs: Any = pytest.importorskip("bike_rig_msgs.srv")

TRIAL_S = 6.0  # the small rig's trial duration, s of rig time
TIME_SCALE = 50.0  # a trial in 0.12 s


def test_sim_operator_mode_trials_on_request(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    rig = small_rig(tmp_path, duration_s=TRIAL_S)
    cmd = node_command(
        "bike_rig.ros.nodes.driver",
        "source:=sim",
        "mode:=operator",
        f"bicycle:={BICYCLE}",
        f"rig:={rig}",
        "seed:=3",
        f"time_scale:={TIME_SCALE}",
        params_file=str(config_file("driver.yaml")),
    )
    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        op = Operator(probe, driver)
        refused = op.start("frame", "torsional", 4)
        assert not refused.accepted and refused.trial_id == ""
        assert refused.message == (
            "orientation 4 is outside the plan: the frame hangs in orientations 1–3 (rig orientations_deg.frame)"
        )
        rod = op.start("calibration_rod", "compound")
        assert not rod.accepted and rod.message.startswith("the calibration rod is only hung as a torsional pendulum")

        first = op.start("fork", "torsional", 2, note="operator test")  # duration 0: the rig's
        assert first.accepted and first.trial_id == "fork_torsional_o2_t1", first.message
        start, stop = op.event(START, first.trial_id), op.event(STOP, first.trial_id)
        assert (start.measurement_key, start.orientation, start.repeat, start.note) == ("TtH2", 2, 1, "operator test")
        assert stop.sample_count == round(TRIAL_S * 1000)
        probe.spin_until(lambda: op.samples(first.trial_id) == stop.sample_count, STEP_TIMEOUT_S, "every sample")

        long = op.start("rear_wheel", "compound", duration_s=1000.0)  # 20 s of wall time: aborted first
        assert long.accepted and long.trial_id == "rear_wheel_compound_t1"
        busy = op.start("front_wheel", "compound")
        assert not busy.accepted and busy.message.startswith("trial rear_wheel_compound_t1 is recording; stop or abort")
        again = op.start("rear_wheel", "compound", duration_s=1000.0)  # resent (its answer lost): the same answer
        assert again.accepted and again.trial_id == long.trial_id, again.message
        assert again.message.endswith("(the same request again)")
        probe.spin_until(lambda: op.samples(long.trial_id) > 0, STEP_TIMEOUT_S, "samples of the long trial")
        aborted = op.stop(long.trial_id, abort=True)
        assert aborted.accepted and "aborted" in aborted.message
        abort_ev = op.event(ABORT, long.trial_id)
        assert 0 < abort_ev.sample_count < 1000 * 1000
        probe.spin_until(lambda: op.samples(long.trial_id) == abort_ev.sample_count, STEP_TIMEOUT_S, "its samples")
        assert not any(e.kind == STOP and e.trial_id == long.trial_id for e in op.events)
        assert sum(e.kind == START and e.trial_id == long.trial_id for e in op.events) == 1

        redo = op.start("fork", "torsional", 2, repeat=1)
        assert redo.accepted and redo.trial_id == "fork_torsional_o2_t1_r2"  # never the same id twice
        assert op.event(STOP, redo.trial_id).sample_count == round(TRIAL_S * 1000)
        anew = op.start("fork", "torsional", 2, repeat=1)  # the same request after its trial's STOP: a new trial
        assert anew.accepted and anew.trial_id == "fork_torsional_o2_t1_r3", anew.message
        assert op.stop(anew.trial_id, abort=True).accepted
        assert driver.proc.poll() is None
    assert driver.proc.returncode == 0, driver.describe()
    assert "no samples" not in driver.stderr_path.read_text()  # no silence warning while the sim streams

    mine = [sample_batch_from_msg(b) for b in op.batches if b.trial_id == first.trial_id]
    fit = fit_trial(mine, trial_event_from_msg(start), trial_event_from_msg(stop))
    name, truth = load_true_parameters(BICYCLE)
    expected = TrialSimulator.create(truth, load_rig(rig), 3, name).damped_period("TtH2")
    assert fit.n_samples == round(TRIAL_S * 1000) and fit.flags == ()
    assert abs(fit.period - expected) < 3 * fit.period_sigma, (fit.period, expected, fit.period_sigma)


def test_silent_can_bus_warns_after_a_second_and_aborts(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    cmd = node_command(
        "bike_rig.ros.nodes.driver",
        "source:=can",
        "can_interface:=virtual",
        f"can_channel:=silent-{uuid.uuid4().hex[:8]}",
        "can_id:=256",
    )
    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        op = Operator(probe, driver)
        asked, asked_ns = time.monotonic(), time.time_ns()
        started = op.start("fork", "torsional", 1)  # until stopped: nothing will ever arrive
        answered_ns = time.time_ns()
        assert started.accepted and started.trial_id == "fork_torsional_o1_t1", started.message
        warning = (
            f"trial {started.trial_id}: no samples yet from the can gyro for 1.0 s — check the bus/wiring and "
            "the CAN id (listening to virtual:"
        )

        def log() -> str:
            return driver.stderr_path.read_text(encoding="utf-8")

        probe.spin_until(lambda: warning in log(), STEP_TIMEOUT_S, "the silence warning", driver.describe)
        assert time.monotonic() - asked >= 1.0  # (not before its second of silence)
        assert "id 0x100" in log()

        aborted = op.stop(started.trial_id, abort=True)  # (answered within the probe's step timeout)
        assert aborted.accepted and aborted.message == f"trial {started.trial_id} aborted after 0 samples"
        start_ev, abort_ev = op.event(START, started.trial_id), op.event(ABORT, started.trial_id)
        assert abort_ev.sample_count == 0 and start_ev.sample_count == 0
        stamp_ns = start_ev.header.stamp.sec * 1_000_000_000 + start_ev.header.stamp.nanosec
        assert asked_ns <= stamp_ns <= answered_ns  # an empty trial is stamped at its request

        again = op.start("fork", "torsional", 1, duration_s=5.0)
        assert again.accepted and again.trial_id == "fork_torsional_o1_t2"
        stopped = op.stop()
        assert stopped.accepted and stopped.message == f"trial {again.trial_id} stopped after 0 samples"
        assert op.event(STOP, again.trial_id).sample_count == 0
        assert not op.stop().accepted  # nothing is running
        assert driver.proc.poll() is None
    assert driver.proc.returncode == 0, driver.describe()
    text = driver.stderr_path.read_text(encoding="utf-8")
    assert text.count(f"trial {started.trial_id}: no samples") == 1  # once per silence
