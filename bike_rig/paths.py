"""Where bike_rig's shipped configuration lives (source tree or installed share directory)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["config_dir", "config_file"]


def config_dir() -> Path:
    """The ``config/`` folder: ``$BIKE_RIG_CONFIG``, else the source tree's, else the installed one."""
    env = os.environ.get("BIKE_RIG_CONFIG")
    candidates = [Path(env)] if env else []
    candidates += [
        Path(__file__).resolve().parents[1] / "config",
        Path(sys.prefix) / "share" / "bike_rig" / "config",
    ]
    for c in candidates:
        if (c / "bicycles").is_dir():
            return c
    return candidates[-1]


def config_file(relative: str) -> Path:
    """A file under :func:`config_dir`, e.g. ``bicycles/browser.yaml``."""
    return config_dir() / relative
