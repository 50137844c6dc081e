"""Simulated sessions shared by the tests (the paper's rig, shorter trials)."""

from __future__ import annotations

import dataclasses

from bike_rig.config.paths import config_file
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session


def short_session(seed: int = 7, duration_s: float = 12.0) -> SimulatedSession:
    """The Browser measured on the paper's rig, with shorter trials (still ≥ 8 cycles each)."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    rig = load_rig(config_file("rig.yaml"))
    rig = dataclasses.replace(rig, trials=dataclasses.replace(rig.trials, durations=(duration_s,)))
    return simulate_session(truth, rig, seed=seed, bicycle=name)
