"""BicycleParameters' text formats.

``<Name>Measured.txt``, ``<Name>Benchmark.txt``, and its parameter-set YAML.

Text files hold one ``name = value+/-sigma`` per line (``#`` starts a comment; several
comma-separated values on one line are averaged, as BicycleParameters does, with the σ of the
mean of independent readings); a UTF-8 byte-order mark is read as such. Data in this format from
the BicycleParameters project are BSD-2-Clause, (c) 2011-2025 BicycleParameters Authors.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml

from .benchmark import PARAMETER_NAMES, PART_GROUPS, ParameterSet, parameters_from_values
from .errors import InputFileError, MeasurementError, one_line
from .measurements import KNOWN_KEYS, Measurements, Origin, Reading, check_value_sigma
from .uncertainty.uncertain import UncertainVector

__all__ = [
    "BP_SPEED_M_S",
    "TextEntry",
    "dump_bp_parameter_yaml",
    "parse_value",
    "read_bp_measured",
    "read_bp_parameters",
    "read_bp_text",
]

_NUMBER_KEYS = re.compile(r"^(alpha|a|Tt|Tc)[A-Z]\d+$")
_PM = re.compile(r"\s*(?:\+/-|±)\s*")
_DISTANCE_KEY = re.compile(r"^a[BHSG]\d+$")
_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class TextEntry:
    """One ``name = ...`` line of a BicycleParameters text file.

    Attributes:
        text: The right-hand side as written.
        line: Its 1-based line number.
    """

    text: str
    line: int


def parse_value(text: str) -> tuple[float, float]:
    """Parse ``"v"``, ``"v+/-s"`` or ``"v ± s"``; several comma-separated values are averaged.

    Returns:
        (value, sigma); sigma 0 where none is written.

    Raises:
        ValueError: the text is not a number with an optional uncertainty, or σ is negative.
    """
    values, variances = [], []
    for part in text.split(","):
        pieces = _PM.split(part.strip())
        if len(pieces) > 2 or not pieces[0]:
            raise ValueError(f"'{text}' is not 'value' or 'value+/-sigma'")
        v = float(pieces[0])
        s = float(pieces[1]) if len(pieces) == 2 else 0.0
        if s < 0:
            raise ValueError(f"'{text}': sigma must be >= 0, got {s:g}")
        values.append(v)
        variances.append(s * s)
    n = len(values)
    return sum(values) / n, math.sqrt(sum(variances)) / n


def _value_sigma(path: str, key: str, entry: TextEntry) -> tuple[float, float]:
    """The value and σ of one entry, checked as any reading (finite, σ ≥ 0, a sane magnitude).

    Raises:
        MeasurementError: naming the file, line and key.
    """
    try:
        v, s = parse_value(entry.text)
    except ValueError as exc:
        raise MeasurementError(path, f"not a number: {one_line(str(exc))}", key=key, line=entry.line) from None
    try:
        check_value_sigma(v, s)
    except ValueError as exc:
        raise MeasurementError(path, str(exc), key=key, line=entry.line) from None
    return v, s


def read_bp_text(path: str | Path) -> dict[str, TextEntry]:
    """Read a BicycleParameters text file into ``{name: TextEntry}`` without interpreting values.

    Raises:
        InputFileError: unreadable file, a line without ``=``, or a key given twice.
    """
    p = str(path)
    try:
        content = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(p, f"cannot read the file ({exc.__class__.__name__}: {exc})") from None
    entries: dict[str, TextEntry] = {}
    for n, raw in enumerate(content.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if "=" not in line:
            raise InputFileError(p, f"expected 'name = value+/-sigma', got '{raw.strip()}'", line=n)
        key, _, rhs = line.partition("=")
        key = key.strip()
        if not key:
            raise InputFileError(p, "a line has no name before '='", line=n)
        if key in entries:
            raise InputFileError(p, f"given twice (first on line {entries[key].line})", key=key, line=n)
        entries[key] = TextEntry(rhs.strip(), n)
    return entries


def _bicycle_name(path: str | Path, suffix: str) -> str:
    stem = Path(path).stem
    return stem[: -len(suffix)] if stem.endswith(suffix) and len(stem) > len(suffix) else stem


def read_bp_measured(path: str | Path) -> Measurements:
    """Read a BicycleParameters ``<Name>Measured.txt`` file.

    Keys the benchmark parameters need become readings; all other keys (rider geometry and
    the like) are kept verbatim in ``extras``.

    Raises:
        InputFileError: the file cannot be read or parsed.
        MeasurementError: a needed value is not a number.
    """
    p = str(path)
    entries = read_bp_text(path)
    readings: dict[str, Reading] = {}
    extras: dict[str, object] = {}
    for key, e in entries.items():
        stray = _is_stray_distance(key, entries)
        if (key in KNOWN_KEYS or _NUMBER_KEYS.match(key)) and not stray:
            v, s = _value_sigma(p, key, e)
            readings[key] = Reading(v, s, Origin(p, key, e.line))
        else:
            extras[key] = e.text
            if stray:
                _LOG.warning(
                    "%s:%d: key '%s': set aside: this hanging has no angle (alpha%s) and no torsional "
                    "period (Tt%s), so it places no line and no inertia; kept with the file's other "
                    "entries (BicycleParameters ignores it too)",
                    p,
                    e.line,
                    key,
                    key[1:],
                    key[1:],
                )
    return Measurements(_bicycle_name(path, "Measured"), readings, p, extras)


def _is_stray_distance(key: str, entries: Mapping[str, object]) -> bool:
    """True for ``a<part><i>`` written without ``alpha<part><i>`` or ``Tt<part><i>``.

    A string-to-axle distance places a hanging line only with the angle the part hung at (Eq 10,
    14, 21) and adds to the inertia only with that hanging's torsional period (Eq 30–35): alone it
    is no orientation. BicycleParameters numbers orientations by their angles and so ignores it
    (its ``GyroMeasured.txt`` has ``aB4`` beside three frame orientations).
    """
    return bool(_DISTANCE_KEY.match(key)) and f"alpha{key[1:]}" not in entries and f"Tt{key[1:]}" not in entries


def read_bp_parameters(path: str | Path) -> ParameterSet:
    """Read a BicycleParameters ``<Name>Benchmark.txt`` parameter file (values ± σ).

    The 26 parameters are required; the per-part outputs of a split fork (``mG, xG, zG, IGxx,
    IGxz, IGyy, IGzz`` and the same for S) and of a flywheel (``mD, IDxx, IDyy``), each group
    when all of it is present, become ``ParameterSet.parts``.
    Every other key is ignored unread: BicycleParameters 1.5.2 copies the lateral force point
    ``xcl``, ``zcl`` into this file in numpy 2's repr (``xcl = np.float64(0.1984375)+/-0.0``),
    which is not a parameter and not a number in this format.

    Raises:
        InputFileError: unreadable, a parameter missing or not a number.
    """
    p = str(path)
    entries = read_bp_text(path)
    values, sigmas = {}, {}
    for key in PARAMETER_NAMES:
        if key not in entries:
            raise MeasurementError(p, "missing (one of the benchmark parameters)", key=key)
        values[key], sigmas[key] = _value_sigma(p, key, entries[key])
    ps = parameters_from_values(_bicycle_name(path, "Benchmark"), values, sigmas, p)
    names = tuple(k for group in PART_GROUPS if all(n in entries for n in group) for k in group)
    if not names:
        return ps
    parts = [_value_sigma(p, k, entries[k]) for k in names]
    vec = UncertainVector(names, np.array([v for v, _ in parts]), np.diag([s * s for _, s in parts]))
    return replace(ps, parts=vec)


#: The forward speed a BicycleParameters parameter set carries when none is given, m/s (its
#: benchmark files' value).
BP_SPEED_M_S = 5.0


def dump_bp_parameter_yaml(
    params: ParameterSet, description: str = "", *, rider: bool = False, speed: float = BP_SPEED_M_S
) -> str:
    """The parameters as a BicycleParameters parameter-set YAML document.

    The layout ``Meijaard2007ParameterSet._from_yaml`` reads: ``values`` holds the 26 benchmark
    parameters and the forward speed ``v`` (m/s) as plain floats, ``rider`` whether body B
    includes a rider. σ are not part of that format and are not written.

    Args:
        params: The parameter set.
        description: The document's description (a default names the bicycle and source).
        rider: Whether a rider was added to the rear frame.
        speed: The forward speed ``v`` the set carries, m/s.
    """
    values: Mapping[str, float] = params.values()
    doc = {
        "description": description
        or f"Benchmark parameters of {params.bicycle}, computed by bike_rig from {params.source}.",
        "parameterization": "Meijaard2007",
        "parameters": params.bicycle.lower(),
        "rider": bool(rider),
        "values": {**{k: float(values[k]) for k in PARAMETER_NAMES}, "v": float(speed)},
    }
    return yaml.safe_dump(doc, sort_keys=False)
