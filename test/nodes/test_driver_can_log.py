"""The driver node playing a python-can log file (``source:=can``, ``can_log_file``), as a process.

A candump ``.log`` written by python-can's own writer, a gyro's frames among another device's:
a trial requested through the service gets the log's samples bit for bit, stamped with the
log's own (epoch) timestamps, and the driver logs which file it plays and which clock stamps
the samples.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.sources.can import CanFrameLayout
from test.support.canlog import write_can_log
from test.support.operator import Operator
from test.support.probe import START, STOP, Probe, node_command
from test.support.processes import RosProcess

msgs: Any = pytest.importorskip("bike_rig_msgs.msg")


def test_a_trial_from_a_log_file_is_the_logs_samples(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    log = tmp_path / "gyro.log"
    rates, first_stamp = write_can_log(log, layout, 500, t0=1_790_000_000.0)
    cmd = node_command("bike_rig.ros.nodes.driver", "source:=can", f"can_log_file:={log}", "can_log_speed:=0.0")
    with RosProcess("driver", cmd, ros_env, tmp_path) as driver:
        op = Operator(probe, driver)
        started = op.start("fork", "torsional", 1, duration_s=1.5)
        assert started.accepted, started.message
        stop = op.event(STOP, started.trial_id)
        start = op.event(START, started.trial_id)
        probe.spin_until(lambda: op.samples(started.trial_id) == 1500, 60, "the trial's samples", driver.describe)
        assert driver.proc.poll() is None
    assert driver.proc.returncode == 0, driver.describe()
    got = np.concatenate([np.asarray(b.rates) for b in op.batches if b.trial_id == started.trial_id])
    assert np.array_equal(np.rint(got / 1e-4), np.rint(rates[:1500] / 1e-4))
    assert stop.sample_count == 1500
    stamp_ns = start.header.stamp.sec * 1_000_000_000 + start.header.stamp.nanosec
    assert stamp_ns == round((first_stamp - 3 / 1000) * 1e9)
    log_text = driver.stderr_path.read_text(encoding="utf-8")
    assert f"driver ready: can: log file {log} id 0x100 4×int16, played as fast as read" in log_text
    assert "stamps: the log's timestamps (epoch time, checked" in log_text
