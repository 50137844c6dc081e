"""Open any accepted input file.

Measurements or a parameter set, in our YAML or BicycleParameters' formats, recognised by
content.
"""

from __future__ import annotations

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

__all__ = ["is_period_key", "load_input", "load_measurements", "load_static_readings"]

_YAML_SUFFIXES = {".yaml", ".yml"}


def load_input(path: str | Path) -> Measurements | ParameterSet:
    """Read a measurement file or a parameter file.

    Accepted: ``bike_rig-measurements/1`` and ``bike_rig-parameters/1`` YAML, BicycleParameters'
    ``*Measured.txt`` and ``*Benchmark.txt`` text files and its parameter-set YAML.

    Raises:
        InputFileError: the file is missing, unreadable or of no accepted kind.
    """
    p = str(path)
    if not Path(path).is_file():
        raise InputFileError(p, "no such file" if not Path(path).exists() else "not a regular file")
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
    if not Path(path).is_file():
        raise InputFileError(p, "no such file" if not Path(path).exists() else "not a regular file")
    if Path(path).suffix.lower() in _YAML_SUFFIXES:
        data, lines = load_yaml_document(path)
        if not isinstance(data, dict) or data.get("format") != MEASUREMENTS_FORMAT:
            raise InputFileError(p, f"expected a measurement file ('format: {MEASUREMENTS_FORMAT}')")
        return measurements_from_document(p, data, lines, static_only=True)
    m = load_measurements(path)
    readings = {k: r for k, r in m.readings.items() if not is_period_key(k)}
    return Measurements(m.bicycle, readings, m.path, m.extras)
