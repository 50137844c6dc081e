"""Three live graphs at once on this 2-core machine: nothing the driver sent is asked to be redone.

Each ``bike-rig run`` is the shipped graph (the simulated Browser session, 39 trials of 30 s)
at 100 times real time, on a domain of its own, all three started together as a busy rig PC
would run them. Each must end with no trial flagged for missing samples, the parameter set
complete, and live results identical to the replay of its own bag.
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from bike_rig.ros.env import ros_environment, unique_domain_id

pytestmark = pytest.mark.ros

GRAPHS = 3
TIME_SCALE = 100


def _bike_rig(*argv: str) -> list[str]:
    return [sys.executable, "-m", "bike_rig.cli.main", *argv]


def test_three_graphs_at_once_lose_nothing_and_agree_with_their_bags(tmp_path: Path) -> None:
    with contextlib.ExitStack() as stack:
        domains = [stack.enter_context(unique_domain_id()) for _ in range(GRAPHS)]
        runs = []
        for i, domain in enumerate(domains):
            cmd = _bike_rig(
                "run",
                "--out",
                f"g{i}",
                "--param",
                f"driver.time_scale={TIME_SCALE}",
                "--param",
                "driver.exit_when_done=true",
            )
            out = (tmp_path / f"g{i}.out").open("w")
            stack.callback(out.close)
            env = ros_environment(domain_id=domain)
            runs.append(subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=out, stderr=subprocess.STDOUT))
        try:
            codes = [p.wait(timeout=420) for p in runs]
        finally:
            for p in runs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
    for i, code in enumerate(codes):
        text = (tmp_path / f"g{i}.out").read_text()
        assert code == 0, text
        redo_gaps = [line for line in text.splitlines() if line.startswith("  REDO") and "gap:" in line]
        assert redo_gaps == [], text
        assert "39 trial(s): " in text and ", 0 without a result" in text, text
        assert "parameters: complete (Browser)" in text, text
        replay = subprocess.run(
            _bike_rig("replay", f"g{i}/bag", "--json"), cwd=tmp_path, capture_output=True, text=True, timeout=120
        )
        assert replay.returncode == 0, replay.stderr
        result = json.loads(replay.stdout)
        assert result["complete"] and result["live"]["compared_trials"] == 39, replay.stdout
        assert result["live"]["identical"], result["live"]
