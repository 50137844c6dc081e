"""``bike-rig budget INPUT``: which measurement to improve (the uncertainty budget).

For each parameter and the weave and capsize speeds, INPUT's inputs (raw readings, or the
parameters of a parameter file) are ranked by their share of the output's first-order variance
(:mod:`bike_rig.core.uncertainty.budget`), named as INPUT names them. ``--json``: ``bicycle``,
``input_kind``, ``inputs``, ``input_keys`` and ``outputs`` (``output``, ``value``, ``sigma``,
``unit``, every ``shares`` entry: ``input``, ``key``, ``share``, ``contribution``).
``--feedback`` budgets the closed loop's speeds (a gain with σ is an input ``feedback.<key>``);
nearly parallel hanging lines print Monte Carlo σ (``*``; ``sigma_method``, ``sigma_linear``).
Bad input: one line, exit 2. See ``docs/results.md``.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..core.benchmark import ComMethod, ParameterSet
from ..core.errors import BikeRigError
from ..core.measurements import PART_NAMES
from ..core.period.small_swing import small_swing_parts
from ..core.rider import add_rider
from ..core.uncertainty.budget import (
    BUDGET_PARAMETERS,
    CAPSIZE,
    PARAMETERS,
    WEAVE,
    OutputBudget,
    UncertaintyBudget,
    budget_json,
    input_ranking,
    reading_names,
    uncertainty_budget,
)
from ..core.uncertainty.mc_sigma import MC_SAMPLES, NEAR_PARALLEL_DEG, PrintedSigmas, line_angles, printed_sigmas
from ..offline.subjects import load_subject
from ..pipeline.swing import swing_alternative
from .commands import HELP
from .common import emit, feedback_from_spec, rider_from_spec
from .format import format_value_sigma
from .options import add_com_method_option, add_feedback_option, add_strict_option

__all__ = ["BudgetUsageError", "add_parser", "budget_text", "run"]

#: Inputs named in each "measure better" line of the text summary.
SUMMARY_INPUTS = 5


class BudgetUsageError(BikeRigError):
    """An option of ``bike-rig budget`` is invalid."""


def add_parser(sub: Any) -> None:
    """Register ``bike-rig budget`` on the ``bike-rig`` sub-command parser."""
    q = sub.add_parser(
        "budget",
        help=HELP["budget"],
        description="For each of the 25 benchmark parameters and the weave and capsize speeds, rank the "
        "raw measurements (every reading, every period) by their share of the output's variance, so you "
        "know what to measure better. A parameter file has no raw readings: its parameters are the inputs.",
    )
    q.add_argument("input", metavar="INPUT", help="measurement file, parameter file or session bag")
    q.add_argument("--json", action="store_true", help="one JSON object with every share on standard output")
    q.add_argument(
        "--rider", default="none", help="'paper' for the paper's rigid rider (Table 1), or a rider YAML file"
    )
    add_feedback_option(q)
    add_strict_option(q)
    q.add_argument("--top", type=int, default=5, metavar="N", help="inputs shown per output in the table (default 5)")
    add_com_method_option(q)
    q.add_argument("-o", "--output", metavar="FILE", help="write to this file instead of standard output")
    q.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``bike-rig budget``; returns the exit status (0)."""
    if args.top < 1:
        raise BudgetUsageError(f"--top N needs N >= 1, got {args.top}")
    subject = load_subject(args.input, args.com_method)
    ps = subject.parameters
    rider = rider_from_spec(args.rider)
    if rider is not None:
        ps = add_rider(ps, rider)
    names = reading_names(subject.measurements) if subject.measurements is not None else None
    fb = feedback_from_spec(args.feedback)
    used = ((t.key, t.result.fit) for t in subject.trials if t.used)
    b = uncertainty_budget(ps, names, swing_alternative(subject.trials), fb, small_swing_parts(used))
    sigmas = None
    if subject.measurements is not None and rider is None:
        sigmas = printed_sigmas(subject.measurements, ps.parameters, _com_method(ps))
    if args.json:
        text = json.dumps(_with_mc(budget_json(b), sigmas), indent=2, allow_nan=False)
    else:
        text = budget_text(b, args.top, source=subject.path, sigmas=sigmas)
        if subject.measurements is not None:
            text += "\n\n" + "\n".join(conditioning_lines(line_angles(subject.measurements), sigmas))
    emit(text, args.output)
    return 0


def _com_method(ps: ParameterSet) -> ComMethod:
    return next(iter(ps.com.values())).used if ps.com else ComMethod.CENTROID


def _with_mc(out: dict[str, Any], sigmas: PrintedSigmas | None) -> dict[str, Any]:
    """The budget JSON with the Monte Carlo σ where it is printed."""
    if sigmas is None:
        return out
    for o in out["outputs"]:
        if o["output"] in sigmas.monte_carlo:
            o.update(sigma=sigmas.sigma[o["output"]], sigma_method="monte_carlo", sigma_linear=o["sigma"])
    return out


def _percent(share: float) -> str:
    return f"{100.0 * share:.1f} %"


def _ranking_line(label: str, b: UncertaintyBudget, outputs: list[str] | None) -> str | None:
    ranked = input_ranking(b, outputs)[:SUMMARY_INPUTS]
    if not ranked:
        return None
    return f"{label}: " + ", ".join(f"{r.input} {_percent(r.mean_share)}" for r in ranked)


def _output_block(o: OutputBudget, top: int, width: int = 24, sigmas: PrintedSigmas | None = None) -> list[str]:
    mc = sigmas is not None and o.output in sigmas.monte_carlo
    value, sigma = format_value_sigma(o.value, sigmas.sigma[o.output] if sigmas and mc else o.sigma, digits=None)
    lines = [f"{o.output} [{o.unit}]: {value} ± {sigma}" + ("*" if mc else "")]
    if not o.shares:
        why = "σ is 0: no uncertainty to share" if o.sigma == 0 else "σ not defined (a double root)"
        lines.append(f"    ({why})")
        return lines
    for s in o.shares[:top]:
        lines.append(f"    {s.input:<{width}}{_percent(s.share):>9}   {s.contribution:.2g} {o.unit}")
    rest = len(o.shares) - top
    if rest > 0:
        lines.append(
            f"    ... {rest} more input{'s' if rest > 1 else ''}, {_percent(sum(s.share for s in o.shares[top:]))}"
        )
    for x in o.systematic:
        lines.append(f"    systematic, {x.source}: {x.shift:+.2g} {o.unit} ({abs(x.shift) / o.sigma:.2g} σ)")
    return lines


def budget_text(
    b: UncertaintyBudget, top: int = 5, source: str | None = None, sigmas: PrintedSigmas | None = None
) -> str:
    """The budget as a readable text table.

    Args:
        b: The budget.
        top: Inputs shown per output.
        source: The input file, named in the heading.
        sigmas: The σ to print (a Monte Carlo σ marked ``*``, footnoted); None: the linear σ.

    Returns:
        A heading, the inputs to measure better (mean share over all outputs and over the
        critical speeds), then per output ``value ± σ`` and its ``top`` inputs with share (%)
        and contribution (output unit).
    """
    what = f"{len(b.inputs)} raw readings" if b.input_kind != PARAMETERS else "the 26 parameters"
    origin = f" (from {source})" if source else ""
    lines = [f"{b.bicycle}: uncertainty budget over {what}{origin}"]
    if b.feedback:
        lines.append(f"weave and capsize speeds of the closed loop with feedback '{b.feedback}' ")
    if b.input_kind == PARAMETERS:
        lines.append(
            "a parameter file has no raw readings: the inputs are the parameters themselves "
            "(correlated parameters are grouped with '+')"
        )
    speeds = [o.output for o in b.outputs if o.output in (WEAVE, CAPSIZE)]
    summary = [
        _ranking_line("measure better first (mean share over all outputs)", b, None),
        _ranking_line("for the critical speeds", b, speeds) if speeds else None,
    ]
    got = [s for s in summary if s is not None]
    lines += got if got else ["no output has a σ: nothing to rank"]
    order = speeds + list(BUDGET_PARAMETERS)
    width = max([24, *(len(name) + 2 for name in b.inputs)])
    for name in order:
        lines.append("")
        lines += _output_block(b.output(name), top, width, sigmas)
    note = sigmas.note() if sigmas is not None else None
    if note:
        lines += ["", f"* {note}; shares and contributions are linear"]
    return "\n".join(lines)


def conditioning_lines(angles: dict[str, float], sigmas: PrintedSigmas | None) -> list[str]:
    """Hanging-line conditioning of each part and which σ the Monte Carlo gave.

    Args:
        angles: ``{part letter: smallest angle between its hanging lines (deg)}``.
        sigmas: The printed σ (None: no Monte Carlo, e.g. with a rider).

    Returns:
        Text lines: one per hung part, then, when a part is nearly parallel or any σ is the
        Monte Carlo one, those outputs with their linear σ.
    """
    lines = ["mass-centre line conditioning (smallest angle between hanging lines):"]
    for part, deg in angles.items():
        note = "  nearly parallel" if deg < NEAR_PARALLEL_DEG else ""
        lines.append(f"    {PART_NAMES[part]:<16}{deg:6.1f}°{note}")
    near = min(angles.values(), default=180.0) < NEAR_PARALLEL_DEG
    head = f"Monte Carlo σ ({MC_SAMPLES:,} seeded draws through the raw readings): "
    if sigmas is None:
        return [*lines, head + "not run with a rider; the σ printed are linear"] if near else lines
    if not near and not sigmas.monte_carlo:
        return lines
    got = [f"{n} {sigmas.sigma[n]:.3g} (linear {sigmas.linear[n]:.3g})" for n in sorted(sigmas.monte_carlo)]
    return [*lines, head + (", ".join(got) if got else "none printed")]
