"""Small simulated sessions for the source and node tests (short trials, one per period)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from bike_rig.config.paths import config_file
from bike_rig.core.sim import (
    SimulatedSession,
    load_rig,
    load_true_parameters,
    simulate_session,
    write_session,
)
from bike_rig.sources import (
    RigClock,
    open_source,
)
from bike_rig.sources.sim_operator import OperatorSimSource

#: Duration of every trial of the small rig, s.
TRIAL_S = 6.0
BICYCLE = config_file("bicycles/benchmark.yaml")


def small_rig(directory: Path, duration_s: float = TRIAL_S, **trials: Any) -> Path:
    """A rig file like ``config/rig.yaml`` with one short trial per period and no beating."""
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, "duration": duration_s, **trials})
    data.pop("coupled_swing", None)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "rig_small.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def small_session(directory: Path, seed: int = 3) -> tuple[SimulatedSession, Path]:
    """A small session simulated and written to ``directory/session``; (session, session.yaml)."""
    name, truth = load_true_parameters(BICYCLE)
    session = simulate_session(truth, load_rig(small_rig(directory)), seed, name)
    return session, write_session(session, directory / "session", volts=True)


START_NS = 1_700_000_000_123_456_789


def operator_source(tmp_path: Path, clock: RigClock, seed: int = 3, pause_s: float = 0.5) -> OperatorSimSource:
    """The benchmark bicycle on the small rig (6 s trials), in operator mode, on ``clock``."""
    source = open_source(
        "sim",
        mode="operator",
        bicycle=str(BICYCLE),
        rig=str(small_rig(tmp_path)),
        seed=seed,
        pause_between_trials_s=pause_s,
    )
    assert isinstance(source, OperatorSimSource)
    source.clock = clock
    return source
