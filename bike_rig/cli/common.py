"""What several ``bike-rig`` commands share: writing their output, and reading a rider or a feedback."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TextIO

from ..core.errors import BikeRigError, InputFileError
from ..core.feedback import Feedback, resolve_feedback
from ..core.rider import AnyRider, resolve_rider
from ..core.textfmt import terminal_safe

__all__ = ["UsageError", "emit", "feedback_from_spec", "rider_from_spec", "show"]


class UsageError(BikeRigError):
    """A command-line argument is invalid."""


def show(text: str, file: TextIO | None = None) -> None:
    r"""Print ``text`` (to standard output, or ``file``) with its control characters escaped.

    Newlines and tabs are kept; ESC, NUL, DEL, C1 and the other control characters that a
    name or a file may hold are written as ``\xNN`` (:func:`~bike_rig.core.textfmt.terminal_safe`).
    """
    print(terminal_safe(text), file=sys.stdout if file is None else file)


def emit(text: str, output: str | None) -> None:
    """Print ``text``, or write it (with a final newline) to the file ``output``; control characters escaped.

    JSON and YAML text is unchanged: their writers escape control characters themselves.

    Raises:
        InputFileError: ``output`` cannot be written.
    """
    if output:
        try:
            Path(output).write_text(terminal_safe(text) + "\n", encoding="utf-8")
        except OSError as exc:
            raise InputFileError(output, f"cannot write ({exc.strerror})") from None
    else:
        show(text)


def rider_from_spec(spec: str | None) -> AnyRider | None:
    """The rider named on the command line (see :func:`~bike_rig.core.rider.resolve_rider`).

    None, ``""`` or ``none`` (no rider), ``paper`` (Table 1) or a rider YAML file (a mapping of
    ``mass, x, z, Ixx, Iyy, Izz, Ixz`` in kg, m and kg m², benchmark frame, or a Yeadon rider:
    ``yeadon_measurements`` and ``yeadon_configuration``).

    Raises:
        RiderError: The rider file is missing, unreadable or lacks a number.
    """
    return resolve_rider(spec)


def feedback_from_spec(spec: str | None) -> Feedback | None:
    """The feedback named by ``--feedback`` (see :func:`~bike_rig.core.feedback.resolve_feedback`).

    None, ``""`` or ``none`` (the open loop), or a feedback YAML file (``format:
    bike_rig-feedback/1``: gains ``k_phi, k_delta, k_phidot, k_deltadot``, numbers or tables).

    Raises:
        FeedbackError: The file is missing, unreadable or invalid (file, key and line).
    """
    return resolve_feedback(spec)
