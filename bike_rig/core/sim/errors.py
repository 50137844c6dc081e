"""Errors of the simulated rig: a bad rig file, or a bicycle the rig cannot measure."""

from __future__ import annotations

from ..errors import BikeRigError, InputFileError

__all__ = ["RigFileError", "SimulationError"]


class RigFileError(InputFileError):
    """A rig description (``config/rig.yaml``) is unreadable, incomplete or impossible."""


class SimulationError(BikeRigError):
    """The true parameters cannot be measured on this rig.

    E.g. a wheel smaller than its pendulum arm, or an inertia tensor that is not positive definite.
    """
