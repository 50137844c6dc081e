"""Stalled nodes lose nothing: SIGSTOP for 20 s each, on a machine kept busy by two CPU hogs.

A stall is what swapping, a debugger or a laptop's power management does to a process; nothing
restarts a stalled node. ``bike-rig run`` of the shipped graph at 25 times real time; while it
streams, the fitter, then the parameter node, then the model node are each stopped for 20 s
(overlapping) and continued. Every trial must still be fitted from all its samples, the set
complete at the end, and ``run`` must say while it lasts that a node is stalled or behind.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from test.support.wait import wait_until

pytestmark = pytest.mark.ros

STALL_S = 20.0
#: When each node is stopped, s after the first result line.
STOPS = {"fitter": 0.0, "parameter": 4.0, "model": 8.0}
HOGS = 2


def _node_pid(domain: str, name: str) -> int | None:
    """The pid of bike_rig node ``name`` on ROS domain ``domain`` (None while it is not found)."""
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            env = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if f"bike_rig.ros.nodes.{name}".encode() in cmd and f"ROS_DOMAIN_ID={domain}".encode() in env:
            return int(pid)
    return None


def test_stalled_fitter_parameter_and_model_nodes_lose_no_trial(ros_env: dict[str, str], tmp_path: Path) -> None:
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(HOGS)]
    out_path = tmp_path / "run.out"
    cmd = [
        sys.executable,
        "-m",
        "bike_rig.cli.main",
        "run",
        "--out",
        "session",
        "--param",
        "driver.time_scale=25",
        "--param",
        "driver.exit_when_done=true",
    ]
    stopped: dict[str, int] = {}
    shown_while_stopped: list[str] = []
    try:
        with out_path.open("w") as out:
            run = subprocess.Popen(cmd, cwd=tmp_path, env=ros_env, stdout=out, stderr=subprocess.STDOUT)
        try:
            wait_until(lambda: " T = " in out_path.read_text() or run.poll() is not None, "first result", 180)
            t0 = time.monotonic()
            pending = dict(STOPS)
            while pending or stopped:
                now = time.monotonic() - t0
                for name, at in list(pending.items()):
                    if now >= at:
                        pid = _node_pid(ros_env["ROS_DOMAIN_ID"], name)
                        assert pid is not None, f"{name} not found\n{out_path.read_text()}"
                        os.kill(pid, signal.SIGSTOP)
                        stopped[name] = pid
                        del pending[name]
                for name, pid in list(stopped.items()):
                    if now >= STOPS[name] + STALL_S:
                        shown_while_stopped.extend(
                            line for line in out_path.read_text().splitlines() if f" {name} " in line
                        )
                        os.kill(pid, signal.SIGCONT)
                        del stopped[name]
                time.sleep(0.05)
            code = run.wait(timeout=300)
        finally:
            for pid in stopped.values():
                os.kill(pid, signal.SIGCONT)
            if run.poll() is None:
                run.send_signal(signal.SIGINT)
                run.wait(timeout=60)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    text = out_path.read_text()
    assert code == 0, text
    for name in STOPS:  # the stall said while it lasted (stderr), and its end
        said = [line for line in shown_while_stopped if line.startswith(f"bike-rig run: {name} ")]
        assert said and ("silent for" in said[0] or "behind" in said[0]), (name, shown_while_stopped)
        assert f"bike-rig run: {name} caught up" in text, text
    assert [line for line in text.splitlines() if line.startswith("  REDO") and "gap:" in line] == [], text
    assert re.search(r"^39 trial\(s\): \d+ ok, \d+ to redo, 0 without a result$", text, re.M), text
    assert re.search(r"^parameters: complete \(Browser\); weave speed \d", text, re.M), text
