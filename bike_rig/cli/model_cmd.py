"""``bike-rig model FILE``: the canonical matrices, the weave and capsize speeds and the eigenvalues, with σ.

FILE is a measurement or parameter file. Prints M, C1, K0, K2 with σ, the weave and capsize
speeds with σ (m/s; :func:`bike_rig.core.uncertainty.speed_sigma.critical_speeds_with_sigma`,
as the model node, ``replay`` and ``report`` compute them) and the eigenvalues (1/s) over the
speeds; ``--json`` as :func:`model_json` (a speed is null when there is no crossing). With
``--feedback FILE`` speeds and eigenvalues are the closed loop's ``A − B K`` (matrices stay the
bicycle's), adding ``feedback``, ``stable_speed_ranges`` and ``open_loop``
(:func:`feedback_json`). Bad inputs: one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

import numpy as np

from ..core.feedback import GAIN_KEYS, GAIN_UNITS, Feedback
from ..core.rider import add_rider
from ..core.textfmt import format_speed
from ..core.uncertainty.matrix_sigma import MatrixSet, SigmaConvention, canonical_with_sigma
from ..core.uncertainty.speed_sigma import CriticalSpeedsWithSigma, critical_speeds_with_sigma
from ..core.whipple import EigenvalueSweep, eigenvalues
from ..core.whipple.closed_loop import closed_loop_stable_range
from . import format as fmt
from .commands import HELP
from .common import emit, feedback_from_spec, rider_from_spec
from .main import _common, _parameters, _speeds
from .options import add_feedback_option

__all__ = ["add_parser", "feedback_json", "feedback_text", "model_json", "run", "speeds_text"]


def add_parser(sub: Any) -> None:
    """Register ``bike-rig model`` on the ``bike-rig`` sub-command parser."""
    q = sub.add_parser("model", help=HELP["model"])
    _common(q)
    q.add_argument("--rider", help="'paper' for the paper's rigid rider (Table 1), or a rider YAML file")
    add_feedback_option(q)
    q.add_argument("--speeds", nargs=3, metavar=("START", "STOP", "N"), help="speeds in m/s (default 0 10 11)")
    q.add_argument("--sigma", choices=[c.value for c in SigmaConvention], default="correlated")
    q.add_argument("--json", action="store_true", help="one JSON object on standard output")
    q.set_defaults(func=run)


def _number(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def model_json(ms: MatrixSet, cs: CriticalSpeedsWithSigma, speeds: np.ndarray, eig: EigenvalueSweep) -> dict[str, Any]:
    """The ``--json`` object (matrices in SI, speeds m/s, eigenvalues 1/s).

    Keys: ``M``, ``C1``, ``K0``, ``K2`` and their ``*_sigma``, ``weave_speed``, ``capsize_speed``
    and their ``*_sigma`` (None when absent or not simple), ``speeds``, ``modes``, and
    ``eigenvalues`` (per speed, ``{"re", "im"}`` per mode).
    """
    out: dict[str, Any] = {}
    for name in ("M", "C1", "K0", "K2"):
        out[name] = np.asarray(getattr(ms.matrices, name)).tolist()
    for name in ("M", "C1", "K0", "K2"):
        out[f"{name}_sigma"] = np.asarray(getattr(ms.sigma, name)).tolist()
    for label, speed in (("weave", cs.weave), ("capsize", cs.capsize)):
        out[f"{label}_speed"] = None if speed is None else speed.speed
        out[f"{label}_speed_sigma"] = None if speed is None else _number(speed.sigma)
    out["speeds"] = speeds.tolist()
    out["modes"] = list(eig.labels)
    out["eigenvalues"] = [[{"re": float(z.real), "im": float(z.imag)} for z in row] for row in eig.eigenvalues]
    return out


def _ranges(ranges: tuple[tuple[float, float], ...]) -> str:
    """Stable speed ranges for people: ``1.02–4.35, 6.02–∞ m/s`` (or ``none``)."""
    if not ranges:
        return "none"
    return ", ".join(f"{lo:.3f}–{hi:.3f}" if math.isfinite(hi) else f"{lo:.3f}–∞" for lo, hi in ranges) + " m/s"


def feedback_json(
    fb: Feedback, speeds: np.ndarray, ranges: tuple[tuple[float, float], ...], open_cs: Any
) -> dict[str, Any]:
    """The keys ``--feedback`` adds to the ``--json`` object (gains SI, speeds m/s)."""
    return {
        "feedback": {"name": fb.name, "file": fb.source, "gains": fb.gains(speeds).tolist()},
        "stable_speed_ranges": [[lo, hi if math.isfinite(hi) else None] for lo, hi in ranges],
        "open_loop": {
            f"{label}_speed{part}": None if speed is None else _number(getattr(speed, attr))
            for label, speed in (("weave", open_cs.weave), ("capsize", open_cs.capsize))
            for part, attr in (("", "speed"), ("_sigma", "sigma"))
        },
    }


def feedback_text(fb: Feedback, ranges: tuple[tuple[float, float], ...], open_cs: CriticalSpeedsWithSigma) -> str:
    """The closed loop's heading: the feedback, its stable speed ranges and the open loop's speeds with σ."""
    weave, capsize = format_speed(open_cs.weave, "weave"), format_speed(open_cs.capsize, "capsize")
    gains = "".join(
        f"  {k} [{u}]: {s.describe()}\n" for k, u, s in zip(GAIN_KEYS, GAIN_UNITS, fb.schedules, strict=True)
    )
    return (
        f"closed loop with feedback '{fb.name}' ({fb.source or 'built in'}): T_δ = −(kφ φ + kδ δ + kφ̇ φ̇ + kδ̇ δ̇)\n"
        f"{gains}"
        + ("(the σ below include the gains given with σ)\n" if fb.uncertain_knots() else "")
        + f"stable speeds (closed loop): {_ranges(ranges)}\n"
        f"open loop: weave {weave}, capsize {capsize}"
    )


def speeds_text(cs: CriticalSpeedsWithSigma) -> str:
    """The weave and capsize speeds with σ (σ to two significant digits), or why one is absent."""
    return (
        f"weave speed:   {format_speed(cs.weave, 'weave')}\n"
        f"capsize speed: {format_speed(cs.capsize, 'capsize')}\n"
        f"(σ first order from the parameter covariance, {cs.convention.value} convention)"
    )


def run(args: argparse.Namespace) -> int:
    """Run ``bike-rig model``; returns the exit status (0).

    Raises:
        BikeRigError: An unreadable input, a bad rider or bad speeds (one line, exit status 2).
    """
    ps = _parameters(args.file, args.com_method)
    rider = rider_from_spec(args.rider)
    if rider is not None:
        ps = add_rider(ps, rider)
    fb = feedback_from_spec(args.feedback)
    speeds = _speeds(args.speeds)
    convention = SigmaConvention(args.sigma)
    ms = canonical_with_sigma(ps, convention)
    cs = critical_speeds_with_sigma(ps, convention, ms, feedback=fb)
    eig = eigenvalues(ms.matrices, ms.g, speeds, gains=None if fb is None else fb.gains(speeds))
    closed: list[str] = []
    if fb is not None:
        ranges = closed_loop_stable_range(ms.matrices, ms.g, fb)
        open_cs = critical_speeds_with_sigma(ps, convention, ms)
        closed = [feedback_text(fb, ranges, open_cs)]
    if args.json:
        doc = model_json(ms, cs, speeds, eig)
        if fb is not None:
            doc.update(feedback_json(fb, speeds, ranges, open_cs))
        emit(json.dumps(doc, indent=2), args.output)
        return 0
    text = "\n\n".join(
        [
            f"{ps.bicycle}: Whipple model (from {ps.source})",
            fmt.matrix_table(ms),
            *closed,
            speeds_text(cs),
            fmt.eigen_table(speeds.tolist(), eig.eigenvalues, eig.labels),
        ]
    )
    emit(text, args.output)
    return 0
