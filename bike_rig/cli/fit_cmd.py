"""``bike-rig fit FILE...``: the period of each pendulum trial (paper Eq 23–27), and combined.

Each FILE is a trial (:mod:`bike_rig.core.trials`). Prints a table of the fits, each flag with
its reason, and for several files the combined period per measurement key (never combining
different keys; keyless files only when their periods agree within
:data:`SAME_MEASUREMENT_SPREAD`); ``--json`` prints one object per file (JSON Lines, NaN as
null); ``--plot DIR`` writes each fit's figure. Exit 0, or 1 with ``--strict`` when a trial has
no period, 2 for an unreadable file or bad option. Options and JSON keys: ``docs/cli.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.errors import BikeRigError, InputFileError
from ..core.period import CombinedPeriod, PeriodFit, WindowPolicy, combine_periods, fit_period
from ..core.textfmt import terminal_safe
from ..core.trials import Trial, read_trial
from .commands import HELP
from .common import show
from .format import format_value_sigma
from .options import (
    add_column_options,
    add_threshold_options,
    add_window_options,
    columns_from_args,
    thresholds_from_args,
    window_from_args,
)

__all__ = ["SAME_MEASUREMENT_SPREAD", "FitUsageError", "add_parser", "combined_summary", "run"]

#: Largest relative spread (max − min) / mean of the clean periods of files that name no
#: measurement for them to be combined as one (0.05 %): repeats of one simulated measurement
#: spread by at most 0.024 % (25 Browser and 25 Fisher sessions), while any two periods of
#: the six shipped bicycles differ by at least 0.097 % (Fisher's two wheels, torsional).
SAME_MEASUREMENT_SPREAD = 5e-4

_KEY = re.compile(r"^T[ct][RFBHGP][1-9]\d*$")


class FitUsageError(BikeRigError):
    """An option of ``bike-rig fit`` is invalid."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``fit``.

    Args:
        subparsers: ``bike-rig``'s sub-command parsers (``add_subparsers()``).
    """
    q = subparsers.add_parser(
        "fit",
        help=HELP["fit"],
        description="Fit the paper's decaying oscillation (Eq 23) to each trial file and report its "
        "period with an honest σ and quality flags; several files are also combined.",
    )
    q.add_argument("files", nargs="+", metavar="FILE", help="trial file: CSV (time,rate or rate), .npy or .mat")
    q.add_argument("--json", action="store_true", help="one JSON object per file (JSON Lines)")
    q.add_argument("--plot", metavar="DIR", help="write a PNG per trial (data, fit, residuals) into DIR")
    q.add_argument("--rate", type=float, metavar="HZ", help="sample rate of files without times or rate")
    q.add_argument("--strict", action="store_true", help="exit with status 1 if any trial has no period")
    q.add_argument(
        "--small-swing-period",
        action="store_true",
        help="when the period follows the swing (a compound pendulum's finite swing), report the period of "
        "a vanishing swing instead of the mean period over the window",
    )
    q.add_argument(
        "--key",
        metavar="KEY",
        help="every file is a trial of this measurement (a period key such as TtB1), whatever its name says",
    )
    add_column_options(q.add_argument_group("columns of CSV and .npy files"))
    add_window_options(q.add_argument_group("window (default: the record minus a 1 s lead-in, in whole cycles)"))
    add_threshold_options(q.add_argument_group("quality thresholds (a flagged trial should be redone)"))
    q.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``bike-rig fit``.

    Args:
        args: The parsed arguments of ``bike-rig fit``.

    Returns:
        The exit status: 0, or 1 with ``--strict`` when a trial has no period.

    Raises:
        FitUsageError: An invalid option.
        InputFileError: A trial file cannot be read, or a plot cannot be written.
    """
    policy = _window_policy(args)
    options = _fit_options(args)
    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise FitUsageError(f"--rate must be a positive number of Hz, got {args.rate}")
    if args.key is not None and not _KEY.match(args.key):
        raise FitUsageError(
            f"--key must be a period key such as TtB1 or TcR1 (Tc or Tt, part letter, orientation), got {args.key!r}"
        )
    plot_dir = _plot_dir(args.plot) if args.plot else None
    columns = columns_from_args(args)
    trials = [read_trial(path, args.rate, columns) for path in args.files]  # all readable before output
    swing = bool(args.small_swing_period)
    fits = [fit_period(t.samples, **t.timing, window=policy, small_swing_period=swing, **options) for t in trials]
    for trial in trials:
        for remark in trial.remarks:
            show(f"bike-rig fit: note: {terminal_safe(trial.path, keep='')}: {remark}", sys.stderr)
    if args.json:
        for trial, fit in zip(trials, fits):
            show(json.dumps(fit_json(trial.path, fit), allow_nan=False))
    else:
        show(fit_table(trials, fits))
        if len(fits) > 1:
            show("")
            show(combined_summary(trials, fits, args.key))
    if plot_dir is not None:
        for name, trial, fit in zip(_plot_names(trials), trials, fits):
            plot_fit(trial, fit, plot_dir / name)
    if args.strict and not all(f.valid for f in fits):
        return 1
    return 0


# ---------------------------------------------------------------- options


def _window_policy(args: argparse.Namespace) -> WindowPolicy:
    """The window of the options; without one, the record minus a 1 s lead-in."""
    window = window_from_args(args, FitUsageError)
    return window or WindowPolicy.lead_in(1.0, whole_cycles=not args.no_whole_cycles)


def _fit_options(args: argparse.Namespace) -> dict[str, float]:
    """The quality thresholds of the options (each has a default, so none is None)."""
    return {key: float(value) for key, value in thresholds_from_args(args, FitUsageError).items() if value is not None}


def _plot_dir(path: str) -> Path:
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputFileError(path, f"cannot create the plot folder ({exc.strerror})") from None
    return folder


# ---------------------------------------------------------------- output


def _number(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def fit_json(file: str, fit: PeriodFit) -> dict[str, Any]:
    """The JSON object of one trial (NaN → None).

    Args:
        file: The trial file, as given.
        fit: Its fit.

    Returns:
        ``file``, ``period``, ``period_sigma`` (s), ``valid``, ``flags`` (``code``, ``reason``),
        ``r2``, ``zeta``, ``omega`` (rad/s), ``n_samples``, ``window`` (samples),
        ``damping_model`` (``viscous``, ``dry``, ``combined``), ``friction`` and its σ (the
        envelope's linear fall per second over the amplitude at the window's centre, 1/s; 0 when
        viscous), ``swing_amplitude`` (at the window's start, rad for rad/s samples),
        ``swing_kappa``, ``small_swing_period`` and its σ (s; None unless κ < 0),
        ``small_swing_systematic`` (s; None unless the small-swing period was asked for),
        ``ends_period`` and its σ (the record's own mean period from the phase at the window's
        ends, s; None under 6 cycles).
    """
    return {
        "file": file,
        "period": _number(fit.period),
        "period_sigma": _number(fit.period_sigma),
        "valid": fit.valid,
        "flags": [{"code": f.code.value, "reason": f.reason} for f in fit.flags],
        "r2": _number(fit.r2),
        "zeta": _number(fit.zeta),
        "omega": _number(fit.omega),
        "n_samples": fit.n_samples,
        "window": [fit.window[0], fit.window[1]],
        "damping_model": fit.damping_model,
        "friction": _number(fit.friction),
        "friction_sigma": _number(fit.friction_sigma),
        "swing_amplitude": _number(fit.swing_amplitude),
        "swing_kappa": _number(fit.swing_kappa),
        "small_swing_period": _number(fit.small_swing_period),
        "small_swing_period_sigma": _number(fit.small_swing_period_sigma),
        "small_swing_systematic": _number(fit.small_swing_systematic),
        "ends_period": _number(fit.ends_period),
        "ends_period_sigma": _number(fit.ends_period_sigma),
    }


def _value_sigma(value: float, sigma: float) -> tuple[str, str]:
    if not math.isfinite(value):
        return "-", "-"
    return format_value_sigma(value, sigma, digits=None)


def fit_table(trials: Sequence[Trial], fits: Sequence[PeriodFit]) -> str:
    """One row per trial: period ± σ (s), r², cycles, ζ, damping model, status; flags (!) and notes (·) below.

    Args:
        trials: The trials.
        fits: Their fits, in the same order.

    Returns:
        The table, its last line the window policy.
    """
    names = [terminal_safe(t.name, keep="") for t in trials]
    width = max(12, *(len(name) for name in names))
    head = (
        f"{'trial':<{width}}  {'T [s]':>12}  {'σ [s]':>9}  {'r²':>6}  {'cycles':>6}  {'ζ':>8}  {'damping':>8}  status"
    )
    rows = [head, "-" * len(head)]
    for name, fit in zip(names, fits):
        value, sigma = _value_sigma(fit.period, fit.period_sigma)
        status = "ok" if fit.clean else ("flagged: redo" if fit.valid else "no period: redo")
        r2 = f"{fit.r2:.4f}" if math.isfinite(fit.r2) else "-"
        cycles = f"{fit.n_cycles:.1f}" if math.isfinite(fit.n_cycles) else "-"
        zeta = f"{fit.zeta:.2e}" if math.isfinite(fit.zeta) else "-"
        damping = fit.damping_model if fit.valid else "-"
        rows.append(
            f"{name:<{width}}  {value:>12}  {sigma:>9}  {r2:>6}  {cycles:>6}  {zeta:>8}  {damping:>8}  {status}"
        )
        rows += [f"{'':<{width}}  ! {flag}" for flag in fit.flags]
        rows += [f"{'':<{width}}  · {note}" for note in fit.notes]
    policy = fits[0].window_policy.describe() if fits else ""
    rows.append(f"(window: {policy}; σ robust to drift and correlated noise)")
    return "\n".join(rows)


def _spread(fits: Sequence[PeriodFit]) -> float:
    """Relative spread (max − min) / mean of the clean trials' periods (0 for fewer than two)."""
    periods = [f.period for f in fits if f.clean and math.isfinite(f.period)]
    if len(periods) < 2:
        return 0.0
    return (max(periods) - min(periods)) / (sum(periods) / len(periods))


_NAME_A_KEY = "name them like frame_torsional_o1_t1.csv or TtB1_1.csv, or give --key KEY"


def _groups(trials: Sequence[Trial], fits: Sequence[PeriodFit], key: str | None) -> tuple[dict[str, list[int]], str]:
    """The trials of each measurement key (in order of appearance), and why any are not combined ("" if all are).

    Files that name no key form one group, "all trials", when no file names one and their
    periods agree within :data:`SAME_MEASUREMENT_SPREAD`.
    """
    keys = [key or t.period_key for t in trials]
    groups: dict[str, list[int]] = {}
    for i, k in enumerate(keys):
        if k is not None:
            groups.setdefault(k, []).append(i)
    keyless = [i for i, k in enumerate(keys) if k is None]
    if not keyless:
        return groups, ""
    names = ", ".join(terminal_safe(Path(trials[i].path).name, keep="") for i in keyless)
    if groups:
        verb = "names" if len(keyless) == 1 else "name"
        return groups, f"not combined: {names} {verb} no measurement key ({_NAME_A_KEY})"
    spread = _spread(fits)
    if spread > SAME_MEASUREMENT_SPREAD:
        periods = [f.period for f in fits if f.clean and math.isfinite(f.period)]
        return {}, (
            f"not combined: the files name no measurement and their periods range from {min(periods):.4g} to "
            f"{max(periods):.4g} s ({100 * spread:.2g} %), more than trials of one measurement differ ({_NAME_A_KEY})"
        )
    return {"all trials": keyless}, ""


def combined_summary(trials: Sequence[Trial], fits: Sequence[PeriodFit], key: str | None = None) -> str:
    """The combined period of each measurement key among the files, or why files are not combined.

    Args:
        trials: The trials.
        fits: Their fits, in the same order.
        key: ``--key``: every trial is of this measurement; None to take each trial's own
            (:attr:`bike_rig.core.trials.Trial.period_key`).

    Returns:
        One line per key (T ± σ in s, counts, Birge ratio), each followed by its notes; then
        one line saying which files were not combined and why, if any.
    """
    groups, why_not = _groups(trials, fits, key)
    lines = []
    for label, members in groups.items():
        combined = combine_periods([fits[i] for i in members])
        lines.append(_combined_line(label, combined))
        shown = [terminal_safe(trials[i].name, keep="") for i in members]
        names = {f"trial {k} ": f"trial {name} " for k, name in enumerate(shown, start=1)}
        for note in combined.notes:
            head = next((h for h in names if note.startswith(h)), None)
            lines.append("  " + (names[head] + note[len(head) :] if head else note))
    if why_not:
        lines.append(why_not)
    return "\n".join(lines)


def _combined_line(label: str, c: CombinedPeriod) -> str:
    counts = f"{c.n_used} used, {c.n_flagged} flagged, {c.n_invalid} without period"
    if c.n_used == 0:
        return f"combined period of {label}: none ({counts})"
    value, sigma = format_value_sigma(c.value, c.sigma, digits=None)
    birge = f"; Birge ratio {c.birge_ratio:.2f}" if math.isfinite(c.birge_ratio) else ""
    return f"combined period of {label}: T = {value} ± {sigma} s ({counts}{birge})"


def _plot_names(trials: Sequence[Trial]) -> list[str]:
    names: list[str] = []
    for trial in trials:
        base = re.sub(r"[^A-Za-z0-9._-]+", "_", trial.name) or "trial"
        name, k = f"{base}.png", 2
        while name in names:
            name, k = f"{base}_{k}.png", k + 1
        names.append(name)
    return names


def plot_fit(trial: Trial, fit: PeriodFit, path: Path) -> None:
    """Write a PNG of the trial: samples and fit above, residuals below.

    The figure is :func:`bike_rig.plots.trials.fit_figure`'s.

    Args:
        trial: The trial.
        fit: Its fit.
        path: The PNG file (its extension is replaced by ``.png``).

    Raises:
        InputFileError: The PNG cannot be written.
    """
    from ..offline.subjects import file_trial
    from ..plots.style import save_figure
    from ..plots.trials import fit_figure

    record = file_trial(trial, fit, trial.period_key or "", trial.name, str(trial.path))
    save_figure(fit_figure(record), path.with_suffix(""), ("png",))
