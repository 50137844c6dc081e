"""``bike-rig replay BAG``: recompute a recorded session offline, or play it back into a graph.

Offline (no ROS runtime) every trial is refitted with the fitter's own function and recorded
fit options, and parameters and model are computed as the nodes do, from the bag's last
StaticReadings (or ``--readings FILE``); the output says whether the results equal what the
live graph published last (relative 1e-12, in publisher order: :mod:`bike_rig.bag.order`).
``--json``: ``params --json``'s ``bicycle`` and ``parameters`` plus ``weave_speed``,
``capsize_speed``, their σ, ``complete``, ``missing``, ``periods``, ``trials``, ``settings``,
``live`` and ``notes``. ``--republish`` plays the raw stream into a live graph. Exit 1 when the
session is incomplete, 2 for a bad bag or option (``docs/cli.md``).
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from ..core.benchmark import ComMethod
from ..core.errors import BikeRigError
from ..core.textfmt import format_speed, terminal_safe
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..offline.replay import FitOverrides, ReplayResult, ReplaySettings, replay_bag, result_json
from . import format as fmt
from .commands import HELP
from .options import (
    add_strict_option,
    add_threshold_options,
    add_window_options,
    thresholds_from_args,
    window_from_args,
)

__all__ = ["ReplayUsageError", "add_parser", "replay_text", "run"]


class ReplayUsageError(BikeRigError):
    """An option of ``bike-rig replay`` is invalid."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``replay`` on ``subparsers`` (``bike-rig``'s sub-commands)."""
    q = subparsers.add_parser(
        "replay",
        help=HELP["replay"],
        description="Recompute every trial's period, the parameters and the weave and capsize speeds "
        "from a bag, offline, with the live nodes' own functions and recorded settings, and compare "
        "with what the live graph published.",
    )
    q.add_argument("bag", metavar="BAG", help="bag directory (or its .mcap file)")
    q.add_argument("--json", action="store_true", help="one JSON object on standard output")
    f = q.add_argument_group("fit settings (default: those recorded with each trial's period estimate)")
    f.add_argument("--default-fit", action="store_true", help="start from the fitter's defaults, not the recorded")
    add_window_options(f, overrides=True)
    add_threshold_options(f, overrides=True)
    s = q.add_argument_group("parameters and model (default: as the live graph ran)")
    s.add_argument("--com-method", choices=[m.value for m in ComMethod], help="mass-centre method")
    s.add_argument("--rider", help="rider in the rear frame: none, paper or a rider YAML file (rigid or Yeadon)")
    s.add_argument("--sigma", choices=[c.value for c in SigmaConvention], help="σ convention")
    s.add_argument(
        "--readings", metavar="FILE", help="static readings from this measurement file, not the bag's (periods ignored)"
    )
    add_strict_option(s)
    r = q.add_argument_group("republish into a live graph (rclpy)")
    r.add_argument("--republish", action="store_true", help="play gyro, trial events and static readings back")
    r.add_argument("--rate-scale", type=float, default=1.0, metavar="X", help="X times the original speed (default 1)")
    r.add_argument(
        "--wait", type=float, default=5.0, metavar="S", help="wait up to S s for subscribers before playing (default 5)"
    )
    q.set_defaults(func=run)


def settings_from_args(args: argparse.Namespace) -> ReplaySettings:
    """The replay settings the options ask for.

    Args:
        args: The parsed options of ``bike-rig replay``.

    Returns:
        The settings; an option not given keeps what was recorded.

    Raises:
        ReplayUsageError: An invalid fit window or threshold.
    """
    thresholds = thresholds_from_args(args, ReplayUsageError)
    fit = FitOverrides(
        window=window_from_args(args, ReplayUsageError),
        whole_cycles=False if args.no_whole_cycles else None,
        min_cycles=thresholds["min_cycles"],
        min_r2=thresholds["min_r2"],
        max_modulation=thresholds["max_modulation"],
        max_drift=thresholds["max_drift"],
        use_defaults=args.default_fit,
    )
    return ReplaySettings(
        fit=fit,
        com_method=None if args.com_method is None else ComMethod(args.com_method),
        rider=None if args.rider is None else ("" if args.rider == "none" else args.rider),
        sigma_convention=None if args.sigma is None else SigmaConvention(args.sigma),
        readings=getattr(args, "readings", None),
    )


def run(args: argparse.Namespace) -> int:
    """Run ``bike-rig replay``; returns the exit status."""
    if args.republish:
        return _republish(args)
    result = replay_bag(args.bag, settings_from_args(args))
    if args.json:
        print(json.dumps(result_json(result), indent=2, allow_nan=False))
    else:
        print(terminal_safe(replay_text(result)))
    return 0 if result.complete else 1


def _republish(args: argparse.Namespace) -> int:
    if not (math.isfinite(args.rate_scale) and args.rate_scale > 0):
        raise ReplayUsageError(f"--rate-scale must be a positive number, got {args.rate_scale}")
    if not (math.isfinite(args.wait) and args.wait >= 0):
        raise ReplayUsageError(f"--wait must be a non-negative number of seconds, got {args.wait}")
    from ..ros.republish import republish  # rclpy only here

    stats = republish(args.bag, rate_scale=args.rate_scale, wait_s=args.wait)
    if args.json:
        print(json.dumps(stats.to_dict(), indent=2))
    else:
        print(terminal_safe(stats.describe()))
    return 0 if not stats.interrupted else 130


# ---------------------------------------------------------------- text


def _vs(value: float, sigma: float) -> str:
    if not math.isfinite(value):
        return "-"
    v, s = fmt.format_value_sigma(value, sigma, digits=None)
    return f"{v} ± {s}"


def _trials_table(result: ReplayResult) -> str:
    w = max(len("trial"), *(len(t.trial_id) for t in result.trials))
    head = f"{'trial':<{w}}  {'key':<5}  {'period [s]':>20}  {'samples':>7}  {'used':<4}  {'live':<9}  flags"
    rows = [head, "-" * len(head)]
    for t in result.trials:
        p = t.result
        if t.recorded is None:
            live = "-"
        elif (
            p.valid == t.recorded.valid
            and p.flag_codes == t.recorded.flag_codes
            and (p.period == t.recorded.period or (math.isnan(p.period) and math.isnan(t.recorded.period)))
        ):
            live = "same"
        else:
            live = "differs"
        flags = ", ".join(p.flag_codes) + (f" ({t.note})" if t.note else "")
        rows.append(
            f"{t.trial_id:<{w}}  {p.measurement_key or '-':<5}  {_vs(p.period, p.period_sigma):>20}  "
            f"{p.n_samples:>7}  {'yes' if t.used else 'no':<4}  {live:<9}  {flags}"
        )
    return "\n".join(rows)


def _speed(s: Any) -> str:
    return format_speed(s)


def replay_text(result: ReplayResult) -> str:
    """The ``replay`` report: trials, parameters, critical speeds, comparison with live."""
    out = [f"{result.bicycle}: replay of {result.bag}"]
    over = " (fit settings overridden)" if result.fit_overridden else ""
    out.append(
        f"settings: com method {result.com_method.value}, rider '{result.rider or 'none'}', "
        f"σ {result.sigma_convention.value}{over}"
    )
    if result.readings_swapped:
        out.append(f"static readings: from {result.readings}, NOT the bag's (swapped with --readings)")
    else:
        out.append(f"static readings: the bag's ({result.readings})")
    out += ["", _trials_table(result), ""]
    ps = result.parameters
    if ps is None:
        out.append("incomplete: no usable trial for " + ", ".join(result.session.missing))
    else:
        out.append(fmt.parameter_table(ps))
        out.append("")
        rider = f" (with the {result.rider} rider)" if result.rider else ""
        st = result.stability
        assert st is not None
        out.append(f"weave speed{rider}:   {_speed(st.weave)}")
        out.append(f"capsize speed{rider}: {_speed(st.capsize)}")
    out += [f"note: {n}" for n in result.notes]
    out.append("")
    out.append(_live_text(result))
    return "\n".join(out)


def _live_text(result: ReplayResult) -> str:
    live = result.live
    if not live.differences:
        return "live results: none recorded to compare with (" + ", ".join(live.missing) + ")"
    worst = live.worst
    assert worst is not None
    others = [d.what for d in live.differences if not d.what.startswith("trial ")]
    compared = ([f"{live.compared_trials} trial fits"] if live.compared_trials else []) + others
    if live.identical:
        text = (
            f"live results: identical (largest relative difference {worst.max_relative:.1e}; "
            f"compared: {', '.join(compared)})"
        )
    else:
        bad = [d for d in live.differences if not d.identical]
        text = f"live results: DIFFER in {len(bad)} of {len(live.differences)} comparisons"
        results, trial = live.largest_move(trials=False), live.largest_move(trials=True)
        moves = (
            [f"the results (combined periods, parameters, speeds) by at most {results.in_sigma:.2g}"]
            if results is not None
            else []
        )
        if trial is not None:
            moves.append(f"the trial fits' periods by at most {trial.in_sigma:.2g} ({trial.what})")
        if moves:
            text += "; moved, in units of the live σ: " + ", ".join(moves)
        expected = [
            why
            for why, on in (
                ("the fit settings are overridden", result.fit_overridden),
                ("the static readings are swapped", result.readings_swapped),
            )
            if on
        ]
        if expected:
            text += f" (expected: {'; '.join(expected)})"
        text += "".join(f"\n  {d.what}: {d.detail or f'relative {d.max_relative:.1e}'}" for d in bad[:10])
        if len(bad) > 10:
            text += f"\n  ... and {len(bad) - 10} more"
    if live.missing:
        text += "\n  not compared: " + ", ".join(live.missing)
    return text
