"""Trial files: one rate-gyro record of a pendulum swing each, ready for the period fitter.

:func:`read_trial` reads CSV-like text (``.csv``, ``.txt``, ``.tsv``, ``.dat``), NumPy
``.npy`` and BicycleParameters' pendulum ``.mat`` files; the formats, column choice and time
units are described in ``docs/cli.md`` (``fit``). Samples stay in the file's unit (the period
does not care); times are returned in seconds. A trial's measurement key (``TtB2``) comes
from a ``.mat``'s fields, else from its file name (:func:`key_from_name`). Unusable files raise
:class:`~bike_rig.core.errors.InputFileError`; bad values (NaN, gaps) are left to the fitter.
"""

from __future__ import annotations

import io
import math
import os
import re
import warnings
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from .errors import InputFileError, one_line, short_repr
from .safe_yaml import open_regular_file
from .trial_binary import MAX_TRIAL_BYTES, check_mat_sizes, check_npy_header, load_mat_isolated
from .trial_columns import RATE_AGREEMENT, ColumnChoice, Columns, check_rate_agrees, choose_columns, times_in_seconds

__all__ = ["TEXT_SUFFIXES", "ColumnChoice", "Trial", "key_from_name", "read_trial", "uniform_sample_rate"]

FloatArray = NDArray[np.float64]

#: File name endings read as delimited text.
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")

#: The largest text trial file read [bytes]: some 2.5 M rows, 40 minutes at 1 kHz (a pendulum
#: trial is some tens of seconds).
MAX_TEXT_TRIAL_BYTES = 64 << 20
#: The most rows a text trial may hold: 2.3 hours at 1 kHz. Only the time and signal columns
#: are kept, 8 bytes a number, so a text trial takes at most 128 MiB however short its rows.
MAX_TEXT_ROWS = 8 << 20
#: The longest line of a text trial [characters]: a row of samples is some tens, a header of
#: some thousand columns fits.
MAX_LINE_CHARS = 64 << 10
#: Characters read at a time while measuring a line that is too long.
_MEASURE_CHUNK = 1 << 20

#: BicycleParameters' part names and the letter of their period keys (fork and handlebar as one).
_PART_LETTERS = {"Rwheel": "R", "Fwheel": "F", "Frame": "B", "Fork": "H", "Handlebar": "G", "Rod": "P"}
_ORDINALS = {"First": 1, "Second": 2, "Third": 3, "Fourth": 4, "Fifth": 5, "Sixth": 6}
#: BicycleParameters' trial file stem: <bicycle><part><pendulum><ordinal><trial>.
_BP_STEM = re.compile(rf"^[A-Za-z0-9]*?({'|'.join(_PART_LETTERS)})(Compound|Torsional)({'|'.join(_ORDINALS)})\d*$")
#: The simulated rig's trial stem: <part>_<pendulum>[_o<orientation>][_t<trial>].
_SIM_STEM = re.compile(
    r"^(rear_wheel|front_wheel|frame|fork|calibration_rod)_(compound|torsional)(?:_o(\d+))?(?:_t\d+)?$"
)
#: A period key as a word of a file name (TtB2_t1, fork-TcH1-2).
_KEY_WORD = re.compile(r"(?:^|[^A-Za-z0-9])(T[ct][RFBHGP][1-9]\d*)(?=$|[^A-Za-z0-9])")


@dataclass(frozen=True)
class Trial:
    """One trial's samples and what is known about it.

    Attributes:
        samples: The gyro samples (float64, the file's unit).
        sample_rate_hz: Constant sample rate [Hz], or None when ``times`` are given.
        times: Time of each sample [s], or None for a constant rate.
        name: The trial's name (BicycleParameters' naming when the file says, else the stem).
        path: The file, as given.
        bicycle: BicycleParameters ``bicycle`` (e.g. ``Browser``), if given.
        part: ``part`` (``Rwheel``, ``Fwheel``, ``Frame``, ``Fork``, ``Handlebar``, ``Rod``...).
        pendulum: ``pendulum`` (``Compound`` or ``Torsional``).
        angle: ``angleOrder`` / ``angle``: the hanging orientation (``First``, ``Second``...).
        trial: ``trial``: the repetition (``1``, ``2``...).
        notes: ``notes``.
        time_unit: The unit the file's times were in (``s``, ``ms``, ``us``, ``ns``), None
            without times; ``times`` are in seconds whatever it was.
        remarks: What the reader decided that the user should know (a time unit inferred from
            the spacing, a signal column chosen among several).
    """

    samples: FloatArray
    sample_rate_hz: float | None
    times: FloatArray | None
    name: str
    path: str
    bicycle: str | None = None
    part: str | None = None
    pendulum: str | None = None
    angle: str | None = None
    trial: str | None = None
    notes: str | None = None
    time_unit: str | None = None
    remarks: tuple[str, ...] = ()

    @property
    def timing(self) -> dict[str, Any]:
        """The keyword for :func:`~bike_rig.core.period.fit_period`: ``times`` or ``sample_rate_hz``.

        Evenly spaced time stamps (every step within 1e-6 of the mean step, or within the
        stamps' float resolution) are given as their
        sample rate, the way the live fitter fits a stream: a file and a live stream of the same
        samples then get the same fit. The rate is snapped to 6 decimals when it is that close
        to such a value (e.g. 1000.0 Hz from a time column written as i / 1000).
        """
        if self.times is not None:
            rate = uniform_sample_rate(self.times)
            return {"times": self.times} if rate is None else {"sample_rate_hz": rate}
        return {"sample_rate_hz": self.sample_rate_hz}

    @property
    def period_key(self) -> str | None:
        """The measurement file's key of this period (``TtB1``, ``TcR1``...), if known.

        From a .mat file's ``part``, ``pendulum`` and ``angleOrder``, else from the file name
        (:func:`key_from_name`); None when neither says.
        """
        if self.pendulum is not None and self.part in _PART_LETTERS:
            kind = self.pendulum[:1].lower()
            order = _ORDINALS.get(self.angle or "First")
            if kind in ("c", "t") and order is not None:
                return f"T{kind}{_PART_LETTERS[self.part]}{order}"
        return key_from_name(Path(self.path).stem)

    @property
    def duration(self) -> float:
        """Time spanned by the samples [s]."""
        if self.times is not None:
            return float(self.times[-1] - self.times[0]) if self.times.size else 0.0
        assert self.sample_rate_hz is not None
        return self.samples.size / self.sample_rate_hz


def key_from_name(stem: str) -> str | None:
    """The period key a trial file's name gives (``frame_torsional_o2_t3`` → ``TtB2``), or None.

    Args:
        stem: The file name without its extension.

    Returns:
        The key for the simulated rig's names, BicycleParameters' names
        (``BrowserForkCompoundFirst1`` → ``TcH1``) and names holding the key as a word
        (``TtB2_t1``); None otherwise.
    """
    found = _SIM_STEM.match(stem)
    if found:
        from .sim.plan import PlannedMeasurement

        orientation = int(found[3]) if found[3] else None
        return PlannedMeasurement(found[1], found[2], orientation).key
    found = _BP_STEM.match(stem)
    if found:
        return f"T{found[2][0].lower()}{_PART_LETTERS[found[1]]}{_ORDINALS[found[3]]}"
    words = set(_KEY_WORD.findall(stem))
    return words.pop() if len(words) == 1 else None


def read_trial(
    path: str | os.PathLike[str], sample_rate_hz: float | None = None, columns: ColumnChoice | None = None
) -> Trial:
    """Read one trial file (CSV, ``.npy`` or BicycleParameters ``.mat``; see the module).

    The path must be a regular file (a FIFO, a device or a symlink loop is named, never read).
    Text is read a line at a time, keeping only the time and signal columns (at most
    :data:`MAX_TEXT_ROWS` rows; a line over :data:`MAX_LINE_CHARS` is refused). A given sample
    rate must agree with the file's own times or rate within
    :data:`~bike_rig.core.trial_columns.RATE_AGREEMENT`, as a ``.mat``'s must with each other.

    Args:
        path: The file.
        sample_rate_hz: Sample rate [Hz] for files that carry neither times nor a rate.
        columns: The time and signal columns (CSV by name or index, ``.npy`` by index) and the
            time unit, as the user chose them; None to recognise them.

    Returns:
        The trial, its times in seconds.

    Raises:
        InputFileError: The file is unreadable, has the wrong shape, a non-numeric cell, no
            times and no rate, columns that cannot be told apart, or times whose unit cannot
            be told.
    """
    name = str(path)
    if sample_rate_hz is not None and not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise InputFileError(name, f"the sample rate must be a positive number of Hz, got {sample_rate_hz}")
    p = Path(path)
    suffix = p.suffix.lower()
    choice = columns or ColumnChoice()
    with open_regular_file(name, p) as handle:  # a FIFO, a device or a symlink loop is refused here, unopened
        size = os.fstat(handle.fileno()).st_size
        limit = MAX_TEXT_TRIAL_BYTES if suffix in TEXT_SUFFIXES else MAX_TRIAL_BYTES
        if size > limit:
            raise InputFileError(name, f"{size} bytes: larger than any trial file ({limit} bytes)")
        with np.errstate(all="ignore"):  # overflowing or NaN values are refused or left to the fitter, silently
            if suffix in TEXT_SUFFIXES:
                text = io.TextIOWrapper(handle, encoding="utf-8-sig", newline=None)
                try:
                    return _read_text(name, p, text, sample_rate_hz, choice)
                finally:
                    text.detach()
            if suffix == ".npy":
                return _read_npy(name, p, sample_rate_hz, choice)
            if suffix == ".mat":
                return _read_mat(name, p, sample_rate_hz, choice)
    raise InputFileError(name, f"unknown trial format {p.suffix!r} (expected {', '.join(TEXT_SUFFIXES)}, .npy or .mat)")


def _needs_rate(name: str, sample_rate_hz: float | None, what: str) -> float:
    if sample_rate_hz is None:
        raise InputFileError(name, f"missing sample rate: {what} carries no times, give the rate (--rate HZ)")
    return float(sample_rate_hz)


def _make(
    name: str,
    p: Path,
    samples: FloatArray,
    times: FloatArray | None,
    rate: float | None,
    remarks: tuple[str, ...] = (),
    time_unit: str | None = None,
    **meta: str | None,
) -> Trial:
    if samples.size == 0:
        raise InputFileError(name, "no samples")
    trial_name = p.stem
    parts = [meta.get(k) for k in ("bicycle", "part", "pendulum", "angle", "trial")]
    if all(parts):
        trial_name = "".join(str(x) for x in parts)
    return Trial(
        samples=samples,
        sample_rate_hz=None if times is not None else rate,
        times=times,
        name=trial_name,
        path=name,
        time_unit=time_unit if times is not None else None,
        remarks=remarks,
        **meta,
    )


def _from_columns(
    name: str,
    p: Path,
    samples: FloatArray,
    raw_times: FloatArray | None,
    columns: Columns,
    width: int,
    sample_rate_hz: float | None,
    what: str,
) -> Trial:
    """A trial from a table's signal and time columns (``width`` columns in all), its times in seconds.

    ``what`` names the table in the missing-rate message (``a one-column file``). A rate given
    besides the times must agree with them (:func:`~bike_rig.core.trial_columns.check_rate_agrees`).
    """
    if raw_times is None:
        if sample_rate_hz is None and width > 1:
            reason = f"missing sample rate: {what} has no time column, give the rate (--rate HZ) or choose one (--time)"
            raise InputFileError(name, reason)
        return _make(name, p, samples, None, _needs_rate(name, sample_rate_hz, what), columns.remarks)
    times, unit, remarks = times_in_seconds(name, raw_times, columns)
    if sample_rate_hz is not None:
        check_rate_agrees(name, times, sample_rate_hz, "--rate", columns.time_label)
    return _make(name, p, samples, times, None, columns.remarks + remarks, unit)


def _from_table(
    name: str, p: Path, data: FloatArray, columns: Columns, sample_rate_hz: float | None, what: str
) -> Trial:
    """A trial from the columns of a table (rows of samples), its times in seconds (see :func:`_from_columns`)."""
    samples = np.ascontiguousarray(data[:, columns.signal])
    raw = None if columns.time is None else np.ascontiguousarray(data[:, columns.time])
    return _from_columns(name, p, samples, raw, columns, data.shape[1], sample_rate_hz, what)


# ---------------------------------------------------------------- CSV


def _split(line: str, delimiter: str | None) -> list[str]:
    return [cell.strip() for cell in (line.split(delimiter) if delimiter else line.split())]


def _size_text(n: int) -> str:
    """A length in bytes for people: ``60 MB``, ``70 kB``, ``900 bytes``."""
    if n >= 1_000_000:
        return f"{n / 1e6:.3g} MB"
    return f"{n / 1e3:.3g} kB" if n >= 1000 else f"{n} bytes"


def _long_line(name: str, number: int, head: str, stream: TextIO) -> InputFileError:
    """The error of line ``number``, too long: its length measured a chunk at a time (``head`` read already)."""
    size = len(head.encode())
    line = head
    while not line.endswith("\n") and (line := stream.readline(_MEASURE_CHUNK)):
        size += len(line.encode())
    reason = (
        f"line {number} is {_size_text(size)} long: not a CSV of samples "
        f"(a row of samples is at most {MAX_LINE_CHARS} characters)"
    )
    return InputFileError(name, reason)


@dataclass
class _TextTable:
    """The columns kept of a text trial, its width, delimiter, the header's names and where it starts."""

    signal: array[float] = field(default_factory=lambda: array("d"))
    time: array[float] = field(default_factory=lambda: array("d"))
    rows: int = 0
    width: int = 0
    delimiter: str | None = None
    names: list[str] | None = None
    first_line: int | None = None
    columns: Columns | None = None

    def describe(self) -> str:
        """The columns for messages: ``(rate, volts)``, or ``(3 columns)`` without a header."""
        return f"({', '.join(self.names)})" if self.names else f"({self.width} columns)"

    def add(self, values: list[float]) -> None:
        """Keep the time and signal of one row."""
        assert self.columns is not None
        self.rows += 1
        self.signal.append(values[self.columns.signal])
        if self.columns.time is not None:
            self.time.append(values[self.columns.time])


def _read_text(name: str, p: Path, stream: TextIO, sample_rate_hz: float | None, choice: ColumnChoice) -> Trial:
    table = _text_rows(name, stream, choice)
    if table.columns is None:
        raise InputFileError(name, "no samples")
    what = "a one-column file" if table.width == 1 else f"the file {table.describe()}"
    samples = np.frombuffer(table.signal, dtype=np.float64)
    times = np.frombuffer(table.time, dtype=np.float64) if table.columns.time is not None else None
    return _from_columns(name, p, samples, times, table.columns, table.width, sample_rate_hz, what)


def _text_rows(name: str, stream: TextIO, choice: ColumnChoice) -> _TextTable:
    """The time and signal columns of a text trial, its width and header, read a line at a time.

    Blank lines and ``#`` comments are skipped; the delimiter (``,``, ``;``, tab, else
    whitespace) is that of the first line; one header line (column names) is allowed before
    the first row. ``first_line`` is the header's line, or the first row's without one. The
    columns are chosen at the first row and only theirs are kept, 8 bytes a number; every cell
    must be a number. A line longer than :data:`MAX_LINE_CHARS` is refused (a one-line file of
    60 MB costs a few MB, not gigabytes of cells).
    """
    table = _TextTable()
    number = 0
    readline = stream.readline
    try:
        while table.columns is None and (raw := readline(MAX_LINE_CHARS + 1)):
            number += 1
            if len(raw) > MAX_LINE_CHARS and not raw.endswith("\n"):
                raise _long_line(name, number, raw, stream)
            _head_line(name, table, raw, number, choice)
        if table.columns is None:
            return table
        delimiter, width, signal, time = table.delimiter, table.width, table.columns.signal, table.columns.time
        keep_signal, keep_time = table.signal.append, table.time.append
        while raw := readline(MAX_LINE_CHARS + 1):
            number += 1
            if len(raw) > MAX_LINE_CHARS and not raw.endswith("\n"):
                raise _long_line(name, number, raw, stream)
            try:
                values = list(map(float, raw.split(delimiter) if delimiter else raw.split()))
            except ValueError:  # a blank line, a comment, or a bad cell
                values = []
            if len(values) != width:
                _skip_or_refuse(name, raw, delimiter, width, number)
                continue
            if table.rows >= MAX_TEXT_ROWS:
                raise InputFileError(name, f"more than {MAX_TEXT_ROWS} rows: larger than any trial", line=number)
            table.rows += 1
            keep_signal(values[signal])
            if time is not None:
                keep_time(values[time])
    except UnicodeDecodeError:
        raise InputFileError(name, "not a text file (not UTF-8)") from None
    return table


def _skip_or_refuse(name: str, raw: str, delimiter: str | None, width: int, number: int) -> None:
    """Skip line ``number`` if it is blank or a comment; else raise the error of its bad cell or width."""
    line = raw.strip()
    if not line or line.startswith("#"):
        return
    values = _numbers(name, _split(line, delimiter), number, header_allowed=False)
    assert values is not None
    _row_width(name, len(values), width, number)
    raise AssertionError(f"line {number} was refused, yet its cells and width are right")


def _head_line(name: str, table: _TextTable, raw: str, number: int, choice: ColumnChoice) -> None:
    """Read a line before the first row: a comment, the header, or the first row (which chooses the columns)."""
    line = raw.strip()
    if not line or line.startswith("#"):
        return
    if table.first_line is None:
        table.delimiter = next((d for d in (",", ";", "\t") if d in line), None)
        table.first_line = number
    cells = _split(line, table.delimiter)
    values = _numbers(name, cells, number, header_allowed=table.names is None)
    if values is None:
        table.names = [cell.strip("\"'") for cell in cells]
        table.width = len(cells)
        return
    table.width = _row_width(name, len(values), table.width, number)
    table.columns = choose_columns(name, table.width, table.names, choice, table.first_line)
    table.add(values)


def _numbers(name: str, cells: list[str], number: int, header_allowed: bool) -> list[float] | None:
    """The cells of line ``number`` as numbers, or None for a header line (when ``header_allowed``)."""
    values: list[float] = []
    for column, cell in enumerate(cells, start=1):
        try:
            values.append(float(cell))
        except ValueError:
            if header_allowed:
                return None
            what = "an empty cell" if not cell else f"non-numeric value {cell!r}"
            raise InputFileError(name, f"{what} in column {column}", line=number) from None
    return values


def _row_width(name: str, columns: int, width: int, number: int) -> int:
    """The file's width after a row of ``columns`` numbers at line ``number`` (``width``: 0 before the first)."""
    if width == 0:
        return columns
    if columns != width:
        raise InputFileError(name, f"{columns} columns where the file has {width}", line=number)
    return width


# ---------------------------------------------------------------- NumPy


def _read_npy(name: str, p: Path, sample_rate_hz: float | None, choice: ColumnChoice) -> Trial:
    check_npy_header(name, p)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)  # Python's, on a damaged header's literal
            array = np.load(p, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputFileError(name, f"not a readable NumPy .npy file ({one_line(str(exc))})") from None
    if not isinstance(array, np.ndarray):
        raise InputFileError(name, "not a single NumPy array")
    if array.dtype.kind not in "biuf":
        raise InputFileError(name, f"holds {array.dtype} values, not numbers")
    if array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if array.ndim == 1:
        array = array.reshape(-1, 1)
    if array.ndim != 2 or (array.shape[1] > 2 and not choice.chooses_columns):
        raise InputFileError(
            name,
            f"wrong shape {array.shape}: expected (N,) rates or (N, 2) rows of [time, rate]"
            + ("; choose the columns of an (N, k) array with --time and --signal (0-based)" if array.ndim == 2 else ""),
        )
    columns = choose_columns(name, array.shape[1], None, choice)
    what = "a 1-D array" if array.shape[1] == 1 else f"the ({array.shape[0]}, {array.shape[1]}) array"
    return _from_table(name, p, array.astype(float), columns, sample_rate_hz, what)


# ---------------------------------------------------------------- BicycleParameters .mat


def _text(value: object) -> str | None:
    """A .mat field as text: strings as they are, whole numbers without a decimal point."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        if value.size != 1:
            return None if value.size == 0 else str(value.tolist())
        value = value.item()
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    text = str(value).strip()
    return text or None


def _vector(name: str, mat: dict[str, Any], key: str) -> FloatArray:
    value = np.asarray(mat[key])
    if value.dtype.kind not in "biuf":
        raise InputFileError(name, f"holds {value.dtype} values, not numbers", key=key)
    value = np.squeeze(value)
    if value.ndim == 0:
        value = value.reshape(1)
    if value.ndim != 1:
        raise InputFileError(name, f"wrong shape {np.shape(mat[key])}: expected a vector", key=key)
    return value.astype(float)


def _mat_rates(name: str, mat: dict[str, Any]) -> dict[str, float]:
    """The rates a .mat file states, Hz: ``ActualRate`` (measured), then ``sampleRate`` (asked for).

    Raises:
        InputFileError: one is not a positive number (naming its key).
    """
    rates: dict[str, float] = {}
    for key in ("ActualRate", "sampleRate"):
        if key in mat:
            value = np.asarray(mat[key])
            rate = float(value.reshape(-1)[0]) if value.dtype.kind in "biuf" and value.size == 1 else math.nan
            if not (math.isfinite(rate) and rate > 0):
                got = one_line(short_repr(mat[key], 80))
                raise InputFileError(name, f"the sample rate must be a positive number, got {got}", key=key)
            rates[key] = rate
    return rates


def _read_mat(name: str, p: Path, sample_rate_hz: float | None, choice: ColumnChoice) -> Trial:
    if choice.chooses_columns:
        raise InputFileError(name, "--time and --signal choose columns of CSV and .npy files; a .mat has none")
    check_mat_sizes(name, p)
    mat, warned = load_mat_isolated(name, p)
    read_remarks = tuple(f"reading the .mat: {w}" for w in warned)
    if "data" not in mat:
        raise InputFileError(name, "no 'data' array (the gyro samples)", key="data")
    samples = _vector(name, mat, "data")
    rates = _mat_rates(name, mat)
    times = None
    rate = None
    unit: str | None = None
    remarks: tuple[str, ...] = ()
    if "time" in mat:
        times = _vector(name, mat, "time")
        if times.size != samples.size:
            raise InputFileError(name, f"{times.size} times for {samples.size} samples", key="time")
        given = Columns(0, 1, "the 'time' array", choice.time_unit, choice.time_unit is not None)
        times, unit, remarks = times_in_seconds(name, times, given)
        for key, value in rates.items():
            try:
                check_rate_agrees(name, times, value, key, "the 'time' array")
            except InputFileError as exc:
                raise InputFileError(name, exc.reason, key=key) from None
        if sample_rate_hz is not None:
            check_rate_agrees(name, times, sample_rate_hz, "--rate", "the 'time' array")
    elif rates:
        (key, rate), *others = rates.items()  # ActualRate (measured) before sampleRate (asked for)
        for other, value in [*others, *([("--rate", sample_rate_hz)] if sample_rate_hz is not None else [])]:
            if abs(value - rate) > RATE_AGREEMENT * rate:
                reason = (
                    f"{key} says {rate:.6g} Hz, but {other} says {value:.6g} Hz: the sample rates disagree "
                    f"(by more than {100 * RATE_AGREEMENT:g} %); give one, or correct the wrong one"
                )
                raise InputFileError(name, reason, key=key if other == "--rate" else other)
    else:
        rate = _needs_rate(name, sample_rate_hz, "no 'ActualRate' or 'sampleRate' and no 'time': the file")
    meta = {
        "bicycle": _text(mat.get("bicycle")),
        "part": _text(mat.get("part")),
        "pendulum": _text(mat.get("pendulum")),
        "angle": _text(mat.get("angleOrder", mat.get("angle"))),
        "trial": _text(mat.get("trial")),
        "notes": _text(mat.get("notes")),
    }
    return _make(name, p, samples, times, rate, read_remarks + remarks, unit, **meta)


def uniform_sample_rate(times: NDArray[np.float64]) -> float | None:
    """The sample rate of evenly spaced time stamps [Hz], or None if they are not evenly spaced."""
    if times.size < 3 or not np.all(np.isfinite(times)):
        return None
    steps = np.diff(times)
    mean = float(times[-1] - times[0]) / (times.size - 1)
    # allowed deviation: 1e-6 of a step, or the stamps' own float resolution (epoch times)
    tolerance = max(1e-6 * mean, 4.0 * float(np.spacing(np.max(np.abs(times[[0, -1]])))))
    if not mean > 0 or float(np.max(np.abs(steps - mean))) > tolerance:
        return None
    rate = 1.0 / mean
    snapped = round(rate, 6)
    return snapped if abs(rate - snapped) <= 1e-9 * rate else rate
