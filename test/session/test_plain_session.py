"""The same whole session scripted through ``bike-rig session --plain --json`` (real node processes)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.session.plan import plan_from_rig
from test.support.sessions import kill_session, plan_script

BIKE_RIG = Path(sys.executable).parent / "bike-rig"


def test_a_scripted_session_completes_and_its_bag_replays(tmp_path: Path, ros_env: dict[str, str]) -> None:
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    sim = simulate_session(truth, rig, 6, name)
    plan = plan_from_rig(rig)
    script = ["start TtB9#1", "start TcR1#1 0.5", "wait 30"]  # an item outside the plan; a trial far too short
    script += plan_script(plan, sim.readings)
    script += ["start", "wait 60"] * 4  # redo whatever was flagged (then: nothing left to start)
    script += ["wait complete 60", "params", "status", "quit"]
    folder = tmp_path / "s"
    argv = [str(BIKE_RIG), "session", "--plain", "--json", "--time-scale", "150", "--seed", "2"]
    argv += ["--output", str(folder)]
    stdin = "\n".join(script) + "\n"
    try:
        done = subprocess.run(argv, input=stdin, capture_output=True, text=True, timeout=600, env=ros_env)
    finally:
        kill_session(folder)
    lines = [json.loads(x) for x in done.stdout.splitlines()]
    errors = [x["text"] for x in lines if x["kind"] == "error"]
    # the refused item; the extra 'start's once every trial of a measurement is ok; nothing else
    assert errors[0].startswith("no plan item 'TtB9#1'"), errors
    assert all(e.startswith(("no plan item", "every trial of the plan is ok")) for e in errors), errors
    results = [x for x in lines if x["kind"] == "result"]
    assert results[0]["flags"] and results[0]["state"] == "REDO"  # the 0.5 s trial
    assert sum(x["state"] == "ok" for x in results) == len(plan.trials)
    params = {x["name"]: x for x in lines if "name" in x and "value" in x}
    assert len(params) == 26
    speeds = [x for x in lines if x.get("weave")]
    assert speeds, done.stdout[-2000:]
    assert lines[-1]["kind"] == "done" and done.returncode == 1  # a command failed (the refused one)
    out = subprocess.run(
        [str(BIKE_RIG), "replay", str(folder / "bag"), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
        env=ros_env,
    )
    replayed = json.loads(out.stdout)
    assert replayed["complete"] and replayed["live"]["identical"], replayed["live"]
    for k, p in params.items():
        assert replayed["parameters"][k]["value"] == p["value"], k
    assert abs(replayed["weave_speed"] - speeds[-1]["weave"][0]) == 0.0


def test_a_silent_can_gyro_warns_within_a_second_and_the_trial_aborts(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """The CAN source on python-can's virtual bus with nothing sending: the console says so, ABORT works."""
    script = ["start TcR1#1", "wait 1.5", "abort", "wait 5", "quit"]
    argv = [str(BIKE_RIG), "session", "--plain", "--json", "--source", "can", "--output", str(tmp_path / "s")]
    try:
        done = subprocess.run(
            argv, input="\n".join(script) + "\n", capture_output=True, text=True, timeout=120, env=ros_env
        )
    finally:
        kill_session(tmp_path / "s")
    lines = [json.loads(x) for x in done.stdout.splitlines()]
    # what the session is connected to: said first, the bus and the domain with the view line to paste
    conn = next(x["connection"] for x in lines if "connection" in x)
    domain = int(ros_env["ROS_DOMAIN_ID"])
    assert (conn["interface"], conn["channel"], conn["can_id"], conn["domain_id"]) == (
        "virtual",
        "bike_rig",
        256,
        domain,
    )
    assert conn["view"] == f"bike-rig view --domain-id {domain}"
    started = next(x for x in lines if x.get("command") == "start")
    warning = next(x for x in lines if x["kind"] == "warning")
    assert "no samples yet" in warning["text"] and "CAN id" in warning["text"]
    assert warning["trial_id"] == started["trial_id"]
    aborted = [x for x in lines if x.get("command") == "abort"]
    assert aborted and aborted[0]["kind"] == "ok" and "0 samples" in aborted[0]["text"]
    assert any("aborted — REDO" in x["text"] for x in lines if x["kind"] == "result")
