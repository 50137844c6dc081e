"""Ride records (CSV file or bag) → their free-decay segments and measured eigenvalues.

The one place that opens a ride record of either kind (:func:`load_record`) and measures it
(:func:`measure_records`), for ``bike-rig ride`` and the report's ride section. A record is a
bag when it is a directory or a ``.mcap`` file, else a CSV file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from ..core.errors import BikeRigError
from ..core.ride.eigen import MeasuredEigenvalue, fit_segment, pool_drive
from ..core.ride.injection import inject_segments
from ..core.ride.record import RideRecord, read_ride_csv
from ..core.ride.segment import Kick, Segment, Segmentation, segment_record, unconfirmed_flag

__all__ = [
    "WHOLE_BELOW_S",
    "MeasuredSegment",
    "RecordOptions",
    "RideOptionError",
    "fit_segments",
    "load_record",
    "measure_records",
]

#: ``segments="auto"``: records shorter than this are one segment [s].
WHOLE_BELOW_S = 5.0


class RideOptionError(BikeRigError):
    """A ride record option is invalid (e.g. a negative speed)."""


@dataclass(frozen=True)
class RecordOptions:
    """How records are read and segmented (the record options of ``bike-rig ride``).

    Attributes:
        signal: CSV signal column (None: the defaults).
        time: CSV time column.
        speed: Speed of every record [m/s] (None: the speed column or topic).
        speed_column: CSV speed column.
        torque_column: CSV steer torque column.
        topic: Bag: the signal's topic (None: the first ``sensor_msgs/Imu``).
        field: Bag: the signal's field.
        speed_topic: Bag: a topic with the speed [m/s].
        torque_topic: Bag: a topic with the steer torque [N m].
        segments: ``whole``, ``find`` or ``auto`` (whole below :data:`WHOLE_BELOW_S`).
        model: The segment model (:data:`bike_rig.core.ride.eigen.MODELS`).
    """

    signal: str | None = None
    time: str | None = None
    speed: float | None = None
    speed_column: str | None = None
    torque_column: str | None = None
    topic: str | None = None
    field: str = "angular_velocity.x"
    speed_topic: str | None = None
    torque_topic: str | None = None
    segments: str = "auto"
    model: str = "auto"


@dataclass(frozen=True)
class MeasuredSegment:
    """One segment: its eigenvalue, where it lies, and its record."""

    eigenvalue: MeasuredEigenvalue
    segment: Segment
    record: RideRecord


def load_record(path: str, options: RecordOptions) -> RideRecord:
    """A CSV file or a bag, read with ``options``, without its non-finite samples (noted).

    Raises:
        RideDataError: A bad CSV file. BagError: a bad bag.
    """
    p = Path(path)
    if p.is_dir() or p.suffix.lower() == ".mcap":
        from ..bag.ride import read_ride_bag

        record = read_ride_bag(
            path, options.topic, options.field, options.speed_topic, torque_topic=options.torque_topic
        )
    else:
        record = read_ride_csv(path, options.signal, options.time, options.speed_column, options.torque_column)
    return record.finite()


def _found(record: RideRecord, mode: str) -> Segmentation | None:
    """The record's segmentation, or None where it is one segment whole (``mode``)."""
    first, last = float(record.times[0]), float(record.times[-1])
    if mode == "whole" or (mode == "auto" and last - first < WHOLE_BELOW_S):
        return None
    return segment_record(record)


def _whole(record: RideRecord) -> Segment:
    """The whole record as one segment."""
    first, last = float(record.times[0]), float(record.times[-1])
    return Segment(first, last, Kick(first, first, "a stored free decay"), "the record's start", "its end")


def fit_segments(
    record: RideRecord,
    segments: Sequence[Segment],
    *,
    found: bool,
    model: str = "auto",
    speed: float | None = None,
    source: str | None = None,
) -> list[MeasuredEigenvalue]:
    """Each segment of ``record`` fitted, numbered from 1 (:func:`~bike_rig.core.ride.eigen.fit_segment`).

    Its speed is ``speed`` [m/s] or the record's mean over it; its source ``source`` or the
    record's. A segment ``found`` by the segmenter whose kick only the roll rate shows is flagged
    (:func:`~bike_rig.core.ride.segment.unconfirmed_flag`).
    """
    out = []
    for k, seg in enumerate(segments, start=1):
        inside = (record.times >= seg.start) & (record.times <= seg.stop)
        m = fit_segment(
            record.times[inside],
            record.signal[inside],
            speed=speed if speed is not None else record.mean_speed(seg.start, seg.stop),
            source=source if source is not None else record.source,
            index=k,
            model=model,
        )
        flag = unconfirmed_flag(seg, record) if found else None
        out.append(m if flag is None else replace(m, flags=(*m.flags, flag)))
    return out


def measure_records(paths: Sequence[str], options: RecordOptions) -> list[MeasuredSegment]:
    """Every record's segments fitted, in order, their σ with the rider's drive shared at each speed.

    Segments found in a record then get their bias and σ from the record's own riding injected
    into their fitted decay (:mod:`bike_rig.core.ride.injection`; none where it has too little).

    Raises:
        RideOptionError: A negative or non-finite speed.
        RideDataError, BagError: A record cannot be read.
    """
    if options.speed is not None and not (math.isfinite(options.speed) and options.speed >= 0):
        raise RideOptionError(f"--speed must be a finite speed >= 0 m/s, got {options.speed}")
    out: list[MeasuredSegment] = []
    found_in: list[tuple[range, Segmentation]] = []  # a record's found segments, by position in out
    for path in paths:
        record = load_record(path, options)
        found = _found(record, options.segments)
        segments = found.segments if found is not None else (_whole(record),)
        first = len(out)
        fitted = fit_segments(
            record, segments, found=found is not None, model=options.model, speed=options.speed, source=path
        )
        out += [MeasuredSegment(m, seg, record) for m, seg in zip(fitted, segments, strict=True)]
        if found is not None and len(out) > first:
            found_in.append((range(first, len(out)), found))
    pooled = pool_drive([m.eigenvalue for m in out])  # the rider's drive shared at each speed
    measured = [MeasuredSegment(e, m.segment, m.record) for e, m in zip(pooled, out, strict=True)]
    for idx, segmentation in found_in:  # their bias and σ from their record's own riding
        record = out[idx.start].record
        done = inject_segments(record, segmentation, [measured[i].eigenvalue for i in idx], options.model)
        for i, e in zip(idx, done, strict=True):
            measured[i] = MeasuredSegment(e, out[i].segment, record)
    return measured
