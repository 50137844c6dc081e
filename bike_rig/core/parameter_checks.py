"""Parameters refused when impossible, each broken rule traced back to where it came from.

:func:`compute_checked` (raw readings → parameters) refuses a result breaking a rule of
:mod:`bike_rig.core.plausibility`, naming the readings it came from: for I_yy ≤ 0 the period,
the arm and the shortest period giving a positive moment (Eq 28, :func:`compound_period_min`),
else the readings that move the result most (complex-step derivatives). :func:`check_parameter_set`
checks a parameter file's set, naming the unit a mistyped value was likely in. Both raise
:class:`~bike_rig.core.plausibility.ImplausibleParametersError` (one line, exit 2); a rider is
checked where it is read (:func:`bike_rig.core.rider.check_rider_body`).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from .benchmark import ComMethod, ParameterSet, benchmark_formulas, compute_parameters
from .inertia import fork_pendulum_length, frame_pendulum_length
from .measurements import Measurements, fork_is_split
from .plausibility import (
    UNITS,
    ImplausibleParametersError,
    Violation,
    violations,
)
from .reading_ranges import parameter_unit_mistakes, reading_unit
from .uncertainty.uncertain import complex_step_jacobian

__all__ = [
    "check_parameter_set",
    "compound_period_min",
    "compute_checked",
    "trace_violation",
]

#: Readings named for a rule broken by a computed result: the most influential ones.
TRACED_READINGS = 3


def compound_period_min(l: float, g: float) -> float:  # noqa: E741
    """The shortest compound-pendulum period with a positive moment about the mass centre (from Eq 28).

    I = (T / 2π)² m g l − m l² > 0 needs T > 2π √(l / g).

    Args:
        l: Distance from the pivot to the mass centre, m.
        g: Acceleration of gravity, m/s².

    Returns:
        The period, s.
    """
    return 2.0 * math.pi * math.sqrt(l / g)


def _unit(key: str) -> str:
    u = reading_unit(key)
    return {"m/s^2": "m/s²", "1": ""}.get(u, u)


def _reading(key: str, value: float) -> str:
    unit = _unit(key)
    return f"{key} = {value:.6g}" + (f" {unit}" if unit else "")


def _result(names: Sequence[str], values: Sequence[float]) -> str:
    return ", ".join(f"{n} = {v:.6g} {UNITS.get(n, '')}".rstrip() for n, v in zip(names, values))


def _arm(part: str, p: Mapping[str, float], m: Measurements) -> tuple[str, float] | None:
    """The compound pendulum's arm of part R, F, B or H: (its words, m), or None when not simple."""
    if part in "RF":
        key = f"l{part}"
        return (key, m.readings[key].value) if key in m.readings else None
    if part == "B":
        return "the frame's arm l_B (Eq 36)", float(frame_pendulum_length(p["xB"], p["zB"], p["rR"]))
    if part == "H" and not fork_is_split(m.readings):
        return "the fork's arm l_H (Eq 37)", float(fork_pendulum_length(p["xH"], p["zH"], p["w"], p["rF"]))
    return None


def _compound(v: Violation, p: Mapping[str, float], m: Measurements) -> str | None:
    """``TcR1 = 0.1 s with lR = 0.293 m gives IRyy = -0.265 kg m²: ...`` for a moment I_yy ≤ 0, else None."""
    if len(v.names) != 1 or len(v.names[0]) != 4 or not v.names[0].endswith("yy") or p[v.names[0]] > 0:
        return None
    part = v.names[0][1]
    period, arm = f"Tc{part}1", _arm(part, p, m)
    if period not in m.readings or arm is None or not arm[1] > 0 or not p["g"] > 0:
        return None
    words, length = arm
    shown = f"{words} = {length:.6g} m"
    need = compound_period_min(length, p["g"])
    return (
        f"{_reading(period, m.readings[period].value)} with {shown} gives {_result(v.names, v.values)}: "
        f"a compound period of at least {need:.4g} s is needed (Eq 28: I = (T/2π)² m g l − m l² > 0 "
        f"needs T > 2π√(l/g))"
    )


def _part_of(names: Sequence[str]) -> str:
    """The body the parameters belong to (``B`` for IBxx...), "" for none or several."""
    parts = {n[1] if n.startswith("I") else n[1:] for n in names if n[:1] in "Imxz" and len(n) >= 2}
    return parts.pop() if len(parts) == 1 else ""


def _influential(names: Sequence[str], m: Measurements, method: ComMethod, lump: bool) -> list[str]:
    """The readings that move ``names`` most, the body's own readings first.

    The influence of a reading is |∂result/∂reading| times its value (a relative change), or
    times one degree for an angle (an angle is an offset: its size means nothing).
    """
    inputs = {k: float(r.value) for k, r in m.readings.items()}
    keys = [k for k in inputs if math.isfinite(inputs[k])]
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prop = complex_step_jacobian(lambda x: benchmark_formulas(x, method, lump), inputs, keys, list(names))
    except (ArithmeticError, ValueError, KeyError):
        return []
    scale = np.array([1.0 if reading_unit(k) == "deg" else abs(inputs[k]) for k in keys])
    weight = np.nan_to_num(np.abs(prop.jacobian) * scale).sum(axis=0)
    part = _part_of(names)
    own = [bool(part) and re.fullmatch(rf"(Tt|Tc|alpha|a|m){part}\d*", k) is not None for k in keys]
    order = sorted((i for i in range(len(keys)) if weight[i] > 0), key=lambda i: (not own[i], -weight[i]))
    return [keys[i] for i in order[:TRACED_READINGS]]


def trace_violation(
    v: Violation, p: Mapping[str, float], m: Measurements, method: ComMethod = ComMethod.CENTROID, lump: bool = False
) -> str:
    """One broken rule of a computed set in words that name the readings it came from.

    Args:
        v: The violation (of :func:`~bike_rig.core.plausibility.violations`).
        p: The computed parameters, SI.
        m: The readings they were computed from.
        method: The mass-centre method used.
        lump: Whether a flywheel was lumped into the front wheel.
    """
    special = _compound(v, p, m)
    if special is not None:
        return special
    keys = [n for n in v.names if n in m.readings]  # a parameter that is a reading itself (mB, g, w...)
    keys += [k for k in _influential(v.names, m, method, lump) if k not in keys]
    if not keys:
        return str(v)
    readings = ", ".join(_reading(k, m.readings[k].value) for k in keys)
    return f"{readings} give {v}"


def compute_checked(
    m: Measurements, method: ComMethod = ComMethod.CENTROID, lump_flywheel: bool = False
) -> ParameterSet:
    """The benchmark parameters of the readings, refused when they are not physically possible.

    Raises:
        ImplausibleParametersError: naming the file, each broken rule and the readings it came from.
        MeasurementError, GeometryError: as :func:`~bike_rig.core.benchmark.compute_parameters`.
    """
    with np.errstate(all="ignore"):
        ps = compute_parameters(m, method, lump_flywheel)
    found = violations(ps)
    if found:
        p = ps.values()
        traced = [trace_violation(v, p, m, method, lump_flywheel) for v in found]
        raise ImplausibleParametersError(f"{m.path}: bicycle '{m.bicycle}'", found, traced)
    return ps


def check_parameter_set(ps: ParameterSet, where: str | None = None) -> ParameterSet:
    """``ps`` itself when it is physically possible (a parameter file's set: the file's keys are named).

    A broken rule that a wrong unit explains says so (``lam = 18 rad ... looks like degrees``).

    Raises:
        ImplausibleParametersError: naming the file and every broken rule.
    """
    found = violations(ps)
    if not found:
        return ps
    hints = {u.key: u for u in parameter_unit_mistakes(ps.values())}
    texts = []
    for v in found:
        hint = next((hints[n] for n in v.names if n in hints), None)
        texts.append(str(v) + (f" ({hint.key} looks like {' or '.join(hint.likely)})" if hint else ""))
    label = f"{where or ps.source}: parameter set '{ps.bicycle}'"
    raise ImplausibleParametersError(label, found, texts)
