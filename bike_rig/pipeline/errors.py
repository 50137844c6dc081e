"""Errors of the pipeline stages."""

from __future__ import annotations

from ..core.errors import BikeRigError

__all__ = ["AssemblyError", "FlagCodeError", "PipelineError"]


class PipelineError(BikeRigError):
    """A stage's input cannot be used."""


class FlagCodeError(PipelineError):
    """A trial result names a quality flag code that is not a ``FlagCode``."""


class AssemblyError(PipelineError):
    """A period estimate that cannot be used (unknown measurement key or flag code)."""
