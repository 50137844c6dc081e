"""bike_rig's YAML files: one bicycle's measurements, and a parameter set.

``format: bike_rig-measurements/1`` (SI, degrees only in keys ending in ``_deg``; every
measured value ``[value, sigma]``, ``{value: v, sigma: s}`` or ``"v +/- s"``; rotations exact
counts; the refined method's ``surface_plate``, ``fork_only``, ``handlebar`` and ``flywheel``
sections) and ``format: bike_rig-parameters/1`` (the 26 BicycleParameters keys to
``[value, sigma]``, SI, ``lam`` in rad). Every key is described in ``docs/formats.md``;
``config/bicycles/browser.yaml`` is an example.
"""

from __future__ import annotations

import errno
from collections.abc import Iterator, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .benchmark import PARAMETER_NAMES, PART_GROUPS, ParameterSet, parameters_from_values
from .errors import InputFileError, MeasurementError, one_line, short_repr
from .io_bp import parse_value
from .measurements import (
    MAX_MAGNITUDE,
    SPLIT_FORK_KEYS,
    SURFACE_PLATE_KEYS,
    Measurements,
    Origin,
    Reading,
    check_value_sigma,
    missing_reason,
    required_keys,
)
from .safe_yaml import (
    LIMITS,
    NotRegularFileError,
    YamlDuplicateKeyError,
    YamlLimitError,
    compose_bounded,
    construct,
    read_regular_file,
    yaml_error_reason,
)
from .trial_periods import PeriodEvidence, period_from_trials
from .uncertainty.uncertain import UncertainVector

__all__ = [
    "MEASUREMENTS_FORMAT",
    "PARAMETERS_FORMAT",
    "dump_measurements_yaml",
    "dump_parameters_yaml",
    "load_yaml_document",
    "measurements_from_document",
    "parameters_from_document",
]

MEASUREMENTS_FORMAT = "bike_rig-measurements/1"
PARAMETERS_FORMAT = "bike_rig-parameters/1"

ATTRIBUTION = (
    "Derived from BicycleParameters data (https://github.com/moorepants/BicycleParameters), "
    "BSD-2-Clause, (c) 2011-2025 BicycleParameters Authors."
)

#: (section, key) -> (flat key suffix-free name, unit comment); {p} is the part letter.
_WHEEL = {
    "mass": ("m{p}", "kg"),
    "rotations": ("n{p}", "exact count"),
    "distance_rolled": ("d{p}", "m, over those rotations"),
    "pendulum_arm": ("l{p}", "m, rod/rim contact to wheel centre"),
    "compound_period": ("Tc{p}1", "s"),
    "torsional_period": ("Tt{p}1", "s"),
}
_PART = {
    "mass": ("m{p}", "kg"),
    "compound_period": ("Tc{p}1", "s, swinging about the {axle} axle"),
}
_ORIENTATION = {
    "angle_deg": ("alpha{p}{i}", "degrees"),
    "distance": ("a{p}{i}", "m"),
    "torsional_period": ("Tt{p}{i}", "s"),
}
_GEOMETRY = {
    "wheelbase": ("w", "m"),
    "head_tube_angle_deg": ("gamma", "degrees from the horizontal"),
    "fork_offset": ("f", "m"),
}
_ROD = {
    "mass": ("mP", "kg"),
    "length": ("lP", "m"),
    "diameter": ("dP", "m"),
    "torsional_period": ("TtP1", "s"),
}
_FLYWHEEL = {
    "mass": ("mD", "kg, the front wheel with the flywheel in it"),
    "compound_period": ("TcD1", "s, the front wheel with the flywheel"),
    "torsional_period": ("TtD1", "s, the front wheel with the flywheel"),
}
_SURFACE_PLATE = {
    k: (k, "m") for k in SURFACE_PLATE_KEYS + tuple(k for k in SPLIT_FORK_KEYS if not k.startswith(("m", "T")))
}
_WHEELS = {"rear_wheel": "R", "front_wheel": "F"}
_PARTS = {
    "frame": ("B", "rear"),
    "fork": ("H", "front"),
    "fork_only": ("S", "front"),
    "handlebar": ("G", "handlebar reference"),
}
#: Sections of plain fields (not wheels nor hung parts).
_FIELD_SECTIONS = (
    ("geometry", _GEOMETRY),
    ("surface_plate", _SURFACE_PLATE),
    ("flywheel", _FLYWHEEL),
    ("calibration_rod", _ROD),
)


Lines = dict[tuple[object, ...], int]


def _walk(node: yaml.Node, path: tuple[object, ...], lines: Lines) -> None:
    lines.setdefault(path, node.start_mark.line + 1)  # a key's own line wins over its value's
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else str(k)
            lines[path + (key,)] = k.start_mark.line + 1
            _walk(v, path + (key,), lines)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _walk(v, path + (i,), lines)


def load_yaml_document(path: str | Path) -> tuple[Any, Lines]:
    """Load a YAML file and the 1-based line number of every key and item in it.

    The file is read within :data:`~bike_rig.core.safe_yaml.LIMITS` (size, nesting, aliases
    expanded), so a hostile file costs bounded time and memory; it must be a regular file (a
    FIFO or a device is refused, never read), and no mapping in it may repeat a key.

    Raises:
        InputFileError: unreadable or not a regular file, invalid YAML, a key given twice
            (naming both lines) or beyond the limits (one line, with the line of the error when
            known).
    """
    p = str(path)
    try:
        raw = read_regular_file(p, path, LIMITS.max_bytes, "a bike_rig YAML file")
        text = raw.decode("utf-8")
    except NotRegularFileError as exc:
        if exc.os_error is None or exc.os_error.errno == errno.ELOOP:  # a FIFO, a device, a directory, a loop
            raise
        raise InputFileError(p, _cannot_read(exc.os_error)) from None
    except UnicodeDecodeError as exc:
        raise InputFileError(p, _cannot_read(exc), line=raw.count(b"\n", 0, exc.start) + 1) from None
    try:
        node, loader = compose_bounded(text)
        data = construct(node, loader)
    except YamlDuplicateKeyError as exc:
        raise InputFileError(p, f"given twice (first on line {exc.first_line})", key=exc.key, line=exc.line) from None
    except YamlLimitError as exc:
        raise InputFileError(p, f"invalid YAML: {exc.reason}", line=exc.line) from None
    except yaml.YAMLError as exc:
        reason, line = yaml_error_reason(exc, text)
        raise InputFileError(p, f"invalid YAML: {reason}", line=line) from None
    lines: Lines = {}
    if node is not None:
        _walk(node, (), lines)
    return data, lines


def _cannot_read(exc: Exception) -> str:
    return f"cannot read the file ({exc.__class__.__name__}: {one_line(str(exc))})"


def _label(path: tuple[object, ...]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


class _Doc:
    """A loaded YAML document with line-aware accessors raising MeasurementError."""

    def __init__(self, path: str, data: Any, lines: Lines, static_only: bool = False):
        self.path, self.data, self.lines = path, data, lines
        self.static_only = static_only
        self.evidence: dict[str, PeriodEvidence] = {}

    def error(self, where: tuple[object, ...], reason: str) -> MeasurementError:
        line = self.lines.get(where)
        if line is None and where:
            line = self.lines.get(where[:-1])
        return MeasurementError(self.path, reason, key=_label(where) or None, line=line)

    def mapping(self, where: tuple[object, ...], value: Any) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.error(where, f"expected a mapping of keys, got {type(value).__name__}")
        return value

    def reading(self, where: tuple[object, ...], value: Any) -> tuple[float, float]:
        try:
            if isinstance(value, bool):
                raise ValueError("a boolean is not a measurement")
            if isinstance(value, (list, tuple)):
                if len(value) != 2:
                    raise ValueError(f"expected [value, sigma], got {len(value)} items")
                v, s = (_number(x) for x in value)
            elif isinstance(value, Mapping):
                unknown = set(value) - {"value", "sigma"}
                if unknown or "value" not in value or "sigma" not in value:
                    raise ValueError("expected {value: v, sigma: s}")
                v, s = _number(value["value"]), _number(value["sigma"])
            elif isinstance(value, str):
                if "+/-" not in value and "±" not in value:
                    raise ValueError(f"'{value}' has no sigma; write [value, sigma]")
                v, s = parse_value(value)
            elif isinstance(value, (int, float)):
                raise ValueError(f"{short_repr(value)} has no sigma; every measured value is [value, sigma]")
            else:
                raise ValueError(f"not a number: {short_repr(value)}")
            check_value_sigma(v, s)
        except ValueError as exc:
            raise self.error(where, str(exc)) from None
        return v, s

    def origin(self, where: tuple[object, ...]) -> Origin:
        return Origin(self.path, _label(where), self.lines.get(where))


def _trial_period(doc: _Doc, where: tuple[object, ...], spec: Mapping[str, Any]) -> PeriodEvidence:
    """A period given as ``{trials: [files], sample_rate_hz: optional}``, fitted and combined."""
    unknown = set(spec) - {"trials", "sample_rate_hz"}
    files = spec.get("trials")
    if unknown or not isinstance(files, list) or not files or not all(isinstance(f, str) for f in files):
        raise doc.error(where, "a period from trials is {trials: [file, ...], sample_rate_hz: optional}")
    rate = spec.get("sample_rate_hz")
    if rate is not None and (isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0):
        raise doc.error(where + ("sample_rate_hz",), f"must be a positive number, got {short_repr(rate)}")
    base = Path(doc.path).parent
    ev = period_from_trials([base / f for f in files], None if rate is None else float(rate))
    if ev.combined.n_used == 0:
        reasons = "; ".join(
            f"{Path(f).name}: " + (", ".join(fl.reason for fl in fit.flags) or "invalid")
            for f, fit in zip(ev.files, ev.fits)
        )
        raise doc.error(where, f"no usable trial, redo the measurement ({reasons})")
    return ev


def _number(x: Any) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, str)):
        raise ValueError(f"not a number: {short_repr(x)}")
    try:
        return float(x)
    except (ValueError, OverflowError):  # OverflowError: an integer beyond any float
        raise ValueError(f"not a number: {short_repr(x)}") from None


def _fields(
    doc: _Doc, where: tuple[object, ...], section: Any, table: Mapping[str, tuple[str, str]], fmt: Mapping[str, object]
) -> Iterator[tuple[str, Reading]]:
    sec = doc.mapping(where, section)
    for key in sec:
        if key not in table and key != "orientations":
            raise doc.error(where + (key,), f"unknown key; expected one of {', '.join(table)}")
    for key, (flat, _unit) in table.items():
        if key not in sec:
            continue
        w = where + (key,)
        if key == "rotations":
            n = sec[key]
            if isinstance(n, bool) or not isinstance(n, int) or abs(n) > MAX_MAGNITUDE:
                raise doc.error(w, f"rotations is an exact whole count, got {short_repr(n)}")
            yield flat.format(**fmt), Reading(float(n), 0.0, doc.origin(w))
        elif key.endswith("period") and doc.static_only:
            continue  # periods come from elsewhere (live trials)
        elif key.endswith("period") and isinstance(sec[key], Mapping) and "trials" in sec[key]:
            ev = _trial_period(doc, w, sec[key])
            doc.evidence[flat.format(**fmt)] = ev
            yield flat.format(**fmt), Reading(ev.value, ev.sigma, doc.origin(w))
        else:
            v, s = doc.reading(w, sec[key])
            yield flat.format(**fmt), Reading(v, s, doc.origin(w))


def _yaml_location(flat: str) -> tuple[str, ...]:
    """Where a flat key lives in the YAML layout, e.g. 'TcB1' -> ('frame', 'compound_period')."""
    if flat == "g":
        return ("gravity",)
    for section, table in _FIELD_SECTIONS:
        for key, (f, _u) in table.items():
            if f == flat:
                return (section, key)
    for section, p in _WHEELS.items():
        for key, (f, _u) in _WHEEL.items():
            if f.format(p=p) == flat:
                return (section, key)
    for section, (p, axle) in _PARTS.items():
        for key, (f, _u) in _PART.items():
            if f.format(p=p, axle=axle) == flat:
                return (section, key)
    return (flat,)


def _check_complete(doc: _Doc, readings: Mapping[str, Reading]) -> None:
    for flat in required_keys(readings):
        if doc.static_only and flat.startswith(("Tc", "Tt")):
            continue
        if flat not in readings:
            where = _yaml_location(flat)
            parent = where[:-1]
            line = doc.lines.get(parent) if parent else None
            raise MeasurementError(doc.path, missing_reason(flat), key=_label(where), line=line)


def _check_sections(doc: _Doc, top: Mapping[str, Any]) -> None:
    """Reject a top-level key that is not a section of a measurement document."""
    known = {"format", "bicycle", "attribution", "notes", "gravity", "other"} | {s for s, _t in _FIELD_SECTIONS}
    known |= set(_WHEELS) | set(_PARTS)
    for key in top:
        if key not in known:
            raise doc.error((key,), f"unknown section; expected one of {', '.join(sorted(known))}")


def _part_readings(doc: _Doc, section: str, value: Any, p: str, axle: str) -> dict[str, Reading]:
    """The readings of one part's section (frame or fork): its fields, then each orientation's."""
    sec = doc.mapping((section,), value)
    readings = dict(_fields(doc, (section,), sec, _PART, {"p": p, "axle": axle}))
    orients = sec.get("orientations", [])
    if not isinstance(orients, list):
        raise doc.error((section, "orientations"), "expected a list of orientations")
    for i, o in enumerate(orients):
        readings.update(_orientation_readings(doc, (section, "orientations", i), o, p, i))
    return readings


def _orientation_readings(doc: _Doc, w: tuple[object, ...], o: Any, p: str, i: int) -> dict[str, Reading]:
    """The readings of orientation ``i`` (0-based) of part ``p``, each of its keys required.

    With ``static_only`` the torsional period is not required.
    """
    got = dict(_fields(doc, w, o, _ORIENTATION, {"p": p, "i": i + 1}))
    for key, (flat, _u) in _ORIENTATION.items():
        if doc.static_only and key == "torsional_period":
            continue
        if flat.format(p=p, i=i + 1) not in got:
            raise doc.error(w, f"orientation {i + 1} lacks '{key}'")
    return got


def measurements_from_document(path: str, data: Any, lines: Lines, static_only: bool = False) -> Measurements:
    """Build :class:`Measurements` from a loaded ``bike_rig-measurements/1`` document.

    Args:
        path: The file, for messages.
        data: The loaded document.
        lines: Line numbers (from :func:`load_yaml_document`).
        static_only: Skip every pendulum period (they will come from live trials) and do not
            require them.

    Raises:
        MeasurementError: a key is unknown, malformed or lacks its σ (with its line).
    """
    doc = _Doc(path, data, lines, static_only)
    top = doc.mapping((), data)
    _check_sections(doc, top)
    readings: dict[str, Reading] = {}
    if "gravity" in top:
        v, s = doc.reading(("gravity",), top["gravity"])
        readings["g"] = Reading(v, s, doc.origin(("gravity",)))
    for section, table in _FIELD_SECTIONS:
        if section in top:
            readings.update(_fields(doc, (section,), top[section], table, {}))
    for section, p in _WHEELS.items():
        if section in top:
            readings.update(_fields(doc, (section,), top[section], _WHEEL, {"p": p}))
    for section, (p, axle) in _PARTS.items():
        if section in top:
            readings.update(_part_readings(doc, section, top[section], p, axle))
    _check_complete(doc, readings)
    name = top.get("bicycle")
    if not isinstance(name, str) or not name:
        raise doc.error(("bicycle",), "missing: the bicycle's name")
    other = top.get("other") or {}
    return Measurements(name, readings, path, dict(doc.mapping(("other",), other)), doc.evidence)


def parameters_from_document(path: str, data: Any, lines: Lines) -> ParameterSet:
    """A :class:`ParameterSet` from our parameter YAML or a BicycleParameters parameter set.

    Accepts ``bike_rig-parameters/1`` (values with σ), BicycleParameters' parameter-set YAML
    (``values:`` of plain floats, σ = 0) and a flat mapping of the 26 keys to floats.
    """
    doc = _Doc(path, data, lines)
    top = doc.mapping((), data)
    if top.get("format") == PARAMETERS_FORMAT:
        where: tuple[object, ...] = ("parameters",)
        table = doc.mapping(where, top.get("parameters"))
        name = str(top.get("bicycle") or Path(path).stem)
        with_sigma = True
    elif "values" in top:
        where = ("values",)
        table = doc.mapping(where, top["values"])
        name = str(top.get("parameters") or Path(path).stem)
        with_sigma = False
    else:
        where, table, name, with_sigma = (), top, Path(path).stem, False
    values, sigmas = {}, {}
    for key in PARAMETER_NAMES:
        w = where + (key,)
        if key not in table:
            raise doc.error(w, "missing (one of the benchmark parameters)")
        if with_sigma:
            values[key], sigmas[key] = doc.reading(w, table[key])
        else:
            try:
                values[key] = _number(table[key])
            except ValueError as exc:
                raise doc.error(w, str(exc)) from None
        try:
            check_value_sigma(values[key], sigmas.get(key, 0.0))
        except ValueError as exc:
            raise doc.error(w, str(exc)) from None
    ps = parameters_from_values(name, values, sigmas, path)
    if with_sigma and top.get("parts") is not None:
        return replace(ps, parts=_parts(doc, top["parts"]))
    return ps


def _parts(doc: _Doc, value: Any) -> UncertainVector:
    """The ``parts:`` section of a parameter file: per-part outputs with σ, each group whole."""
    table = doc.mapping(("parts",), value)
    known = [k for group in PART_GROUPS for k in group]
    for key in table:
        if key not in known:
            raise doc.error(("parts", key), f"unknown key; expected one of {', '.join(known)}")
    names: list[str] = []
    for group in PART_GROUPS:
        if any(k in table for k in group):
            for key in group:
                if key not in table:
                    raise doc.error(("parts", key), f"missing (the per-part outputs {', '.join(group)} come whole)")
            names += group
    got = [doc.reading(("parts", key), table[key]) for key in names]
    return UncertainVector(tuple(names), np.array([v for v, _ in got]), np.diag([s * s for _, s in got]))


def _scalar(text: str) -> str:
    """``text`` as a one-line YAML scalar (quoted when it must be; control characters and newlines escaped)."""
    lines = yaml.safe_dump(text, width=1 << 16, allow_unicode=True).splitlines()
    if len(lines) > 1 and lines[1] != "...":  # a single-quoted scalar folded over lines
        lines = yaml.safe_dump(text, width=1 << 16, allow_unicode=True, default_style='"').splitlines()
    return lines[0]


def _pair(r: Reading) -> str:
    return f"[{r.value!r}, {r.sigma!r}]"


def _rows(r: Mapping[str, Reading], table: Mapping[str, tuple[str, str]], fmt: Mapping[str, object]) -> list[str]:
    """The lines of a section's fields present in ``r``, each with its unit in a comment."""
    found = []
    for key, (flat, unit) in table.items():
        k = flat.format(**fmt)
        if k in r:
            val = str(int(r[k].value)) if key == "rotations" else _pair(r[k])
            found.append(f"  {key}: {val}  # {unit.format(**fmt)}")
    return found


def _part_rows(m: Measurements, p: str, axle: str) -> list[str]:
    """The lines of one part's section: its fields, then its orientations (one flow mapping each)."""
    r = m.readings
    body = _rows(r, _PART, {"p": p, "axle": axle})
    idx = m.orientations(p)
    if idx:
        body.append("  orientations:  # angle_deg: degrees; distance: m; torsional_period: s")
        for i in idx:
            flats = {key: flat.format(p=p, i=i) for key, (flat, _u) in _ORIENTATION.items()}
            items = [f"{key}: {_pair(r[flat])}" for key, flat in flats.items() if flat in r]
            body.append("    - {" + ", ".join(items) + "}")
    return body


def _section(out: list[str], name: str, body: list[str]) -> None:
    """Append section ``name`` with its lines to ``out``, unless it has none."""
    if body:
        out.append(f"{name}:")
        out.extend(body)


def dump_measurements_yaml(m: Measurements, attribution: str | None = None) -> str:
    """A ``bike_rig-measurements/1`` document for ``m``, with units in comments.

    Values are written with Python's shortest round-trip repr, so reading the file back gives
    bit-identical readings.
    """
    r = m.readings
    out = [f"format: {MEASUREMENTS_FORMAT}", f"bicycle: {_scalar(m.bicycle)}"]
    if attribution:
        out.append(f"attribution: {yaml.safe_dump(attribution, width=1 << 16).splitlines()[0]}")
    out.append("# SI units; angles in degrees only where the key ends in _deg. Every value: [value, sigma].")
    if "g" in r:
        out.append(f"gravity: {_pair(r['g'])}  # m/s^2")

    _section(out, "geometry", _rows(r, _GEOMETRY, {}))
    _section(out, "surface_plate", _rows(r, _SURFACE_PLATE, {}))
    for name, p in _WHEELS.items():
        _section(out, name, _rows(r, _WHEEL, {"p": p}))
    _section(out, "flywheel", _rows(r, _FLYWHEEL, {}))
    for name, (p, axle) in _PARTS.items():
        _section(out, name, _part_rows(m, p, axle))
    _section(out, "calibration_rod", _rows(r, _ROD, {}))
    if m.extras:
        out.append("other:  # recorded but not needed for the benchmark parameters, kept verbatim")
        for k, v in m.extras.items():
            out.append(f"  {k}: {yaml.safe_dump(v, width=1 << 16).splitlines()[0]}")
    return "\n".join(out) + "\n"


def dump_parameters_yaml(params: ParameterSet, attribution: str | None = None) -> str:
    """A ``bike_rig-parameters/1`` document: the 26 parameters as ``[value, sigma]``."""
    out = [f"format: {PARAMETERS_FORMAT}", f"bicycle: {_scalar(params.bicycle)}"]
    if attribution:
        out.append(f"attribution: {yaml.safe_dump(attribution, width=1 << 16).splitlines()[0]}")
    out.append("# SI units (lam in rad). Every value: [value, sigma].")
    out.append("parameters:")
    pv = params.parameters
    for name in PARAMETER_NAMES:
        out.append(f"  {name}: [{pv.value(name)!r}, {pv.sigma(name)!r}]")
    if params.parts is not None:
        out.append("parts:  # per-part outputs (fork S, handlebar G measured separately), [value, sigma]")
        for name in params.parts.names:
            out.append(f"  {name}: [{params.parts.value(name)!r}, {params.parts.sigma(name)!r}]")
    return "\n".join(out) + "\n"
