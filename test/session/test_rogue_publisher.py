"""A rogue publisher on the session's domain (another process, real nodes): the driver's trials stay exact."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.core.sim.session import SimulatedTrial
from bike_rig.offline.session import read_session
from bike_rig.pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.fit import TrialFit, fit_trial
from test.support.sessions import PlainSession as Session
from test.support.sessions import end_process, kill_session
from test.support.wait import wait_until

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
ROGUE = Path(__file__).with_name("rogue.py")
REPO = Path(__file__).resolve().parents[2]
SEED = 4


def _alone(trial: SimulatedTrial) -> TrialFit:
    """The simulated trial fitted from its own samples alone, in the driver's 50-sample batches."""
    rate, n = float(trial.sample_rate), trial.rate.size
    batches = [SampleBatch(trial.name, a, rate, np.asarray(trial.rate[a : a + 50])) for a in range(0, n, 50)]
    start = TrialEventRecord(TrialEventKind.START, trial.name, trial.key, sample_rate_hz=rate)
    stop = TrialEventRecord(TrialEventKind.STOP, trial.name, trial.key, sample_rate_hz=rate, sample_count=n)
    return fit_trial(batches, start, stop)


def test_junk_from_another_process_never_touches_the_drivers_trial(tmp_path: Path, ros_env: dict[str, str]) -> None:
    folder = tmp_path / "s"
    argv = [
        str(BIKE_RIG),
        "session",
        "--plain",
        "--json",
        "--time-scale",
        "150",
        "--seed",
        str(SEED),
        "--output",
        str(folder),
    ]
    s = Session(argv, ros_env)
    rogue = subprocess.Popen(
        [sys.executable, str(ROGUE), "rear_wheel_compound_t1"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**ros_env, "PYTHONPATH": str(REPO)},
    )
    try:
        assert rogue.stdin is not None and rogue.stdout is not None
        assert rogue.stdout.readline().strip() == "MATCHED"
        rogue.stdin.write("GO\n")
        rogue.stdin.flush()
        assert rogue.stdout.readline().strip() == "DONE"
        result = s.trial("TcR1#1")  # the id the rogue sent junk for

        def missing() -> list[str]:
            s.send("status")
            return list(s.until(lambda r: "missing" in r)["missing"])

        # the parameter node's update follows the result: the absurd estimate blocks nothing
        wait_until(
            lambda: "TcR1" not in missing(), "TcR1 no longer missing", interval_s=0.2, describe=lambda: str(missing())
        )
        s.send("quit")
        s.proc.wait(60)
    finally:
        end_process(rogue)
        s.close()
        kill_session(folder)
    # the driver's trial is fitted exactly as from the simulated rig's samples alone
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    trial = simulate_session(truth, load_rig(config_file("rig.yaml")), SEED, name).trials[0]
    assert trial.key == "TcR1"
    expected = _alone(trial)
    assert result["trial_id"] == trial.name and result["state"] == "ok" and result["flags"] == []
    assert result["period"] == expected.period and result["period_sigma"] == expected.period_sigma
    parameter_log = (folder / "logs" / "parameter.log").read_text()
    assert "trial 'rogue_t1': period 1e+308 ± 0.0001 s is not a rig pendulum's" in parameter_log
    fitter_log = (folder / "logs" / "fitter.log").read_text()
    evicted = [line for line in fitter_log.splitlines() if "fitted as it is" in line]
    assert not any(trial.name in line for line in evicted), evicted  # only the rogue's own junk, if any


ROGUE_FLOOD = Path(__file__).with_name("rogue_flood.py")
FLOOD_S = 12.0


def test_a_flood_at_ten_times_the_rate_with_backward_stamps_and_wrong_rates(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    """A rogue sends 10× the driver's batches while a 12 s trial records in real time.

    Its own trial, and the driver's trial id with indices and stamps going backwards at a wrong
    rate: the driver's trial is fitted exactly, the recorder records every one of its batches,
    the fitter drops the rest.
    """
    rig = yaml.safe_load(config_file("rig.yaml").read_text())
    rig["trials"]["duration"] = FLOOD_S
    rig.pop("coupled_swing", None)
    rig_file = tmp_path / "rig.yaml"
    rig_file.write_text(yaml.safe_dump(rig))
    folder = tmp_path / "s"
    argv = [
        str(BIKE_RIG),
        "session",
        "--plain",
        "--json",
        "--time-scale",
        "1",
        "--seed",
        str(SEED),
        "--rig",
        str(rig_file),
        "--output",
        str(folder),
    ]
    s = Session(argv, ros_env)
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    trial = simulate_session(truth, load_rig(rig_file), SEED, name).trials[0]
    flood = subprocess.Popen(
        [sys.executable, str(ROGUE_FLOOD), trial.name, str(FLOOD_S), "10"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**ros_env, "PYTHONPATH": str(REPO)},
    )
    try:
        assert flood.stdin is not None and flood.stdout is not None
        assert flood.stdout.readline().strip() == "MATCHED"
        s.send("start TcR1#1")
        started = s.until(lambda r: r.get("command") == "start")
        assert started["kind"] == "ok" and started["trial_id"] == trial.name, started
        flood.stdin.write("GO\n")
        flood.stdin.flush()
        result = s.until(lambda r: r["kind"] == "result" and r.get("trial_id") == trial.name, timeout_s=90)
        done = flood.stdout.readline().split()
        assert done[0] == "DONE" and int(done[1]) > 0, done
        s.send("quit")
        s.proc.wait(60)
    finally:
        end_process(flood)
        s.close()
        kill_session(folder)
    rate, n = float(trial.sample_rate), trial.rate.size
    expected = _alone(trial)
    assert result["state"] == "ok" and result["flags"] == [], result
    assert result["period"] == expected.period and result["period_sigma"] == expected.period_sigma
    # the recorder kept every batch of the driver's (and the rogue's too: it records what was said)
    recorded = read_session(folder / "bag").trials[trial.name].batches
    driver = {b.first_index for b in recorded if b.sample_rate_hz == rate}
    assert driver == set(range(0, n, 50))
    # the flood overlapped the trial: the rogue's batches of its id (at 250 Hz) arrived among the driver's in
    # each half of it (a count per second of wall time would measure the machine's load, not the fitter)
    order = [(int(b.first_index), float(b.sample_rate_hz)) for b in recorded]
    first, middle, last = (order.index((i, rate)) for i in (0, 50 * (n // 100), 50 * ((n - 1) // 50)))
    junk = [k for k, (_, r) in enumerate(order) if r == 250.0]
    early, late = sum(first < k < middle for k in junk), sum(middle < k < last for k in junk)
    assert early > 0 and late > 0, f"rogue batches in the trial's halves: {early}, {late} (of {len(junk)})"
    fitter_log = (folder / "logs" / "fitter.log").read_text()
    assert f"trial {trial.name}: batches from another process than the one that started it: dropped" in fitter_log
    assert "flood_e20: STOP without START" in fitter_log  # the rogue's own events: its own trials
    assert len(fitter_log.splitlines()) < 0.2 * int(done[1])  # lines for the rogue's junk trials, not per batch
