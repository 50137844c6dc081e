"""The soak's short version: a live session recording trial after trial, every process's memory bounded.

``make soak`` runs the same for an hour at the rig's real 1 kHz (``tools/soak.py``).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from bike_rig.pipeline.resend import DEFAULT_HISTORY_SAMPLES

REPO = Path(__file__).resolve().parents[2]


def test_a_short_soak_keeps_every_process_alive_and_its_memory_flat(ros_env: dict[str, str]) -> None:
    argv = [sys.executable, str(REPO / "tools" / "soak.py"), "--seconds", "45", "--time-scale", "100", "--every", "2"]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=300, env=ros_env)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    rows = re.findall(r"^(\w+)\s+([\d.]+) MB\s+([\d.]+) MB\s+([\d.]+) MB\s+([+-][\d.]+) %$", done.stdout, re.M)
    assert {r[0] for r in rows} == {"console", "driver", "fitter", "parameter", "model", "recorder"}
    assert all(abs(float(r[4])) <= 5.0 for r in rows), rows
    results = int(re.search(r"(\d+) trial results", done.stdout).group(1))  # type: ignore[union-attr]
    assert results >= 40, done.stdout[:400]  # it did record: > one plan of trials
    assert f"history of {DEFAULT_HISTORY_SAMPLES} samples full: " in done.stdout and "not reached" not in done.stdout
