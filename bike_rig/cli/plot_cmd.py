"""``bike-rig plot``: placeholder, being built (issue 5)."""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_parser"]


def run(args: argparse.Namespace) -> int:
    """Not built yet."""
    raise NotImplementedError("bike-rig plot is being built")


def add_parser(sub: Any) -> None:
    """Register ``bike-rig plot``."""
    q = sub.add_parser("plot", help="(being built)")
    q.set_defaults(func=run)
