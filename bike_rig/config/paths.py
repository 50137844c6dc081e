"""Where bike_rig's shipped configuration lives (source tree or installed share directory)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["config_dir", "config_file", "resolve_shipped"]


def config_dir() -> Path:
    """The ``config/`` folder: ``$BIKE_RIG_CONFIG``, else the source tree's, else the installed one."""
    env = os.environ.get("BIKE_RIG_CONFIG")
    candidates = [Path(env)] if env else []
    candidates += [
        Path(__file__).resolve().parents[2] / "config",
        Path(sys.prefix) / "share" / "bike_rig" / "config",
    ]
    for c in candidates:
        if (c / "bicycles").is_dir():
            return c
    return candidates[-1]


def config_file(relative: str) -> Path:
    """A file under :func:`config_dir`, e.g. ``bicycles/browser.yaml``."""
    return config_dir() / relative


def resolve_shipped(spec: str, folder: str) -> str:
    """``spec`` as given when it exists, else the shipped example file it names, else ``spec``.

    A bare name (``browser``, ``balance_assist``, with or without ``.yaml``) names
    ``config/<folder>/<name>.yaml``; a path ending in ``config/<folder>/<file>`` (as the
    manual writes it) names that shipped file, so the examples work from any folder. What
    exists in the working folder always wins.

    Args:
        spec: What the user typed.
        folder: The shipped folder for this kind of input, e.g. ``bicycles`` or ``feedback``.
    """
    if not spec or Path(spec).exists():
        return spec
    p = Path(spec)
    parts = p.parts
    if len(parts) == 1:
        name = p.name if p.suffix in (".yaml", ".yml") else f"{p.name}.yaml"
        candidate = config_dir() / folder / name
    elif len(parts) >= 3 and parts[-3] == "config" and parts[-2] == folder:
        candidate = config_dir() / folder / parts[-1]
    else:
        return spec
    return str(candidate) if candidate.is_file() else spec
