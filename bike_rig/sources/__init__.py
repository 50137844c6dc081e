"""Gyro sources: one interface (:class:`~bike_rig.sources.base.GyroSource`), backends chosen
by name, python-can style::

    from bike_rig.sources import open_source, drain
    with open_source("sim", session="run1/session.yaml", time_scale=20.0) as source:
        for event in drain(source):       # TrialStarted, SampleBlock..., TrialStopped, ...
            ...

* ``sim`` (:mod:`.sim`): the simulated rig walking a session plan (a ``session.yaml`` written
  by ``bike-rig simulate``, or simulated in memory from a bicycle, a rig and a seed);
* ``can`` (:mod:`.can`): a CAN gyro through python-can; trials on request;
* ``bag`` (:mod:`.bag`): a recorded session's gyro stream and trial events, from a rosbag2 bag;
* ``daq`` (:mod:`.daq`): an NI-DAQmx analog input (optional ``nidaqmx``); trials on request.

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
    drain,
    open_source,
    sample_stamp_ns,
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
    "drain",
    "open_source",
    "sample_stamp_ns",
    "source_class",
]
