"""`bike-rig run` as a live child process: its command line, a short rig, its result lines."""

from __future__ import annotations

import contextlib
import re
import sys
from pathlib import Path

import yaml

from bike_rig.config.paths import config_file
from test.support.processes import RosProcess

#: The beating trial (the fitter flags it, poor fit or beating: REDO).
BEATING = "frame_torsional_o2_t1"
#: A result line; the cycles need the trial's sample rate, from its START (DDS may deliver a
#: START up to a heartbeat late at the very start of a run, after its result).
RESULT = re.compile(r"^trial (\S+) \((\w+)\): T = (\d+\.\d+) ± (\S+) s(, \d+ cycles)?, r² (\d\.\d{5}) - (ok|REDO)$")


def live_rig(directory: Path, beating: bool = True) -> Path:
    """A short rig: one 15 s trial per period; one trial that beats."""
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, "duration": 15})
    beat = {"detuning": [0.25, 0.3], "amplitude_ratio": [0.8, 0.9]}  # beats within 15 s: flagged
    data["coupled_swing"].update({"probability": 0.0, "trials": [BEATING] if beating else [], **beat})
    path = directory / "rig.yaml"  # also a name in the config folder: the current directory's wins
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def bike_rig_argv(*argv: str) -> list[str]:
    return [sys.executable, "-m", "bike_rig.cli.main", *argv]


def all_lines(run: RosProcess) -> list[str]:
    """Every stdout line of an ended process (those not read yet too)."""
    with contextlib.suppress(AssertionError):
        run.expect("\0", 5)  # no line starts with it: reads up to the end
    return run.lines
