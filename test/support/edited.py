"""Input files with one value replaced: the Browser's measurement text, the benchmark's parameter file."""

from __future__ import annotations

import re
from pathlib import Path

from bike_rig.config.paths import config_file
from test.support.paper import shared_dir

#: The benchmark bicycle's parameter file.
BENCHMARK = config_file("bicycles/benchmark.yaml")


def browser_measured() -> str:
    """BicycleParameters' BrowserMeasured.txt, as shipped in the shared data."""
    return (shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt").read_text()


def measured(tmp_path: Path, key: str, text: str) -> Path:
    """Browser's Measured.txt with one reading replaced (``key = text``), written in ``tmp_path``."""
    out, n = re.subn(rf"^{key} = .*$", f"{key} = {text}", browser_measured(), flags=re.M)
    assert n == 1
    path = tmp_path / f"{key}Measured.txt"
    path.write_text(out)
    return path


def parameter_file(tmp_path: Path, key: str, value: float) -> Path:
    """The benchmark bicycle's parameter file with one value replaced (σ 0), written in ``tmp_path``."""
    out, n = re.subn(rf"^  {key}: \[.*\]$", f"  {key}: [{value!r}, 0.0]", BENCHMARK.read_text(), flags=re.M)
    assert n == 1
    path = tmp_path / f"p_{key}.yaml"
    path.write_text(out)
    return path
