"""Nodes SIGKILLed under a plain session (real node processes), each in turn.

The fitter, the parameter and the model nodes are killed mid-session: the session says so in
one line each, restarts them, and goes on to the same results (their inputs come back from the
topics' transient-local history). The driver is killed last: the line says to resume, and
``--resume`` continues the session from its bag with every trial recorded before.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

from test.support.sessions import PlainSession as Session
from test.support.sessions import kill_session, session_pids
from test.support.wait import wait_until

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
ITEMS = ["TcR1#1", "TcR1#2", "TcR1#3", "TtR1#1", "TtR1#2", "TtR1#3"]


def test_killed_nodes_are_said_restarted_and_a_killed_driver_resumed(tmp_path: Path, ros_env: dict[str, str]) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    common = [str(BIKE_RIG), "session", "--plain", "--json", "--time-scale", "150", "--seed", "5"]
    s = Session([*common, "--output", str(a)], ros_env)
    try:
        results = [s.trial(ITEMS[0])]
        pids = session_pids(a)
        for node, item in zip(("fitter", "parameter", "model"), ITEMS[1:4], strict=True):
            os.kill(pids[node], signal.SIGKILL)
            # (the health monitor may report the node first: the launcher's word is the error record)
            said = s.until(lambda r, node=node: r.get("node") == node and r["kind"] == "error")  # type: ignore[misc]
            assert said["kind"] == "error" and "killed by SIGKILL" in said["text"] and "restarted" in said["text"]
            assert len(said["text"].splitlines()) == 1
            results.append(s.trial(item))
        assert all(r["state"] == "ok" for r in results), results

        # the restarted parameter and model nodes: the rear wheel's keys are no longer missing
        def held() -> list[str]:
            """The parameter node's lacking keys once TcR1 and TtR1 are not among them, else []."""
            s.send("status")
            keys = list(s.until(lambda r: "lacking" in r)["lacking"])  # (the parameter node's own keys)
            return keys if keys and "TcR1" not in keys and "TtR1" not in keys else []

        missing = wait_until(held, "the restarted parameter node to hold TcR1 and TtR1", interval_s=0.2)
        assert "TtP1" in missing, missing
        os.kill(pids["driver"], signal.SIGKILL)
        said = s.until(lambda r: r.get("node") == "driver" and r["kind"] == "error")
        assert "--resume" in said["text"] and str(a) in said["text"]
        s.send("quit")
        assert s.proc.wait(30) == 0
    finally:
        s.close()
        kill_session(a)

    stdin = "wait 60\nstart TtR1#3\nwait 60\nstatus\nquit\n"
    try:
        done = subprocess.run(
            [*common, "--output", str(b), "--resume", str(a)],
            input=stdin,
            capture_output=True,
            text=True,
            timeout=300,
            env=ros_env,
        )
    finally:
        kill_session(b)
    lines = [json.loads(x) for x in done.stdout.splitlines()]
    assert done.returncode == 0, (done.stderr[-2000:], lines)
    back = [x for x in lines if x["kind"] == "result"]
    # the same trials, fitted again (an aborted one has no period: the bag lacked its STOP)
    assert [x.get("period") for x in back[:4]] == [r["period"] for r in results], (back, done.stderr[-2000:])
    assert back[4]["key"] == "TtR1" and back[4]["state"] == "ok"
    progress = next(x for x in lines if "done" in x)
    assert progress["done"] == 5
