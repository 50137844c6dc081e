"""Simulated rides of the Browser with the paper's rider and the balance assist, made as a user makes them."""

from __future__ import annotations

from pathlib import Path

from bike_rig.config.paths import config_dir
from test.support.cli import run_cli

#: The Browser's measurement file and the balance assist's controller file.
BROWSER = str(config_dir() / "bicycles" / "browser.yaml")
ASSIST = str(config_dir() / "feedback" / "balance_assist.yaml")


def simulate_ride(out: Path, speed: float, duration_s: float, seed: int | None = None) -> Path:
    """``bike-rig ride simulate`` of the Browser, the paper's rider and the assist into ``out`` (output captured).

    Args:
        out: The record to write (``.csv``, else a bag directory).
        speed: Forward speed, m/s.
        duration_s: Length of the ride, s.
        seed: The simulation's seed (the command's default if None).
    """
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--feedback", ASSIST]
    argv += ["--speed", f"{speed:g}", "--duration", f"{duration_s:g}", "-o", str(out)]
    argv += [] if seed is None else ["--seed", str(seed)]
    code, _, err = run_cli(*argv)
    assert code == 0, err
    return out
