"""Errors of the report."""

from __future__ import annotations

from ..core.errors import BikeRigError

__all__ = ["ReportOutputError"]


class ReportOutputError(BikeRigError):
    """The report cannot be written where it was asked to go.

    Args:
        path: The output directory or file, as given.
        reason: Why.
    """

    def __init__(self, path: str, reason: str) -> None:
        """The error: ``path`` could not be written because of ``reason``."""
        self.path = path
        self.reason = reason
        super().__init__(f"{path}: {reason}")
