"""``bike-rig run`` with a node stalled (SIGSTOP, then SIGCONT): said once, waited for, caught up.

The shipped graph on the short rig of ``test_run_live.py`` (13 trials of 15 s, no beating) at 25
times real time. After the first result the parameter node is stopped; the driver finishes
meanwhile, and ``run`` must neither stay quiet about it nor give up on the set: it says the node
is silent, waits past its usual 5 s, and once the node is continued the set completes.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import time
from pathlib import Path

import pytest

from test.support.live import RESULT, all_lines, bike_rig_argv, live_rig
from test.support.nodes import node_environment
from test.support.processes import RosProcess
from test.support.sessions import session_pids

pytestmark = pytest.mark.ros


def _stderr_line(run: RosProcess, needle: str, timeout_s: float) -> str:
    """Wait for a stderr line holding ``needle``; return it."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        lines = run.stderr_path.read_text(errors="replace").splitlines()
        found = [line for line in lines if needle in line]
        if found:
            return found[0]
        if run.proc.poll() is not None:
            break
        time.sleep(0.1)
    raise AssertionError(f"no stderr line with {needle!r} within {timeout_s} s\n{run.describe()}")


def test_a_stalled_parameter_node_is_said_waited_for_and_caught_up(ros_env: dict[str, str], tmp_path: Path) -> None:
    rig, folder = live_rig(tmp_path, beating=False), tmp_path / "session"
    cmd = bike_rig_argv(
        "run",
        "--out",
        str(folder),
        "--param",
        f"driver.rig={rig}",
        "--param",
        "driver.bicycle=bicycles/browser.yaml",
        "--param",
        "driver.time_scale=25",
        "--param",
        "driver.exit_when_done=true",
        "--param",
        "driver.seed=4",
    )
    run = RosProcess("run", cmd, node_environment(ros_env), tmp_path)  # (this checkout's bike_rig, nodes too)
    parameter = 0
    try:
        first = run.expect("trial", 90)
        while not RESULT.match(f"trial {first}"):
            first = run.expect("trial", 60)
        parameter = session_pids(folder)["parameter"]
        os.kill(parameter, signal.SIGSTOP)
        silent = _stderr_line(run, "parameter silent for", 20)
        # the driver is done; run waits past its 5 s without a result because the node is stalled
        # (run says "waiting for" only after that: while settling, 5 s after the last arrival)
        waiting = _stderr_line(run, "bike-rig run: waiting for ", 60)
        driver_log = (folder / "logs" / "driver.log").read_text(errors="replace")
        os.kill(parameter, signal.SIGCONT)
        parameter = 0
        caught_up = _stderr_line(run, "parameter caught up", 60)
        code = run.proc.wait(timeout=90)
    finally:
        if parameter:
            with contextlib.suppress(ProcessLookupError):
                os.kill(parameter, signal.SIGCONT)
        run.stop()
    lines = all_lines(run)
    out = "\n".join(lines)
    stderr = run.stderr_path.read_text(errors="replace").splitlines()
    assert code == 0, run.describe()
    assert re.fullmatch(r"bike-rig run: parameter silent for \d+ s \(stalled\?\): results will follow", silent)
    assert waiting.startswith("bike-rig run: waiting for the parameter set (") and "): parameter silent for " in waiting
    assert caught_up == "bike-rig run: parameter caught up", stderr
    # the order of events: the driver's plan had finished while the node was stopped, run said the
    # node was silent, then that it waits (past its 5 s: the wait that used to give up), and only
    # after the node was continued that it caught up
    assert "plan finished: 13 trials" in driver_log, driver_log[-2000:]
    assert stderr.index(silent) < stderr.index(waiting) < stderr.index(caught_up), stderr
    assert sum(line.startswith("bike-rig run: parameter silent") for line in stderr) == 1, stderr  # once
    assert sum("parameter caught up" in line for line in stderr) == 1, stderr
    assert not [line for line in stderr if "gave up" in line], stderr
    assert "13 trial(s): 13 ok, 0 to redo, 0 without a result" in lines, out
    assert any(line.startswith("parameter set complete: weave speed ") for line in lines), out
    assert any(line.startswith("parameters: complete (Browser); weave speed ") for line in lines), out
