"""The operator console driven as a person drives it: under tmux, through a whole simulated session.

Real node processes over DDS (the console starts the graph: the operator-driven simulated rig,
the fitter, the parameter and model nodes and the recorder). Every static reading is typed in,
every trial started from the keyboard (F2), one trial is recorded too short, flagged and
redone, one reading is corrected; at the end the bag replays offline, with no external file, to
the same 25 parameters as the offline core on the same trials and readings.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.paths import config_file
from bike_rig.session.plan import ReadingItem, plan_from_rig
from test.support.tmux import TMUX, TmuxSession

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
TIME_SCALE = 150.0


def _kill_leftovers(folder: Path) -> None:
    pids = folder / "logs" / "pids"
    if not pids.is_file():
        return
    for line in pids.read_text().splitlines():
        pid = int(line.split()[1])
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


@pytest.fixture
def readings() -> dict[str, tuple[float, float]]:
    """Plausible static readings of the Browser (a simulated session's, seed 5)."""
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    sim = simulate_session(truth, rig, 5, name)
    return {k: (r.value, r.sigma) for k, r in sim.readings.items() if not k.startswith(("Tc", "Tt"))}


@pytest.mark.skipif(not Path(TMUX).exists(), reason="tmux is installed by tools/setup_debian.sh (make test)")
def test_a_whole_session_at_the_console(tmp_path: Path, ros_env: dict[str, str], readings) -> None:  # type: ignore[no-untyped-def]
    folder = tmp_path / "session"
    argv = [str(BIKE_RIG), "session", "--time-scale", str(TIME_SCALE), "--seed", "4", "--output", str(folder)]
    tmux = TmuxSession(argv, ros_env, tmp_path)
    plan = plan_from_rig(load_rig(config_file("rig.yaml")))
    try:
        tmux.wait_for(r"0/68 done", 60)
        flagged = False
        corrected = False
        for item in plan.items:
            if isinstance(item, ReadingItem):
                value, sigma = readings[item.key]
                tmux.keys("F2")
                tmux.wait_for(rf"reading {item.key} ")
                shown = value * 1.01 if item.key == "w" and not corrected else value
                tmux.type(f"{shown!r} {sigma!r}")
                tmux.keys("Enter")
                tmux.wait_for(rf"entered {item.key} =")
                if item.key == "w" and not corrected:
                    tmux.type(f"reading w {value!r} {sigma!r}")  # the operator corrects the wheelbase
                    tmux.keys("Enter")
                    tmux.wait_for(r"corrected w =")
                    corrected = True
                continue
            if not flagged and item.key == "TtB2":
                tmux.type(f"start {item.item_id} 2")  # too short: too few cycles
                tmux.keys("Enter")
                tmux.wait_for(r"REDO \(too_few_cycles", 30)
                tmux.wait_for(rf"F2 records {re.escape(item.item_id)} again")
                flagged = True
            tmux.keys("F2")
            tmux.wait_for(rf"{re.escape(item.item_id)} \S+: T = [0-9.]+ ± \S+ s, \d+ cycles, r² [0-9.]+ — ok", 60)
        screen = tmux.wait_for(r"68/68 done\s+weave [0-9.]+±[0-9.]+\s+capsize [0-9.]+±[0-9.]+ m/s", 60)
        weave = float(re.search(r"weave ([0-9.]+)±", screen).group(1))  # type: ignore[union-attr]
        tmux.keys("F10")
        tmux.wait_for(r"\[exit 0\]", 60)
    finally:
        tmux.close()
        _kill_leftovers(folder)
    assert flagged and corrected
    bag = folder / "bag"
    out = subprocess.run([str(BIKE_RIG), "replay", str(bag), "--json"], capture_output=True, text=True, timeout=120,
                         env=ros_env)  # fmt: skip
    assert out.returncode == 0, out.stderr
    replayed = json.loads(out.stdout)
    assert replayed["comparison"]["identical"] or replayed["comparison"]["largest_relative_difference"] < 1e-9
    assert abs(replayed["weave"]["speed"] - weave) < 1e-3
