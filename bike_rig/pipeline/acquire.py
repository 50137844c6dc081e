"""Acquisition, the first stage: what the driver announces and streams, as plain records.

A trial is announced by a START event, streamed as batches of gyro samples and closed by a
STOP (or ABORT) event. The driver node publishes these as ``TrialEvent`` and ``GyroBatch``
messages; :mod:`bike_rig.messages` converts them to and from the records here, which is all
the later stages (fitting, assembly, the offline runner) read. Times are rig time in integer
nanoseconds since the epoch; rates in Hz; gyro samples in rad/s (``raw_volts`` in V).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from functools import cached_property
from typing import overload

import numpy as np
from numpy.typing import NDArray

__all__ = ["NS_PER_S", "SampleBatch", "SampleBlock", "TrialEventKind", "TrialEventRecord", "sample_stamp_ns"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

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


@dataclass(frozen=True, eq=False)
class SampleBlock(Sequence[SampleBatch]):
    """One trial's batches in receiving order, held as columns (a recording read at once).

    It is the sequence of its :class:`SampleBatch` records (made when first asked for); the
    fitting stage takes the columns at once when it can
    (:meth:`~bike_rig.pipeline.fit.TrialAccumulator.add_block`).

    Attributes:
        trial_id: The trial (every batch's).
        first_index: Each batch's first sample index.
        sample_rate_hz: Each batch's sample rate, Hz.
        bounds: Where each batch's samples start in ``rates``, then where the last one ends.
        rates: The samples, rad/s (a batch's are ``rates[bounds[i]:bounds[i + 1]]``).
        volts: Reads the raw volts when first asked for (a replay never asks): where each
            batch's start in them (then the end) and the volts, V (:attr:`volt_bounds`,
            :attr:`raw_volts`).
        stamp_ns: Each batch's rig time of its first sample, ns.
        frame_ids: The distinct header frame ids.
        frame: Each batch's frame id (index into ``frame_ids``).
    """

    trial_id: str
    first_index: IntArray
    sample_rate_hz: FloatArray
    bounds: IntArray
    rates: FloatArray = field(repr=False)
    volts: Callable[[], tuple[IntArray, FloatArray]] = field(repr=False)
    stamp_ns: IntArray = field(repr=False)
    frame_ids: tuple[str, ...] = field(repr=False)
    frame: IntArray = field(repr=False)

    @cached_property
    def _volt_columns(self) -> tuple[IntArray, FloatArray]:
        return self.volts()

    @property
    def volt_bounds(self) -> IntArray:
        """Where each batch's raw volts start in :attr:`raw_volts`, then the end."""
        return self._volt_columns[0]

    @property
    def raw_volts(self) -> FloatArray:
        """The raw volts of every batch, one after the other, V."""
        return self._volt_columns[1]

    def __len__(self) -> int:
        """Number of batches."""
        return len(self.first_index)

    @overload
    def __getitem__(self, i: int) -> SampleBatch: ...
    @overload
    def __getitem__(self, i: slice) -> Sequence[SampleBatch]: ...
    def __getitem__(self, i: int | slice) -> SampleBatch | Sequence[SampleBatch]:
        """The batch(es) at ``i``."""
        return self.batches()[i]

    def __iter__(self) -> Iterator[SampleBatch]:
        """The batches, in receiving order."""
        return iter(self.batches())

    def batches(self) -> list[SampleBatch]:
        """The batches as records (their arrays are views of the columns; made once)."""
        made: list[SampleBatch] | None = self.__dict__.get("_batches")
        if made is None:
            b, v = self.bounds.tolist(), self.volt_bounds.tolist()
            columns = (self.first_index, self.sample_rate_hz, self.stamp_ns, self.frame)
            made = [
                SampleBatch(self.trial_id, f, r, self.rates[b[i] : b[i + 1]], self.raw_volts[v[i] : v[i + 1]], s, fid)
                for i, (f, r, s, fid) in enumerate(
                    zip(
                        *(c.tolist() for c in columns[:3]),
                        (self.frame_ids[c] for c in self.frame.tolist()),
                        strict=True,
                    )
                )
            ]
            object.__setattr__(self, "_batches", made)
        return made


def sample_stamp_ns(start_ns: int, index: int, sample_rate_hz: float) -> int:
    """Rig time of sample ``index`` of a trial whose first sample is at ``start_ns``, ns."""
    return start_ns + round(index * NS_PER_S / sample_rate_hz)
