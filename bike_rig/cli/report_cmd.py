"""``bike-rig report``: placeholder, being built (issue 5)."""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_parser"]


def run(args: argparse.Namespace) -> int:
    """Not built yet."""
    raise NotImplementedError("bike-rig report is being built")


def add_parser(sub: Any) -> None:
    """Register ``bike-rig report``."""
    q = sub.add_parser("report", help="(being built)")
    q.set_defaults(func=run)
