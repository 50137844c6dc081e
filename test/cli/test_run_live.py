"""``bike-rig run`` with real node processes over DDS (localhost, the test run's domain id).

The shipped graph (``config/graph.yaml``: the simulated rig → fitter → parameter → model,
recorder) on a short rig (one 15 s trial per period, 13 trials) played 100 times faster than
real time; the command runs from a scratch current directory, as a user's would, with the
installed copy of bike_rig.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

from bike_rig.config.paths import config_file
from bike_rig.core.period.advice import FLAG_ADVICE, flag_advice
from bike_rig.core.period.result import FlagCode
from bike_rig.offline.info import summarize
from test.support.live import BEATING, RESULT, all_lines, bike_rig_argv, live_rig
from test.support.processes import RosProcess


def test_the_default_graph_runs_end_to_end_and_prints_every_result(ros_env: dict[str, str], tmp_path: Path) -> None:
    live_rig(tmp_path)
    cmd = bike_rig_argv(
        "run",
        "--out",
        "session",
        "--param",
        "driver.rig=rig.yaml",
        "--param",
        "driver.bicycle=bicycles/browser.yaml",
        "--param",
        "driver.time_scale=100",
        "--param",
        "driver.exit_when_done=true",
        "--param",
        "driver.seed=4",
    )
    t0 = time.monotonic()
    done = subprocess.run(cmd, cwd=tmp_path, env=ros_env, capture_output=True, text=True, timeout=120)
    wall = time.monotonic() - t0
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    results = {m.group(1): m for m in map(RESULT.match, lines) if m}
    recording = {line.split()[1]: at for at, line in enumerate(lines) if line.endswith("): recording")}
    assert len(results) == 13 and len(lines) == len(set(lines)), done.stdout  # the small rig: 13 trials, each once
    # START (the driver's) and the result (the fitter's) come from two processes, in either order: a
    # trial is "recording" only if its START came first, and then its result counts the cycles
    # (from the START's sample rate); a result before its START has neither
    assert set(recording) <= set(results), done.stdout
    for key, m in results.items():
        started_first = key in recording and recording[key] < lines.index(m.group(0))
        assert (m.group(5) is not None) == started_first, (key, done.stdout)
        assert started_first or key not in recording, (key, done.stdout)  # never "recording" after its result
    assert {k: m.group(7) for k, m in results.items() if m.group(7) != "ok"} == {BEATING: "REDO"}, done.stdout
    at = lines.index(results[BEATING].group(0)) + 1
    flags = lines[at : at + next(i for i, line in enumerate(lines[at:]) if not line.startswith("    "))]
    assert flags, done.stdout  # every flag on a line of its own: code, reason -> advice
    for line in flags:
        code, _, rest = line.strip().partition(": ")
        assert rest.endswith(f" -> {flag_advice(code)}") and FlagCode(code) in FLAG_ADVICE, line
    assert results["calibration_rod_torsional_t1"].group(2) == "TtP1"
    assert "13 trial(s): 12 ok, 1 to redo, 0 without a result" in lines
    assert re.search(rf"^  REDO {BEATING} \(TtB2\): \w+: ", done.stdout, re.M), done.stdout
    assert "parameters: incomplete (Browser); missing: TtB2" in lines  # its only trial is flagged
    # where the session is: one folder with the bag and the logs
    assert "session folder: session" in lines
    assert "  bag:  session/bag  (bike-rig bag info | replay | report BAG)" in lines
    assert "  logs: session/logs" in lines
    assert sorted(p.name for p in (tmp_path / "session" / "logs").iterdir()) == [
        "driver.log",
        "fitter.log",
        "model.log",
        "parameter.log",
        "pids",
        "recorder.log",
    ]
    assert "bike-rig run: parameter.measurements = bicycles/browser.yaml (the static readings of driver.bicycle)" in (
        done.stderr
    )
    assert "node 'driver' finished; the graph was stopped" in done.stderr
    summary = summarize(tmp_path / "session" / "bag")
    assert len(summary.trials) == 13 and {t.state for t in summary.trials} == {"complete"}
    assert all(t.samples == t.announced == 15_000 for t in summary.trials)
    print(f"bike-rig run of 13 trials (15 s each at 100x): {wall:.1f} s wall")


def test_ctrl_c_during_a_trial_records_abort_and_prints_a_summary(ros_env: dict[str, str], tmp_path: Path) -> None:
    live_rig(tmp_path, beating=False)
    out_dir = tmp_path / "s"
    cmd = bike_rig_argv(
        "run",
        "--out",
        str(out_dir),
        "--param",
        f"driver.rig={tmp_path / 'rig.yaml'}",
        "--param",
        "driver.time_scale=10",
        "--param",
        "driver.seed=4",
        "--param",
        "driver.pause_between_trials_s=0.0",  # no pause: Ctrl-C always lands in a trial
    )
    run = RosProcess("run", cmd, ros_env, tmp_path)
    try:
        seen: set[str] = set()
        while len(seen) < 2:  # two trials seen (started or done): the graph is streaming (a trial takes 1.5 s)
            seen.add(run.expect("trial", 60).split()[0])
        time.sleep(0.5)
        # SIGINT, as Ctrl-C, and only that: the wind-down (ABORT, the last results, the nodes
        # stopping, the bag's last sync) may take long on a busy machine, and RosProcess.stop's
        # SIGTERM after its grace would be a second Ctrl-C (skip the wait for the last results)
        os.kill(run.pid, signal.SIGINT)
        code = run.proc.wait(timeout=120)
    finally:
        run.stop()
    lines = all_lines(run)
    out = "\n".join(lines)
    assert code == 0, run.describe()
    bag = summarize(out_dir / "bag").trials  # the trials recorded, in order
    trials = {t.trial_id: t for t in bag}
    # every trial run saw has a line of its own after the stop: a result, or ABORTED (a "recording"
    # line needs the trial's START before its result: two processes, either order)
    done = {m.group(1) for m in map(re.compile(r"^trial (\S+) \(\w+\): (?!recording$)").match, lines) if m}
    aborted = [line.split()[1] for line in lines if re.match(r"^trial \S+ \(\w+\): ABORTED after \d+ samples$", line)]
    assert aborted == [bag[-1].trial_id], out  # the trial in progress, and only it
    last = aborted[0]
    assert re.search(rf"^trial {last} \(\w+\): .* - REDO\n    aborted: the trial was aborted -> ", out, re.M), out
    assert sorted(done) == sorted(trials), out
    n = len(trials)
    assert f"{n} trial(s): {n - 1} ok, 1 to redo, 0 without a result" in lines, out
    assert f"  bag:  {out_dir / 'bag'}  (bike-rig bag info | replay | report BAG)" in lines
    assert {t.state for k, t in trials.items() if k != last} == {"complete"} and trials[last].state == "aborted"
    assert trials[last].samples == trials[last].announced and trials[last].samples < 15_000
    assert "Ctrl-C again" in (tmp_path / "run.stderr").read_text()


def test_a_run_that_fails_at_start_leaves_no_empty_bag(ros_env: dict[str, str], tmp_path: Path) -> None:
    (tmp_path / "mybike.yaml").write_text(config_file("bicycles/browser.yaml").read_text())  # not a session
    cmd = bike_rig_argv("run", "--out", "s", "--param", "driver.session=mybike.yaml")
    done = subprocess.run(cmd, cwd=tmp_path, env=ros_env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if "error" in line]
    assert len(errors) == 1 and errors[0].startswith(
        f"bike-rig run: error: node 'driver': sim source: parameter 'session' = '{tmp_path / 'mybike.yaml'}': "
        "lists no trial files"
    ), done.stderr
    assert "  bag:  none (no trial was recorded; the empty bag was removed)" in done.stdout.splitlines()
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["logs"]
    assert "trial(s)" not in done.stdout  # nothing to summarise


def test_a_node_started_with_a_domain_id_above_101_says_so_in_one_line(ros_env: dict[str, str], tmp_path: Path) -> None:
    env = {**ros_env, "ROS_DOMAIN_ID": "150"}
    cmd = [sys.executable, "-m", "bike_rig.ros.nodes.fitter", "--ros-args"]
    done = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        "fitter: error: ROS_DOMAIN_ID=150 in the environment is outside 0..101, the domain ids Fast DDS supports "
        "on Linux"
    ], done.stderr
