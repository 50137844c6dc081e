"""``bike-rig budget``: placeholder, being built (issue 5)."""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_parser"]


def run(args: argparse.Namespace) -> int:
    """Not built yet."""
    raise NotImplementedError("bike-rig budget is being built")


def add_parser(sub: Any) -> None:
    """Register ``bike-rig budget``."""
    q = sub.add_parser("budget", help="(being built)")
    q.set_defaults(func=run)
