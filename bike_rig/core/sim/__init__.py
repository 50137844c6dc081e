"""The simulated measurement rig: the paper's physics inverted.

From a bicycle's true parameters and a rig description (``config/rig.yaml``), a whole session
as the paper performs it (sections 6–9), reproducible from one seed: :mod:`.rig` (the rig file),
:mod:`.plan` (periods measured, trial names), :mod:`.physics` (true readings), :mod:`.gyro`
(motion, gyro, ADC), :mod:`.pendulum` (dry friction, finite swing), :mod:`.session`
(:func:`simulate_session`, :class:`TrialSimulator`), :mod:`.writer` (:func:`write_session`).
"""

from __future__ import annotations

from .errors import RigFileError, SimulationError
from .rig import RigConfig, load_rig
from .session import SimulatedSession, SimulatedTrial, TrialSimulator, load_true_parameters, simulate_session
from .writer import write_session

__all__ = [
    "RigConfig",
    "RigFileError",
    "SimulatedSession",
    "SimulatedTrial",
    "SimulationError",
    "TrialSimulator",
    "load_rig",
    "load_true_parameters",
    "simulate_session",
    "write_session",
]
