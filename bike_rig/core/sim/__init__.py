"""The simulated measurement rig: the paper's physics inverted.

From a bicycle's true benchmark parameters and a rig description (``config/rig.yaml``),
generate a whole measurement session as the paper performs it (sections 6–9): static
readings with their noise, and every pendulum trial as a gyro signal through the sensor and
ADC model. Reproducible from one seed.

- :mod:`.rig`: the rig description and its file
- :mod:`.plan`: which periods a session measures and how its trials are named
- :mod:`.physics`: the inverse of the paper's equations (true readings)
- :mod:`.gyro`: the pendulum motion, the gyro and the ADC
- :mod:`.pendulum`: a real pendulum's motion (dry friction, finite swing), integrated
- :mod:`.session`: a whole session in memory (:func:`simulate_session`), or trial by trial on
  request (:class:`TrialSimulator`)
- :mod:`.writer`: a session directory on disk (:func:`write_session`)
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
