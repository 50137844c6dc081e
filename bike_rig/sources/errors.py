"""Errors of the gyro sources.

A bad configuration, a missing library or driver, a trial request the source cannot honour, or
a failure while reading.

Every message says what (the parameter or file), where (the source and the value or path) and
why, in one line, so that a node can end with that line and exit status 2.
"""

from __future__ import annotations

from ..config.settings import parameter_message
from ..core.errors import BikeRigError

__all__ = [
    "SourceConfigError",
    "SourceError",
    "SourceIOError",
    "SourceUnavailableError",
    "TrialRequestError",
]


class SourceError(BikeRigError):
    """Base class of every error a gyro source raises on purpose."""


class SourceConfigError(SourceError):
    """A source parameter is missing, malformed or impossible.

    Args:
        source: The source's name (``sim``, ``can``, ``bag``, ``daq``).
        parameter: The offending parameter (a node parameter name).
        reason: Why it cannot be used.
        value: The value given, if it helps (shown with ``repr``).
        where: What is configured, if not ``"<source> source"``; "" for nothing (a node's own
            parameter, which the node's name already introduces).
    """

    def __init__(self, source: str, parameter: str, reason: str, value: object = None, where: str | None = None):
        """Build the one-line message ``<source> source: parameter '<name>' [= value]: reason``."""
        self.source = source
        self.parameter = parameter
        self.reason = reason
        self.value = value
        prefix = f"{source} source: " if where is None else (f"{where}: " if where else "")
        super().__init__(prefix + parameter_message(parameter, reason, value))


class SourceUnavailableError(SourceConfigError):
    """The library or the driver a backend needs is not installed (or the hardware is absent)."""


class TrialRequestError(SourceError):
    """A start or stop request that the source cannot honour.

    A trial is already running, the source walks its own plan, an unknown part... Reported to
    the service caller.
    """


class SourceIOError(SourceError):
    """Reading the source failed while it was running (a file vanished, the bus went down)."""
