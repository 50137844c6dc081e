"""How a command treats a value that a wrong unit explains: a warning line on stderr, or (``--strict``) an error.

Light to import (no numpy): :func:`bike_rig.cli.main.main` applies it before every command.
"""

from __future__ import annotations

import sys
import warnings
from typing import Any

from ..core.reading_ranges import UnitMistakeWarning
from ..core.textfmt import terminal_safe

__all__ = ["apply_unit_policy"]

#: The command whose warnings are shown (one process may run several, e.g. tests calling ``main``).
_COMMAND = ["bike-rig"]


def apply_unit_policy(command: str, strict: bool) -> None:
    """How a command treats a value a wrong unit explains (a :class:`~bike_rig.core.reading_ranges.UnitMistakeWarning`).

    By default each is one line on stderr, ``bike-rig <command>: warning: <file>:<line>: w = 1121 m
    is outside the plausible wheelbase (0.5 to 2.5 m): it looks like millimetres (w = 1.121 m)``,
    every time it is found; with ``strict`` it is an error (one line, exit status 2).
    """
    warnings.simplefilter("error" if strict else "always", UnitMistakeWarning)
    _COMMAND[0] = command
    if getattr(warnings.showwarning, "_bike_rig", False):
        return  # installed by an earlier call in this process
    previous = warnings.showwarning

    def show_warning(message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any) -> None:
        if issubclass(category, UnitMistakeWarning):
            print(f"bike-rig {_COMMAND[0]}: warning: {terminal_safe(str(message), keep='')}", file=sys.stderr)
        else:
            previous(message, category, *args, **kwargs)

    show_warning._bike_rig = True  # type: ignore[attr-defined]
    warnings.showwarning = show_warning
