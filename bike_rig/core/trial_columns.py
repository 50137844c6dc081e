"""Which columns of a trial table hold the time and the gyro signal, and the unit of the times.

:func:`choose_columns` picks the time and signal columns of a CSV or an (N, k) ``.npy``: as
``--time`` / ``--signal`` say (a :class:`ColumnChoice`: header name or 0-based index), else by
header names, else by position (one column: rate; two: time, rate). :func:`times_in_seconds`
converts the times: ``--time-unit``, else the unit in the column's name, else the one unit whose
spacing gives a plausible rate (:data:`PLAUSIBLE_RATE_HZ`) and record length
(:data:`PLAUSIBLE_DURATION_S`). :func:`check_rate_agrees` refuses a given rate that disagrees with
the times by more than :data:`RATE_AGREEMENT`. Times in s, rates in Hz; rules in ``docs/cli.md``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import InputFileError

__all__ = [
    "PLAUSIBLE_DURATION_S",
    "PLAUSIBLE_RATE_HZ",
    "RATE_AGREEMENT",
    "TIME_UNITS",
    "ColumnChoice",
    "Columns",
    "check_rate_agrees",
    "choose_columns",
    "header_time_unit",
    "is_time_name",
    "times_in_seconds",
]

FloatArray = NDArray[np.float64]

#: Time units and their length in seconds.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}

#: Gyro sample rates taken as plausible for a pendulum trial, Hz (a 0.3–3 s swing needs a few
#: samples per cycle; no rig samples a pendulum faster than 100 kHz).
PLAUSIBLE_RATE_HZ = (5.0, 100_000.0)

#: Record lengths taken as plausible when the unit is inferred, s.
PLAUSIBLE_DURATION_S = (1.0, 6 * 3600.0)

#: Largest relative difference of two sample rates of one trial taken as the same rate (1 %):
#: a DAQ's actual rate differs from the one asked for by up to some 0.1 % (its clock divides
#: into the nearest rate it can), times written to 1 ms at 300 Hz give the mean rate of a 1 s
#: record to 0.1 %; a wrong rate (500 for 1000 Hz, a unit off by 1000) is far beyond it.
RATE_AGREEMENT = 1e-2

_UNIT_WORDS: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "msecs", "millis", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "μs", "usec", "usecs", "micros", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nsecs", "nanos", "nanosecond", "nanoseconds"), "ns"),
}
_TIME_WORDS = frozenset({"t", "time", "times", "timestamp", "timestamps", "stamp", "elapsed", "clock"})
_RATE_WORDS = frozenset({"rate", "rates", "gyro", "omega", "angular", "dps"})
_SIGNAL_WORDS = _RATE_WORDS | frozenset({"signal", "volts", "volt", "voltage", "v", "raw", "adc", "rad", "deg"})


@dataclass(frozen=True)
class ColumnChoice:
    """The user's choice of columns and time unit (``--time``, ``--signal``, ``--time-unit``).

    Attributes:
        time: The time column: header name, or 0-based index; None to recognise it.
        signal: The signal column, likewise.
        time_unit: Unit of the times (a key of :data:`TIME_UNITS`); None to read it from the
            header or the spacing.
    """

    time: str | int | None = None
    signal: str | int | None = None
    time_unit: str | None = None

    @classmethod
    def from_text(cls, time: str | None, signal: str | None, time_unit: str | None) -> ColumnChoice:
        """The choice as typed on a command line: an all-digit column is an index.

        Raises:
            ValueError: An unknown time unit.
        """
        if time_unit is not None and time_unit not in TIME_UNITS:
            raise ValueError(f"time unit must be one of {', '.join(TIME_UNITS)}, got {time_unit!r}")
        return cls(_column_spec(time), _column_spec(signal), time_unit)

    @property
    def chooses_columns(self) -> bool:
        """True when a column is chosen (``time`` or ``signal`` given)."""
        return self.time is not None or self.signal is not None


def _column_spec(text: str | None) -> str | int | None:
    if text is None:
        return None
    stripped = text.strip()
    return int(stripped) if stripped.isdigit() else stripped


@dataclass(frozen=True)
class Columns:
    """The columns chosen in a table.

    Attributes:
        time: Index of the time column, None when the table has none (a sample rate is needed).
        signal: Index of the signal column.
        time_label: The time column as named in messages (``time column 'time_ms'``).
        time_unit: The unit the header or ``--time-unit`` gives the times, None if unknown.
        unit_given: True when ``time_unit`` comes from ``--time-unit`` (taken as given).
        remarks: What the choice decided that the user should know.
    """

    time: int | None
    signal: int
    time_label: str
    time_unit: str | None
    unit_given: bool
    remarks: tuple[str, ...] = ()


def _tokens(name: str) -> list[str]:
    return re.findall(r"[a-zµμ]+|\d+", name.lower())


def is_time_name(name: str) -> bool:
    """True for a column name that says time (``t``, ``time_ms``, ``Timestamp (ns)``, ``ms``)."""
    words = _tokens(name)
    if not words or _SIGNAL_WORDS.intersection(words):
        return False
    return bool(_TIME_WORDS.intersection(words)) or all(w in _UNIT_WORDS for w in words)


def _is_rate_name(name: str) -> bool:
    return bool(_RATE_WORDS.intersection(_tokens(name)))


def _is_signal_name(name: str) -> bool:
    return bool(_SIGNAL_WORDS.intersection(_tokens(name)))


def header_time_unit(name: str) -> str | None:
    """The time unit a column name states (``time_ms`` → ``ms``, ``t [s]`` → ``s``), or None."""
    for word in reversed(_tokens(name)):
        if word in _UNIT_WORDS:
            return _UNIT_WORDS[word]
    return None


class _Table:
    """A table's shape and header, and the error of a choice in it."""

    def __init__(self, path: str, width: int, names: Sequence[str] | None, line: int | None):
        self.path, self.width, self.names, self.line = path, width, names, line

    def found(self) -> str:
        if self.names is None:
            return f"{self.width} column{'s' if self.width != 1 else ''} (no header)"
        return f"{self.width} column{'s' if self.width != 1 else ''} ({', '.join(self.names)})"

    def error(self, reason: str) -> InputFileError:
        head = f"header with {self.found()}" if self.names is not None else ""
        return InputFileError(self.path, f"{head}: {reason}" if head else reason, line=self.line)

    def label(self, index: int) -> str:
        return f"'{self.names[index]}'" if self.names is not None else str(index)

    def resolve(self, spec: str | int, option: str) -> int:
        if isinstance(spec, int):
            if 0 <= spec < self.width:
                return spec
            raise self.error(f"{option} {spec}: no such column (0-based: 0 to {self.width - 1})")
        if self.names is None:
            raise self.error(
                f"{option} {spec!r}: the file has no header line to name its columns; "
                f"give a 0-based index ({self.found()})"
            )
        hits = [i for i, n in enumerate(self.names) if n.strip().lower() == spec.strip().lower()]
        if len(hits) != 1:
            what = "no such column" if not hits else "several columns have that name, give a 0-based index"
            raise self.error(f"{option} {spec!r}: {what}")
        return hits[0]


def _time_column(table: _Table, choice: ColumnChoice) -> int | None:
    if choice.time is not None:
        return table.resolve(choice.time, "--time")
    if table.names is None:
        return 0 if table.width >= 2 else None
    timed = [i for i, n in enumerate(table.names) if is_time_name(n)]
    if len(timed) > 1:
        raise table.error(f"several time columns ({', '.join(table.names[i] for i in timed)}): choose one with --time")
    if timed:
        return timed[0]
    if table.width == 2 and not _is_signal_name(table.names[0]):
        return 0  # an unnamed pair (a,b): time, rate as without a header
    return None


def _signal_column(table: _Table, choice: ColumnChoice, time: int | None) -> tuple[int, tuple[str, ...]]:
    if choice.signal is not None:
        signal = table.resolve(choice.signal, "--signal")
        if signal == time:
            raise table.error(f"--signal {choice.signal!r} is the time column")
        return signal, ()
    rest = [i for i in range(table.width) if i != time]
    if not rest:
        raise table.error("only a time column: no gyro samples")
    if len(rest) == 1:
        return rest[0], ()
    if table.names is not None:
        rated = [i for i in rest if _is_rate_name(table.names[i])]
        if len(rated) == 1:
            chosen = table.names[rated[0]]
            note = f"signal: column '{chosen}' of {', '.join(table.names)} (choose another with --signal)"
            return rated[0], (note,)
        raise table.error(
            "cannot tell the time and the signal; choose them with --time COLUMN and --signal COLUMN "
            "(header name or 0-based index)"
        )
    raise table.error(
        f"{table.width} columns: expected 1 (rate) or 2 (time, rate); choose them with --time and --signal "
        "(0-based index)"
    )


def choose_columns(
    path: str, width: int, names: Sequence[str] | None, choice: ColumnChoice | None = None, line: int | None = None
) -> Columns:
    """The time and signal columns of a table (rules: the module and ``docs/cli.md``).

    Args:
        path: The file, for messages.
        width: Number of columns.
        names: The header's column names, None without a header.
        choice: The user's choice (``--time``, ``--signal``, ``--time-unit``).
        line: The header's line (or the first row's without one), for messages.

    Returns:
        The chosen columns and the time unit the header or the choice states.

    Raises:
        InputFileError: A chosen column does not exist, or the columns cannot be told apart;
            the message names the columns found.
    """
    choice = choice or ColumnChoice()
    table = _Table(path, width, names, line)
    time = _time_column(table, choice)
    signal, remarks = _signal_column(table, choice, time)
    if time is None:
        if choice.time_unit is not None:
            raise table.error("--time-unit given but the file has no time column (choose it with --time)")
        return Columns(None, signal, "", None, False, remarks)
    label = f"time column {table.label(time)}"
    unit = choice.time_unit or (header_time_unit(names[time]) if names is not None else None)
    return Columns(time, signal, label, unit, choice.time_unit is not None, remarks)


def _median_step(times: FloatArray) -> float | None:
    """The median of the positive steps between the finite times (None without any), copying as little as it can."""
    finite = times if np.isfinite(times).all() else times[np.isfinite(times)]
    steps = np.diff(finite)
    if not (steps > 0).all():
        steps = steps[steps > 0]
    return float(np.median(steps, overwrite_input=True)) if steps.size else None


def _plausible_rate(step_s: float) -> bool:
    return PLAUSIBLE_RATE_HZ[0] <= 1.0 / step_s <= PLAUSIBLE_RATE_HZ[1]


def _rate_text(step_s: float) -> str:
    return f"{1.0 / step_s:.4g} Hz"


def _inferred(times: FloatArray, step: float) -> list[str]:
    """The units other than s that give a plausible rate and record length."""
    finite = times[np.isfinite(times)]
    span = float(finite.max() - finite.min())
    low, high = PLAUSIBLE_DURATION_S
    return [
        u
        for u, scale in TIME_UNITS.items()
        if u != "s" and _plausible_rate(step * scale) and low <= span * scale <= high
    ]


def times_in_seconds(path: str, times: FloatArray, columns: Columns) -> tuple[FloatArray, str, tuple[str, ...]]:
    """The time column in seconds, its unit, and a remark when the unit was inferred.

    Args:
        path: The file, for messages.
        times: The time column as written.
        columns: The choice (its label, and the unit the header or ``--time-unit`` states).

    Returns:
        ``(seconds, unit, remarks)``.

    Raises:
        InputFileError: The header's unit gives an implausible sample rate, or no unit is
            stated and none (or several) can be inferred; the message names the likely unit.
    """
    step = _median_step(times)
    unit = columns.time_unit
    if step is None or columns.unit_given:
        unit = unit or "s"
        return times * TIME_UNITS[unit], unit, ()
    if unit is not None:
        if _plausible_rate(step * TIME_UNITS[unit]):
            return times * TIME_UNITS[unit], unit, ()
        likely = [u for u in TIME_UNITS if u != unit and _plausible_rate(step * TIME_UNITS[u])]
        hint = f"; they look like {likely[0]}" if len(likely) == 1 else ""
        rate = _rate_text(step * TIME_UNITS[unit])
        raise InputFileError(
            path,
            f"{columns.time_label} says {unit}, but its times step by {step:g} {unit} ({rate}), "
            f"not a plausible gyro sample rate{hint}: fix the column's unit or pass --time-unit",
        )
    if _plausible_rate(step):
        return times, "s", ()
    candidates = _inferred(times, step)
    if len(candidates) == 1:
        u = candidates[0]
        remark = (
            f"{columns.time_label} read in {u}: its steps of {step:g} are {_rate_text(step * TIME_UNITS[u])} in {u} "
            f"but {_rate_text(step)} in s (name the column time_{u} or pass --time-unit {u} to say so)"
        )
        return times * TIME_UNITS[u], u, (remark,)
    could = f" (it could be {' or '.join(candidates)})" if candidates else ""
    raise InputFileError(
        path,
        f"{columns.time_label}: times step by {step:g}, {_rate_text(step)} if in seconds, not a plausible gyro "
        f"sample rate, and their unit cannot be told{could}: name the column with its unit (time_s, time_ms) "
        "or pass --time-unit",
    )


def _step_text(step_s: float) -> str:
    """A time step for people: ``2 ms``, ``0.5 s``, ``20 us``."""
    for unit in ("s", "ms", "us", "ns"):
        if step_s >= TIME_UNITS[unit] or unit == "ns":
            return f"{step_s / TIME_UNITS[unit]:.4g} {unit}"
    raise AssertionError("unreachable")


def _agrees(rate: float, other: float) -> bool:
    return abs(other - rate) <= RATE_AGREEMENT * rate


def check_rate_agrees(path: str, times_s: FloatArray, rate: float, rate_label: str, times_label: str) -> None:
    """Refuse a sample rate that the times (in seconds) contradict.

    The rate agrees when it is within :data:`RATE_AGREEMENT` of the times' mean rate (samples
    over the record's span: robust to rounded stamps) or of their median step's (robust to a
    gap).

    Args:
        path: The file, for messages.
        times_s: The times, s.
        rate: The other source's rate, Hz.
        rate_label: The other source, as named in the message (``--rate``, ``sampleRate``).
        times_label: The times, likewise (``time column 'time'``, ``the 'time' array``).

    Raises:
        InputFileError: The two disagree; the message names both and what each says.
    """
    finite = times_s if np.isfinite(times_s).all() else times_s[np.isfinite(times_s)]
    step = _median_step(finite)
    if step is None or finite.size < 3:
        return
    span = float(finite[-1] - finite[0])
    mean_rate = (finite.size - 1) / span if span > 0 else math.inf
    if _agrees(rate, 1.0 / step) or _agrees(rate, mean_rate):
        return
    raise InputFileError(
        path,
        f"{rate_label} says {rate:.6g} Hz, but {times_label} steps by {_step_text(step)} ({1.0 / step:.6g} Hz): "
        f"the sample rates disagree (by more than {100 * RATE_AGREEMENT:g} %); give one, or correct the wrong one",
    )
