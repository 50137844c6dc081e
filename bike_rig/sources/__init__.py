"""Gyro sources: one interface (:class:`~bike_rig.sources.base.GyroSource`), backends by name.

Python-can style::

    from bike_rig.sources import open_source, drain
    with open_source("sim", session="run1/session.yaml", time_scale=20.0) as source:
        for event in drain(source):       # TrialStarted, SampleBlock..., TrialStopped, ...
            ...

* ``sim`` (:mod:`.sim`): the simulated rig walking a session plan (a ``session.yaml`` written
  by ``bike-rig simulate``, or simulated in memory from a bicycle, a rig and a seed), or with
  ``mode`` ``operator`` simulating each trial requested (:mod:`.sim_operator`);
* ``can`` (:mod:`.can`): a CAN gyro through python-can; trials on request;
* ``bag`` (:mod:`.bag`): a recorded session's gyro stream and trial events, from a rosbag2 bag;
* ``daq`` (:mod:`.daq`): an NI-DAQmx analog input (optional ``nidaqmx``); trials on request.

Each backend owns its parameters: its class's ``PARAMETERS`` (:class:`bike_rig.config.settings.ParamSpec`:
name, default, description, range, choices) are what the driver node declares
(:func:`backend_parameters`) and what its ``from_parameters`` reads and checks
(:class:`~bike_rig.sources.base.Parameters`). Adding a gyro source is one module and one line:

1. ``bike_rig/sources/<name>.py``: a :class:`GyroSource` subclass (:class:`StreamingSource` for
   hardware that streams continuously) with ``name = "<name>"``, ``PARAMETERS`` (new names
   prefixed ``<name>_``; shared ones such as ``base.TIME_SCALE`` or ``base.SAMPLE_RATE``
   reused, not repeated), ``from_parameters`` (``Parameters(cls.name, parameters,
   cls.PARAMETERS)``), ``poll`` (or ``read_available``) and ``describe``;
2. ``"<name>": "bike_rig.sources.<name>:<Class>"`` in :data:`BACKENDS`.

The driver then declares and documents its parameters and accepts ``source:=<name>``; optional
libraries are imported inside ``from_parameters``, so the module imports without them.

Errors (:mod:`.errors`): :class:`SourceConfigError` (a bad parameter: which, its value, why),
:class:`SourceUnavailableError` (a missing library or driver), :class:`TrialRequestError`,
:class:`SourceIOError`. No module here imports rclpy.
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
