"""Gyro sources: one interface (:class:`~bike_rig.sources.base.GyroSource`), backends by name.

``open_source("sim", session=..., time_scale=20.0)`` opens a backend; :func:`drain` yields its
events (``TrialStarted``, ``SampleBlock``..., ``TrialStopped``). Backends: ``sim`` (the simulated
rig, :mod:`.sim`, :mod:`.sim_operator`), ``can`` (python-can), ``bag`` (a recorded session),
``daq`` (NI-DAQmx, optional). Each owns its ``PARAMETERS``, which the driver declares; adding
one is a module and a line in :data:`BACKENDS` (``docs/code.md``). Errors: :mod:`.errors`.
No module here imports rclpy.
"""

from __future__ import annotations

from .base import (
    BACKENDS,
    GyroSource,
    RigClock,
    SampleBlock,
    SourceEvent,
    StreamingSource,
    TrialInfo,
    TrialRequest,
    TrialStarted,
    TrialStopped,
    backend_parameters,
    drain,
    open_source,
    source_class,
)
from .errors import SourceConfigError, SourceError, SourceIOError, SourceUnavailableError, TrialRequestError

__all__ = [
    "BACKENDS",
    "GyroSource",
    "RigClock",
    "SampleBlock",
    "SourceConfigError",
    "SourceError",
    "SourceEvent",
    "SourceIOError",
    "SourceUnavailableError",
    "StreamingSource",
    "TrialInfo",
    "TrialRequest",
    "TrialRequestError",
    "TrialStarted",
    "TrialStopped",
    "backend_parameters",
    "drain",
    "open_source",
    "source_class",
]
