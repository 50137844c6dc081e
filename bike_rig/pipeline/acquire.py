"""Acquisition, the first stage: what the driver announces and streams, as plain records.

A trial is announced by a START event, streamed as batches of gyro samples and closed by a
STOP (or ABORT) event. The driver node publishes these as ``TrialEvent`` and ``GyroBatch``
messages; :mod:`bike_rig.messages` converts them to and from the records here, which is all
the later stages (fitting, assembly, the offline runner) read. Times are rig time in integer
nanoseconds since the epoch; rates in Hz; gyro samples in rad/s (``raw_volts`` in V).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

__all__ = ["NS_PER_S", "SampleBatch", "TrialEventKind", "TrialEventRecord", "sample_stamp_ns"]

FloatArray = NDArray[np.float64]

#: Nanoseconds per second (stamps are integer ns since the epoch).
NS_PER_S = 1_000_000_000

_EMPTY = np.empty(0, dtype=np.float64)


class TrialEventKind(IntEnum):
    """A trial event's kind: the ``START``/``STOP``/``ABORT`` constants of ``TrialEvent.msg``."""

    START = 0
    STOP = 1
    ABORT = 2


@dataclass(frozen=True)
class TrialEventRecord:
    """A trial's START, STOP or ABORT (the fields of a ``TrialEvent`` message).

    Attributes:
        kind: START, STOP or ABORT.
        trial_id: Unique id of the trial within the session.
        measurement_key: The period it measures, e.g. ``"TtB2"`` ("" when unknown).
        part: The part hung (``R``, ``F``, ``B``, ``H``, ``P``).
        pendulum: ``compound`` or ``torsional``.
        orientation: Hanging orientation (1-based; 0 where none applies).
        repeat: Repeat number of this measurement.
        sample_rate_hz: The gyro's sample rate, Hz (NaN when unknown).
        sample_count: Samples streamed (STOP/ABORT; 0 on START).
        stamp_ns: Rig time: START the first sample's, STOP just after the last one, ns.
        frame_id: The header's frame id.
        note: Free text.
    """

    kind: TrialEventKind
    trial_id: str
    measurement_key: str = ""
    part: str = ""
    pendulum: str = ""
    orientation: int = 0
    repeat: int = 0
    sample_rate_hz: float = math.nan
    sample_count: int = 0
    stamp_ns: int = 0
    frame_id: str = ""
    note: str = ""

    @property
    def ends(self) -> bool:
        """A STOP or ABORT: the trial's last event."""
        return self.kind is not TrialEventKind.START


@dataclass(frozen=True)
class SampleBatch:
    """Consecutive gyro samples of one trial (the fields of a ``GyroBatch`` message).

    Attributes:
        trial_id: The trial ("" outside any trial).
        first_index: Index of the first sample within the trial.
        sample_rate_hz: Sample rate, Hz.
        rates: Angular rate, rad/s.
        raw_volts: The gyro's raw output, V (empty when the source has none).
        stamp_ns: Rig time of the first sample, ns.
        frame_id: The header's frame id.
    """

    trial_id: str
    first_index: int
    sample_rate_hz: float
    rates: FloatArray = field(repr=False)
    raw_volts: FloatArray = field(default_factory=lambda: _EMPTY, repr=False)
    stamp_ns: int = 0
    frame_id: str = ""


def sample_stamp_ns(start_ns: int, index: int, sample_rate_hz: float) -> int:
    """Rig time of sample ``index`` of a trial whose first sample is at ``start_ns``, ns."""
    return start_ns + round(index * NS_PER_S / sample_rate_hz)
