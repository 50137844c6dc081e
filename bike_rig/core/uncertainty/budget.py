"""Uncertainty budget: which measurement dominates the σ of each parameter and critical speed.

For every output ``y`` (the 25 benchmark parameters, and the weave and capsize speeds when the
bicycle has them) the first-order variance (paper Eq 3) is split over the inputs:

* **raw readings** (a measurement file or a session bag, ``ps.raw`` set): the inputs are the
  uncertain readings, every period and every static reading (the columns of
  ``ps.raw.jacobian``). They are independent (diagonal covariance), so with the sensitivity
  ``s_j = ∂y/∂x_j`` and the reading's σ_j

      σ_y² = Σ_j (s_j σ_j)²,   share_j = (s_j σ_j)² / σ_y²,   contribution_j = |s_j| σ_j.

  A parameter's sensitivities are its row of ``ps.raw.jacobian``; a speed's are
  ``∂v/∂p @ ps.raw.jacobian`` with ``∂v/∂p`` from the implicit function theorem
  (:func:`bike_rig.core.uncertainty.speed_sigma.critical_speeds_with_sigma`).
* **parameters** (a parameter file, ``ps.raw`` None): the inputs are the 26 parameters with
  the parameter covariance. A parameter file gives independent σ, so each parameter's budget is
  itself (share 1) and the speeds split over the parameters as above.

**Correlated inputs.** When the input covariance has off-diagonal terms (e.g. a parameter file
with a rider added, whose rear-frame parameters ``mB, xB, zB, IB**`` all depend on ``mB``),
a share per single input is not defined: the cross terms ``2 s_i s_j Σ_ij`` belong to no one
input and can be negative. The inputs are then grouped into the connected blocks of the
covariance (inputs linked by a non-zero correlation, transitively), each block is one budget
input named by its members joined with ``+`` (e.g. ``IBxx+IBxz+IByy+IBzz+mB+xB+zB``), and its
share is ``s_G Σ_GG s_Gᵀ / σ_y²`` with contribution ``sqrt(s_G Σ_GG s_Gᵀ)``. Blocks are
mutually independent, so shares are non-negative and sum to 1 exactly, and a diagonal
covariance gives the single-input formula above. Raw readings are always independent, so
measurement files and bags never need grouping.

**Input names.** Inputs are named as the input file names them: the core keeps readings under
BicycleParameters' keys (``aH3``, ``mP``), and :func:`reading_names` maps each to the name its
file gave it (:attr:`bike_rig.core.measurements.Origin.key`): ``fork.orientations[2].distance``
in a bike_rig YAML measurement file, ``aH3`` in a ``Measured.txt``. Pass that mapping to
:func:`uncertainty_budget` as ``names``; every share and the budget also keep the
BicycleParameters key (:attr:`BudgetShare.key`, :attr:`UncertaintyBudget.input_keys`).

**Named σ parts.** A reading's σ may include a named part, e.g. the small-swing period's
systematic (:mod:`bike_rig.core.period.small_swing`): given as ``sigma_parts``, the reading's
share is split into a line ``<input> (<source>)`` of ``(σ part / σ)²`` of it and the rest, so
the budget shows how much that systematic limits each output.

An output with σ = 0 (e.g. the benchmark parameter file, which carries no σ) has no shares.
A critical speed at a double root has no derivative: its σ is NaN and it has no shares.

Units: every value, σ and contribution is in the output's SI unit (:data:`OUTPUT_UNITS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..benchmark import ParameterSet
from ..errors import BikeRigError
from ..feedback import Feedback
from ..measurements import Measurements
from ..symbols import PARAMETER_NAMES
from .speed_sigma import CriticalSpeedsWithSigma, SpeedWithSigma, critical_speeds_with_sigma

__all__ = [
    "BUDGET_PARAMETERS",
    "CAPSIZE",
    "OUTPUT_UNITS",
    "WEAVE",
    "BudgetError",
    "BudgetShare",
    "InputImportance",
    "OutputBudget",
    "SystematicShift",
    "UncertaintyBudget",
    "budget_json",
    "input_ranking",
    "reading_names",
    "uncertainty_budget",
]

FloatArray = NDArray[np.float64]

#: Output names of the two critical speeds.
WEAVE = "weave speed"
CAPSIZE = "capsize speed"

#: The 25 benchmark parameters (PARAMETER_NAMES without g), the budget's parameter outputs.
BUDGET_PARAMETERS: tuple[str, ...] = tuple(n for n in PARAMETER_NAMES if n != "g")

#: SI unit of every parameter (and g) and of the two speeds.
OUTPUT_UNITS: dict[str, str] = {
    **{n: "kg m²" for n in PARAMETER_NAMES if n.startswith("I")},
    **{n: "kg" for n in ("mB", "mF", "mH", "mR")},
    **{n: "m" for n in ("c", "rF", "rR", "w", "xB", "xH", "zB", "zH")},
    "lam": "rad",
    "g": "m/s²",
    WEAVE: "m/s",
    CAPSIZE: "m/s",
}

#: Input kinds (:attr:`UncertaintyBudget.input_kind`).
RAW_READINGS = "raw readings"
PARAMETERS = "parameters"

#: Relative size below which an off-diagonal covariance entry is taken as round-off, not a
#: correlation (|Σ_ij| ≤ this × σ_i σ_j).
CORRELATION_FLOOR = 1e-12


class BudgetError(BikeRigError):
    """A budget was asked for something it does not hold (e.g. an unknown output)."""


@dataclass(frozen=True)
class BudgetShare:
    """One input's part of an output's variance.

    Attributes:
        input: The input as its file names it (``frame.orientations[1].angle_deg`` in a
            bike_rig YAML, ``alphaB2`` in a ``Measured.txt``; see :func:`reading_names`), or
            the parameter name; a group of correlated inputs is named by its members joined
            with ``+``.
        share: Fraction of the output's first-order variance, 0..1.
        contribution: ``|∂output/∂input| σ_input`` (for a group ``sqrt(s Σ sᵀ)``), in the
            output's unit.
        key: The BicycleParameters key of the input (``alphaB2``, ``TtB1``) or the parameter
            name, members joined with ``+``; equal to ``input`` when the file uses these keys.
    """

    input: str
    share: float
    contribution: float
    key: str = ""


@dataclass(frozen=True)
class SystematicShift:
    """How much an output moves under a stated alternative of the analysis (not a σ).

    Attributes:
        source: The alternative, e.g. "finite swing: the small-swing periods instead of the mean".
        shift: The output's first-order change, ``Σ_j ∂y/∂x_j Δx_j``, in the output's unit.
    """

    source: str
    shift: float


@dataclass(frozen=True)
class OutputBudget:
    """The variance budget of one output.

    Attributes:
        output: Parameter name, or ``"weave speed"`` / ``"capsize speed"``.
        value: Its value, in ``unit``.
        sigma: First-order σ (square root of the summed variance), in ``unit``; NaN for a
            speed at a double root.
        unit: SI unit of value, σ and contributions (e.g. ``"kg m²"``, ``"m/s"``).
        shares: Every input with share > 0, largest first (empty when σ is 0 or NaN).
        systematic: The output's shifts under the stated alternatives (the systematic lines).
    """

    output: str
    value: float
    sigma: float
    unit: str
    shares: tuple[BudgetShare, ...]
    systematic: tuple[SystematicShift, ...] = ()


@dataclass(frozen=True)
class UncertaintyBudget:
    """A bicycle's uncertainty budget.

    Attributes:
        bicycle: The bicycle's name (with the rider's, when one was added).
        input_kind: ``"raw readings"`` (measurement file, bag) or ``"parameters"``
            (parameter file).
        inputs: Every input considered (budget input names, see :class:`BudgetShare`), in
            the order of the propagation; inputs with σ = 0 included.
        outputs: The 25 parameters in PARAMETER_NAMES order, then the weave and capsize
            speeds when the bicycle has them.
        input_keys: The BicycleParameters key of each of ``inputs``, in the same order.
        feedback: "" (the open loop) or the name of the steer-torque feedback whose closed
            loop the weave and capsize speeds are of.
    """

    bicycle: str
    input_kind: str
    inputs: tuple[str, ...]
    outputs: tuple[OutputBudget, ...]
    input_keys: tuple[str, ...] = ()
    feedback: str = ""

    def output(self, name: str) -> OutputBudget:
        """The budget of output ``name`` (a parameter name, ``"weave speed"`` or ``"capsize speed"``).

        Raises:
            BudgetError: No such output (e.g. a speed the bicycle does not have).
        """
        for o in self.outputs:
            if o.output == name:
                return o
        known = ", ".join(o.output for o in self.outputs)
        raise BudgetError(f"the budget of {self.bicycle} has no output '{name}' (it has: {known})")

    def top(self, name: str, n: int = 5) -> tuple[BudgetShare, ...]:
        """The ``n`` largest shares of output ``name``."""
        return self.output(name).shares[: max(n, 0)]


@dataclass(frozen=True)
class InputImportance:
    """How much one input matters over several outputs (what to measure better).

    Attributes:
        input: The budget input.
        mean_share: Its share averaged over the outputs considered that have σ > 0 (0..1).
        leads: The outputs where it has the largest share.
    """

    input: str
    mean_share: float
    leads: tuple[str, ...]


def _groups(covariance: FloatArray) -> list[list[int]]:
    """Connected blocks of inputs linked by non-negligible covariance, in first-index order."""
    n = covariance.shape[0]
    s = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    linked = np.abs(covariance) > CORRELATION_FLOOR * np.outer(s, s)
    np.fill_diagonal(linked, False)
    seen = [False] * n
    out: list[list[int]] = []
    for start in range(n):
        if seen[start]:
            continue
        block, stack = [], [start]
        seen[start] = True
        while stack:
            i = stack.pop()
            block.append(i)
            for j in np.flatnonzero(linked[i]):
                if not seen[j]:
                    seen[j] = True
                    stack.append(int(j))
        out.append(sorted(block))
    return out


def _output_budget(
    name: str,
    value: float,
    sens: FloatArray,
    covariance: FloatArray,
    groups: list[list[int]],
    labels: list[tuple[str, str]],
    named: Mapping[int, list[tuple[str, float]]] | None = None,
) -> OutputBudget:
    unit = OUTPUT_UNITS[name]
    if not np.all(np.isfinite(sens)):
        return OutputBudget(name, value, math.nan, unit, ())
    parts = np.array([float(sens[g] @ covariance[np.ix_(g, g)] @ sens[g]) for g in groups])
    parts = np.clip(parts, 0.0, None)  # a group's variance is ≥ 0 (round-off of a PSD block)
    total = float(parts.sum())
    if not total > 0.0:
        return OutputBudget(name, value, 0.0, unit, ())
    lines: list[tuple[str, float, str]] = []  # (line, its variance, key)
    for k in (k for k in range(len(groups)) if parts[k] > 0.0):
        label, key = labels[k]
        rest = 1.0
        for source, fraction in (named or {}).get(k, []):  # (a fraction of the input's variance)
            lines.append((f"{label} ({source})", float(parts[k]) * fraction, key))
            rest -= fraction
        if rest > 0.0:
            lines.append((label, float(parts[k]) * rest if rest < 1.0 else float(parts[k]), key))
    lines.sort(key=lambda line: -line[1])
    shares = tuple(BudgetShare(label, v / total, math.sqrt(v), key) for label, v, key in lines)
    return OutputBudget(name, value, math.sqrt(total), unit, shares)


def _sigma_parts(
    keys: Sequence[str],
    covariance: FloatArray,
    groups: list[list[int]],
    sigma_parts: Mapping[str, Mapping[str, float]],
) -> dict[int, list[tuple[str, float]]]:
    """Per group of one input with named σ parts: (source, fraction of its variance), at most 1 in all."""
    out: dict[int, list[tuple[str, float]]] = {}
    for k, group in enumerate(groups):
        if len(group) != 1:
            continue
        i = group[0]
        variance = float(covariance[i, i])
        left = 1.0
        for source, by_key in sigma_parts.items():
            part = float(by_key.get(keys[i], 0.0))
            if variance > 0.0 and math.isfinite(part) and part > 0.0:
                fraction = min(left, part * part / variance)
                left -= fraction
                out.setdefault(k, []).append((source, fraction))
    return out


def _speeds(ps: ParameterSet, feedback: Feedback | None = None) -> list[tuple[str, SpeedWithSigma]]:
    cs: CriticalSpeedsWithSigma = critical_speeds_with_sigma(ps, feedback=feedback)
    out = []
    for name, sp in ((WEAVE, cs.weave), (CAPSIZE, cs.capsize)):
        if sp is not None:
            out.append((name, sp))
    return out


def reading_names(m: Measurements) -> dict[str, str]:
    """Each reading's BicycleParameters key → the name its input file gave it.

    Args:
        m: The readings, as loaded (each with its :class:`~bike_rig.core.measurements.Origin`).

    Returns:
        ``{key: origin key}``: ``{"aH3": "fork.orientations[2].distance", "TcB1":
        "frame.compound_period", ...}`` for a bike_rig YAML file, ``{"aH3": "aH3", ...}`` for a
        ``Measured.txt`` or a bag; the key itself where the origin is unknown.
    """
    return {k: (r.origin.key if r.origin is not None and r.origin.key else k) for k, r in m.readings.items()}


def uncertainty_budget(
    ps: ParameterSet,
    names: Mapping[str, str] | None = None,
    systematic: Mapping[str, Mapping[str, float]] | None = None,
    feedback: Feedback | None = None,
    sigma_parts: Mapping[str, Mapping[str, float]] | None = None,
) -> UncertaintyBudget:
    """Rank every input by its share of the variance of each parameter and critical speed.

    Args:
        ps: The parameter set (pass ``add_rider(ps, PAPER_RIDER)`` for bicycle plus rider).
            With ``ps.raw`` the inputs are the raw readings, else the 26 parameters.
        names: The input file's name of each input key (:func:`reading_names`); None (or a
            key missing from it) names an input by its key.
        systematic: Alternatives of the analysis, each ``{source: {input key: Δx}}`` (e.g.
            the small-swing periods instead of the mean, per period key, s): every output
            gets its first-order shift under each as a systematic line. Keys that are not
            inputs are ignored.
        feedback: Steer-torque state feedback: the weave and capsize speeds are the closed
            loop's; its gain values given with σ are further inputs (``feedback.<key>``,
            independent). None: the open loop.
        sigma_parts: Named parts of the inputs' σ, each ``{source: {input key: σ part}}``
            (e.g. the small-swing period's systematic, per period key, s): an input's share is
            split into a line ``<input> (<source>)`` of ``(σ part / σ)²`` of it and the rest,
            so a budget shows what a systematic contributes. Keys that are not single
            independent inputs are ignored.

    Returns:
        The budget: 25 parameters (PARAMETER_NAMES order without g), then the weave and
        capsize speeds when they exist.
    """
    values = ps.parameters.as_dict()
    rows = [PARAMETER_NAMES.index(n) for n in BUDGET_PARAMETERS]
    if ps.raw is not None:
        kind, keys = RAW_READINGS, list(ps.raw.names)
        covariance = np.asarray(ps.raw.covariance, dtype=float)
        to_input = np.asarray(ps.raw.jacobian, dtype=float)  # ∂p/∂x, (26, n)
    else:
        kind, keys = PARAMETERS, list(PARAMETER_NAMES)
        covariance = np.asarray(ps.parameters.covariance, dtype=float)
        to_input = np.eye(len(PARAMETER_NAMES))
    knots = feedback.uncertain_knots() if feedback is not None else ()
    if knots:  # the feedback's gains given with σ: further independent inputs, after the others
        n, m = len(keys), len(knots)
        keys = keys + [f"feedback.{k[3]}" for k in knots]
        covariance = np.block(
            [
                [covariance, np.zeros((n, m))],
                [np.zeros((m, n)), np.diag([k[2] ** 2 for k in knots])],
            ]
        )
        to_input = np.hstack([to_input, np.zeros((to_input.shape[0], m))])
    groups = _groups(covariance)
    own = names or {}
    labels = [("+".join(own.get(keys[i], keys[i]) for i in g), "+".join(keys[i] for i in g)) for g in groups]
    parts = _sigma_parts(keys, covariance, groups, sigma_parts or {})
    outputs = [
        _output_budget(n, values[n], to_input[r], covariance, groups, labels, parts)
        for n, r in zip(BUDGET_PARAMETERS, rows)
    ]
    shifts = _input_shifts(keys, systematic or {})
    outputs = [replace(o, systematic=_shifts(to_input[r], shifts)) for o, r in zip(outputs, rows, strict=True)]
    for name, sp in _speeds(ps, feedback):
        grad = sp.gradient if sp.gradient is not None else np.full(len(PARAMETER_NAMES), math.nan)
        sens = grad @ to_input
        if knots:
            sens[-len(knots) :] = sp.gain_gradient if sp.gain_gradient is not None else math.nan
        o = _output_budget(name, sp.speed, sens, covariance, groups, labels, parts)
        outputs.append(replace(o, systematic=_shifts(sens, shifts)))
    inputs = tuple(label for label, _ in labels)
    keys_out = tuple(key for _, key in labels)
    fb_name = "" if feedback is None else feedback.name
    return UncertaintyBudget(ps.bicycle, kind, inputs, tuple(outputs), keys_out, fb_name)


def _input_shifts(keys: Sequence[str], systematic: Mapping[str, Mapping[str, float]]) -> list[tuple[str, FloatArray]]:
    """Each alternative's input changes as a vector over ``keys`` (alternatives touching no input dropped)."""
    out = []
    for source, by_key in systematic.items():
        delta = np.array([float(by_key.get(k, 0.0)) for k in keys])
        if np.any(delta != 0.0):
            out.append((source, delta))
    return out


def _shifts(sensitivity: FloatArray, shifts: list[tuple[str, FloatArray]]) -> tuple[SystematicShift, ...]:
    return tuple(SystematicShift(source, float(sensitivity @ delta)) for source, delta in shifts)


def input_ranking(b: UncertaintyBudget, outputs: Sequence[str] | None = None) -> tuple[InputImportance, ...]:
    """The inputs ranked by their mean share over ``outputs``: the measurements to improve first.

    Args:
        b: The budget.
        outputs: Output names to average over (default: all of the budget's outputs); outputs
            with σ = 0 or NaN are skipped.

    Returns:
        Every input with a non-zero mean share, largest first.

    Raises:
        BudgetError: An output name is unknown.
    """
    chosen = [b.output(n) for n in outputs] if outputs is not None else list(b.outputs)
    counted = [o for o in chosen if o.shares]
    total: dict[str, float] = {}
    leads: dict[str, list[str]] = {}
    for o in counted:
        for s in o.shares:
            total[s.input] = total.get(s.input, 0.0) + s.share
        leads.setdefault(o.shares[0].input, []).append(o.output)
    n = max(len(counted), 1)
    ranked = sorted(total, key=lambda k: -total[k])
    return tuple(InputImportance(k, total[k] / n, tuple(leads.get(k, ()))) for k in ranked)


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def budget_json(b: UncertaintyBudget) -> dict[str, Any]:
    """The budget as one JSON-ready object (NaN as None).

    ``{"bicycle", "input_kind", "inputs": [...], "input_keys": [...], "outputs": [{"output",
    "value", "sigma", "unit", "shares": [{"input", "key", "share", "contribution"}],
    "systematic": [{"source", "shift"}]}]}``:
    ``inputs`` and each share's ``input`` name the inputs as their file does, ``input_keys``
    and ``key`` by their BicycleParameters keys. With a feedback, ``"feedback"`` (its name)
    follows ``"bicycle"``: the speeds are then the closed loop's.
    """
    head: dict[str, Any] = {"bicycle": b.bicycle}
    if b.feedback:
        head["feedback"] = b.feedback
    return {
        **head,
        "input_kind": b.input_kind,
        "inputs": list(b.inputs),
        "input_keys": list(b.input_keys),
        "outputs": [
            {
                "output": o.output,
                "value": _num(o.value),
                "sigma": _num(o.sigma),
                "unit": o.unit,
                "shares": [
                    {"input": s.input, "key": s.key, "share": _num(s.share), "contribution": _num(s.contribution)}
                    for s in o.shares
                ],
                "systematic": [{"source": x.source, "shift": _num(x.shift)} for x in o.systematic],
            }
            for o in b.outputs
        ],
    }
