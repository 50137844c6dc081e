"""Open any accepted input file.

Measurements or a parameter set, in our YAML or BicycleParameters' formats, recognised by
content.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from .benchmark import PARAMETER_NAMES, ParameterSet
from .errors import InputFileError
from .io_bp import read_bp_measured, read_bp_parameters, read_bp_text
from .io_yaml import (
    MEASUREMENTS_FORMAT,
    PARAMETERS_FORMAT,
    load_yaml_document,
    measurements_from_document,
    parameters_from_document,
)
from .measurements import Measurements, is_period_key
from .parameter_checks import check_parameter_set
from .reading_ranges import UnitMistake, UnitMistakeWarning, parameter_unit_mistakes, unit_mistakes
from .safe_yaml import open_regular_file

__all__ = ["is_period_key", "load_input", "load_measurements", "load_static_readings", "warn_unit_mistakes"]

_YAML_SUFFIXES = {".yaml", ".yml"}


def _where(m: Measurements, key: str) -> str:
    origin = m.readings[key].origin
    if origin is None:
        return m.path
    return f"{origin.path}:{origin.line}" if origin.line is not None else f"{origin.path}: key '{origin.key}'"


def warn_unit_mistakes(got: Measurements | ParameterSet) -> list[str]:
    """Warn (:class:`~bike_rig.core.reading_ranges.UnitMistakeWarning`) of each value a wrong unit explains.

    Returns:
        The warnings' texts (for a report's notes), each ``<file>:<line>: w = 1121 m is outside ...``.

    Raises:
        UnitMistakeWarning: the first one, when warnings of its class are errors (``--strict``).
    """
    found: list[tuple[str, UnitMistake]]
    if isinstance(got, Measurements):
        found = [(_where(got, u.key), u) for u in unit_mistakes({k: r.value for k, r in got.readings.items()})]
    else:
        found = [(f"{got.source}: key '{u.key}'", u) for u in parameter_unit_mistakes(got.values())]
    texts = [f"{where}: {u}" for where, u in found]
    for text in texts:
        warnings.warn(UnitMistakeWarning(text), stacklevel=2)
    return texts


def load_input(path: str | Path) -> Measurements | ParameterSet:
    """Read a measurement file or a parameter file, and warn of values a wrong unit explains.

    Accepted: ``bike_rig-measurements/1`` and ``bike_rig-parameters/1`` YAML, BicycleParameters'
    ``*Measured.txt`` and ``*Benchmark.txt`` text files and its parameter-set YAML. A parameter
    set must be physically possible (:func:`~bike_rig.core.parameter_checks.check_parameter_set`);
    each value outside its plausible range that a wrong unit explains is a
    :class:`~bike_rig.core.reading_ranges.UnitMistakeWarning` (:func:`warn_unit_mistakes`).

    Raises:
        InputFileError: the file is missing, unreadable or of no accepted kind.
        ImplausibleParametersError: a parameter set that is not physically possible.
        UnitMistakeWarning: when warnings of its class are errors (``--strict``).
    """
    got = _read_input(path)
    warn_unit_mistakes(got)
    return check_parameter_set(got) if isinstance(got, ParameterSet) else got


def _read_input(path: str | Path) -> Measurements | ParameterSet:
    p = str(path)
    open_regular_file(p, path).close()  # a FIFO, a device or a symlink loop is named as such, never read
    if Path(path).suffix.lower() in _YAML_SUFFIXES:
        data, lines = load_yaml_document(path)
        if not isinstance(data, dict):
            raise InputFileError(p, "expected a YAML mapping at the top level")
        fmt = data.get("format")
        if fmt == MEASUREMENTS_FORMAT:
            return measurements_from_document(p, data, lines)
        if fmt == PARAMETERS_FORMAT or "values" in data or "IBxx" in data:
            return parameters_from_document(p, data, lines)
        raise InputFileError(
            p,
            f"unknown kind of YAML file: expected 'format: {MEASUREMENTS_FORMAT}' or "
            f"'format: {PARAMETERS_FORMAT}' (or a BicycleParameters parameter set)",
        )
    entries = read_bp_text(path)
    if not entries:
        raise InputFileError(p, "empty file: no 'name = value+/-sigma' lines")
    is_parameters = all(k in entries for k in PARAMETER_NAMES) and "TtP1" not in entries
    return read_bp_parameters(path) if is_parameters else read_bp_measured(path)


def load_measurements(path: str | Path) -> Measurements:
    """Read a file that must hold raw measurements.

    Raises:
        InputFileError: the file holds something else.
    """
    got = load_input(path)
    if not isinstance(got, Measurements):
        raise InputFileError(str(path), "holds benchmark parameters, but raw measurements are needed here")
    return got


def load_static_readings(path: str | Path) -> Measurements:
    """Read a measurement file's static readings only.

    Every pendulum period is left out (the live rig measures them), from our YAML (period
    entries, even trial lists, are skipped) or a BicycleParameters ``Measured.txt`` (its
    ``Tc*``/``Tt*`` lines are dropped).

    Raises:
        InputFileError: the file is missing, unreadable, or holds parameters.
    """
    p = str(path)
    open_regular_file(p, path).close()  # a FIFO, a device or a symlink loop is named as such, never read
    if Path(path).suffix.lower() in _YAML_SUFFIXES:
        data, lines = load_yaml_document(path)
        if not isinstance(data, dict) or data.get("format") != MEASUREMENTS_FORMAT:
            raise InputFileError(p, f"expected a measurement file ('format: {MEASUREMENTS_FORMAT}')")
        static = measurements_from_document(p, data, lines, static_only=True)
        warn_unit_mistakes(static)
        return static
    m = load_measurements(path)  # (warns of unit mistakes)
    readings = {k: r for k, r in m.readings.items() if not is_period_key(k)}
    return Measurements(m.bicycle, readings, m.path, m.extras)
