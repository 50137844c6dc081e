"""A rogue publisher on the session's domain (another process, real nodes): the driver's trials stay exact."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.paths import config_file
from bike_rig.pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.fit import fit_trial
from test.session.test_session_faults import Session
from test.support.sessions import kill_session

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
ROGUE = Path(__file__).with_name("rogue.py")
REPO = Path(__file__).resolve().parents[2]
SEED = 4


def test_junk_from_another_process_never_touches_the_drivers_trial(tmp_path: Path, ros_env: dict[str, str]) -> None:
    folder = tmp_path / "s"
    argv = [str(BIKE_RIG), "session", "--plain", "--json", "--time-scale", "150", "--seed", str(SEED),
            "--output", str(folder)]  # fmt: skip
    s = Session(argv, ros_env)
    rogue = subprocess.Popen([sys.executable, str(ROGUE), "rear_wheel_compound_t1"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env={**ros_env, "PYTHONPATH": str(REPO)})  # fmt: skip
    try:
        assert rogue.stdin is not None and rogue.stdout is not None
        assert rogue.stdout.readline().strip() == "MATCHED"
        rogue.stdin.write("GO\n")
        rogue.stdin.flush()
        assert rogue.stdout.readline().strip() == "DONE"
        result = s.trial("TcR1#1")  # the id the rogue sent junk for
        deadline = time.monotonic() + 20  # the parameter node's update follows the result
        while True:
            s.send("status")
            missing = s.until(lambda r: "missing" in r)["missing"]
            if "TcR1" not in missing or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        s.send("quit")
        s.proc.wait(60)
    finally:
        rogue.kill()
        rogue.wait(10)
        for stream in (rogue.stdin, rogue.stdout):
            if stream is not None:
                stream.close()
        s.close()
        kill_session(folder)
    # the driver's trial is fitted exactly as from the simulated rig's samples alone
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    trial = simulate_session(truth, load_rig(config_file("rig.yaml")), SEED, name).trials[0]
    assert trial.key == "TcR1"
    rate = float(trial.sample_rate)
    n = trial.rate.size
    batches = [SampleBatch(trial.name, a, rate, np.asarray(trial.rate[a : a + 50])) for a in range(0, n, 50)]
    start = TrialEventRecord(TrialEventKind.START, trial.name, "TcR1", sample_rate_hz=rate)
    stop = TrialEventRecord(TrialEventKind.STOP, trial.name, "TcR1", sample_rate_hz=rate, sample_count=n)
    expected = fit_trial(batches, start, stop)
    assert result["trial_id"] == trial.name and result["state"] == "ok" and result["flags"] == []
    assert result["period"] == expected.period and result["period_sigma"] == expected.period_sigma
    assert "TcR1" not in missing  # the absurd estimate blocked nothing
    parameter_log = (folder / "logs" / "parameter.log").read_text()
    assert "trial 'rogue_t1': period 1e+308 ± 0.0001 s is not a rig pendulum's" in parameter_log
    fitter_log = (folder / "logs" / "fitter.log").read_text()
    evicted = [line for line in fitter_log.splitlines() if "fitted as it is" in line]
    assert not any(trial.name in line for line in evicted), evicted  # only the rogue's own junk, if any
