"""Faults in a live session.

The fitter and the parameter node are killed (SIGTERM, the default of ``kill``) and restarted
mid-session, and the session still completes with the same results as the offline core. (A
SIGKILLed reader stays matched in DDS until its lease expires; a new fitter started meanwhile
was seen, once in a few runs, to receive nothing. The recorder's SIGKILL case is ``test/bag``'s
recover test.)

A restarted fitter gets the session's trial events and the gyro batches still in the
transient-local history (``bike_rig.config.topics``) and re-fits the trial in progress; a restarted
parameter node gets every period estimate again.
"""

from __future__ import annotations

import functools
import os
import signal
from pathlib import Path

import pytest
import yaml

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.ros.demo import run_demo
from bike_rig.ros.running import RunningGraph
from test.support.wait import wait_until

pytestmark = pytest.mark.ros  # a whole graph of node processes (run_demo)


def _short_rig(tmp: Path) -> Path:
    rig = yaml.safe_load(config_file("rig.yaml").read_text())
    rig["trials"]["duration"] = 15
    rig.pop("coupled_swing", None)
    path = tmp / "rig.yaml"
    path.write_text(yaml.safe_dump(rig))
    return path


def test_fitter_and_parameter_node_restarted_mid_session(tmp_path: Path) -> None:
    killed: list[tuple[str, int]] = []

    def ended(running: RunningGraph, name: str) -> bool:
        return name in {n for n, _, _ in running.dead()}

    def inject(running: RunningGraph, fitted: int) -> None:
        for name, at in (("fitter", 8), ("parameter", 20)):
            if fitted >= at and name not in {n for n, _ in killed}:
                os.kill(running.pid(name), signal.SIGTERM)
                wait_until(functools.partial(ended, running, name), f"the SIGTERMed {name} to end", interval_s=0.01)
                running.restart(name)
                killed.append((name, fitted))

    out = tmp_path / "session"
    result = run_demo(
        out,
        seed=9,
        time_scale=50.0,
        samples_per_batch=50,
        timeout_s=150,
        progress=lambda _line: None,
        rig=_short_rig(tmp_path),
        on_progress=inject,
    )
    assert [n for n, _ in killed] == ["fitter", "parameter"]
    assert result.periods == 39 and result.invalid == {}
    offline = compute_parameters(load_measurements(out / "session" / "session.yaml")).parameters
    ps = result.session.parameters
    assert ps is not None
    for name in PARAMETER_NAMES:
        assert ps.parameters.value(name) == pytest.approx(offline.value(name), rel=1e-12, abs=0), name
