"""What several ``bike-rig`` commands share: writing their output, and reading a rider or a feedback."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import BikeRigError, InputFileError
from ..core.feedback import Feedback, resolve_feedback
from ..core.rider import AnyRider, resolve_rider

__all__ = ["UsageError", "emit", "feedback_from_spec", "rider_from_spec"]


class UsageError(BikeRigError):
    """A command-line argument is invalid."""


def emit(text: str, output: str | None) -> None:
    """Print ``text``, or write it (with a final newline) to the file ``output``.

    Raises:
        InputFileError: ``output`` cannot be written.
    """
    if output:
        try:
            Path(output).write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise InputFileError(output, f"cannot write ({exc.strerror})") from None
    else:
        print(text)


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
