"""A ride record and its CSV reader.

A record is a plain time series: the sample times [s], the signal (the roll rate [rad/s],
or whatever column is chosen), and optionally the forward (wheel) speed [m/s] and the steer
torque [N m] at the same times. A CSV file has one header line naming its columns; the time column
holds seconds (``12.34``) or ISO 8601 timestamps (``2024-05-01T10:00:00.120``), which become
seconds from the first sample.

Default columns (each may be named by option instead): time ``time``, ``t``, ``time_s`` or
``timestamp``; signal ``roll_rate``, ``gyro_x`` or ``angular_velocity_x``; speed ``speed``,
``speed_mps`` or ``wheel_speed``; steer torque ``steer_torque`` (all optional but time and signal).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from datetime import datetime
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import InputFileError
from ..safe_yaml import NotRegularFileError, open_regular_file

__all__ = [
    "SIGNAL_COLUMNS",
    "SPEED_COLUMNS",
    "TIME_COLUMNS",
    "TORQUE_COLUMNS",
    "RideDataError",
    "RideRecord",
    "read_ride_csv",
]

FloatArray = NDArray[np.float64]

#: Time columns tried in turn when none is named.
TIME_COLUMNS = ("time", "t", "time_s", "timestamp")
#: Signal (roll rate) columns tried in turn when none is named.
SIGNAL_COLUMNS = ("roll_rate", "gyro_x", "angular_velocity_x")
#: Speed columns tried in turn when none is named.
SPEED_COLUMNS = ("speed", "speed_mps", "wheel_speed")
#: Steer torque columns tried in turn when none is named.
TORQUE_COLUMNS = ("steer_torque",)


class RideDataError(InputFileError):
    """A ride record cannot be read: the file, line and column, and why."""


@dataclass(frozen=True)
class RideRecord:
    """One ride record.

    Attributes:
        source: The file (or bag) it came from, as the user named it.
        times: Sample times [s] from the first sample, increasing.
        signal: The signal fitted, e.g. the roll rate [rad/s].
        signal_name: The signal's column (or topic and field).
        speed: Forward (wheel) speed at every sample [m/s], or None.
        torque: Steer torque at every sample [N m], or None.
        notes: What was done to the record as read (samples left out), for the user.
    """

    source: str
    times: FloatArray
    signal: FloatArray
    signal_name: str = "roll_rate"
    speed: FloatArray | None = None
    torque: FloatArray | None = None
    notes: tuple[str, ...] = ()

    def finite(self) -> RideRecord:
        """The record without the samples whose signal is not a number (NaN, ±inf), and a note of them.

        Segments are found and fitted across the gap left (the fits take uneven times); a
        record whose every sample is finite is returned as it is.

        Raises:
            RideDataError: Fewer than two samples are numbers.
        """
        good = np.isfinite(self.signal)
        if bool(np.all(good)):
            return self
        numbers = int(np.sum(good))
        if numbers < 2:
            reason = f"{numbers} of {good.size} samples of {self.signal_name} are numbers: a record needs two"
            raise RideDataError(self.source, reason)
        bad = np.flatnonzero(~good)
        spans = int(np.sum(np.diff(bad) > 1)) + 1
        note = (
            f"{bad.size} samples of {self.signal_name} are not numbers (NaN or inf) between "
            f"{self.times[bad[0]]:.3f} and {self.times[bad[-1]]:.3f} s ({spans} gap{'s' if spans > 1 else ''}): "
            "left out, the segments span the gaps"
        )
        return replace(
            self,
            times=self.times[good],
            signal=self.signal[good],
            speed=None if self.speed is None else self.speed[good],
            torque=None if self.torque is None else self.torque[good],
            notes=(*self.notes, note),
        )

    def mean_speed(self, start: float = -math.inf, stop: float = math.inf) -> float:
        """The mean of the speed column between ``start`` and ``stop`` [s] (NaN without one) [m/s]."""
        if self.speed is None:
            return math.nan
        inside = (self.times >= start) & (self.times <= stop) & np.isfinite(self.speed)
        return float(np.mean(self.speed[inside])) if np.any(inside) else math.nan


def _pick(header: Sequence[str], named: str | None, defaults: Sequence[str], path: str, what: str) -> int | None:
    """The position of the column ``named`` (or of the first default present), or None."""
    cols = [h.strip() for h in header]
    if named is not None:
        if named not in cols:
            raise RideDataError(path, f"no {what} column '{named}' (columns: {', '.join(cols)})", line=1)
        return cols.index(named)
    for name in defaults:
        if name in cols:
            return cols.index(name)
    return None


def _time_value(text: str, origin: list[datetime]) -> float:
    """A time cell as seconds: a number, or an ISO 8601 timestamp (seconds from the first, ``origin``).

    Raises:
        ValueError: Neither (or a timestamp with a time zone where the first had none, or back).
    """
    try:
        return float(text)
    except ValueError:
        stamp = datetime.fromisoformat(text.strip())
        if not origin:
            origin.append(stamp)
        try:
            return (stamp - origin[0]).total_seconds()  # exact to the microsecond
        except TypeError:
            raise ValueError("a timestamp with a time zone mixed with ones without") from None


def _columns(rows: list[list[str]], cols: dict[str, int], path: str) -> tuple[dict[str, list[float]], list[int]]:
    """The chosen columns' numbers (time: seconds) and the line of each data row."""
    header = rows[0]
    values: dict[str, list[float]] = {k: [] for k in cols}
    lines: list[int] = []
    origin: list[datetime] = []
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        for key, c in cols.items():
            name = header[c].strip()
            if c >= len(row):
                raise RideDataError(path, f"{len(row)} cells, no column '{name}'", line=line)
            try:
                x = _time_value(row[c], origin) if key == "time" else float(row[c])
            except ValueError:
                raise RideDataError(path, f"column '{name}': {row[c]!r} is not a number", line=line) from None
            values[key].append(x)
        lines.append(line)
    return values, lines


def read_ride_csv(
    path: str | Path,
    signal: str | None = None,
    time: str | None = None,
    speed: str | None = None,
    torque: str | None = None,
) -> RideRecord:
    """Read a ride record from a CSV file (module docstring for the columns).

    Args:
        path: The CSV file.
        signal: The signal column (default: the first of :data:`SIGNAL_COLUMNS`).
        time: The time column, seconds or ISO 8601 timestamps (default: :data:`TIME_COLUMNS`).
        speed: The speed column [m/s] (default: :data:`SPEED_COLUMNS` if present).
        torque: The steer torque column [N m] (default: :data:`TORQUE_COLUMNS` if present).

    Raises:
        RideDataError: Missing file or column, a cell that is not a number (file, line,
            column), times that do not increase, fewer than two rows.
    """
    p = str(path)
    try:
        raw = open_regular_file(p, path)  # a FIFO, a device or a symlink loop is named, never read
    except NotRegularFileError as exc:
        raise RideDataError(p, exc.reason) from None
    try:
        with io.TextIOWrapper(raw, encoding="utf-8", newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise RideDataError(p, f"cannot be read as CSV ({exc})") from None
    if not rows:
        raise RideDataError(p, "empty file: a header line naming the columns is expected")
    header = rows[0]
    t_col = _pick(header, time, TIME_COLUMNS, p, "time")
    y_col = _pick(header, signal, SIGNAL_COLUMNS, p, "signal")
    for col, what, names in ((t_col, "time", TIME_COLUMNS), (y_col, "signal", SIGNAL_COLUMNS)):
        if col is None:
            raise RideDataError(p, f"no {what} column: name one by option, or use one of {', '.join(names)}", line=1)
    assert t_col is not None and y_col is not None
    v_col = _pick(header, speed, SPEED_COLUMNS, p, "speed")
    q_col = _pick(header, torque, TORQUE_COLUMNS, p, "steer torque")
    cols = {"time": t_col, "signal": y_col, "speed": v_col, "torque": q_col}
    values, lines = _columns(rows, {k: c for k, c in cols.items() if c is not None}, p)
    t = np.asarray(values["time"], dtype=float)
    if t.size < 2:
        raise RideDataError(p, f"{t.size} data rows: a record needs at least two")
    if not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0):
        bad = int(np.flatnonzero(~(np.isfinite(t[1:]) & (np.diff(t) > 0)))[0]) + 1
        raise RideDataError(p, f"column '{header[t_col].strip()}': the times do not increase", line=lines[bad])
    return RideRecord(
        source=p,
        times=t - t[0],
        signal=np.asarray(values["signal"], dtype=float),
        signal_name=header[y_col].strip(),
        speed=np.asarray(values["speed"], dtype=float) if "speed" in values else None,
        torque=np.asarray(values["torque"], dtype=float) if "torque" in values else None,
    )
