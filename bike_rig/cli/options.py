"""The fit-window, quality-threshold and trial-column options, for every command that fits trials.

:func:`add_window_options` (``--lead-in`` | ``--start``/``--stop`` | ``--envelope``,
``--no-whole-cycles``), :func:`add_threshold_options` (``--min-cycles``, ``--min-r2``,
``--max-modulation``, ``--max-drift``) and the trial-column options (``--time``, ``--signal``,
``--time-unit``): with their defaults for ``fit`` (``overrides=False``), defaulting to None, "as
recorded", for ``replay`` (``overrides=True``). :func:`add_feedback_option` adds ``--feedback
FILE`` and :func:`add_strict_option` ``--strict`` (a value a wrong unit explains is an error).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass

from ..core.benchmark import ComMethod
from ..core.errors import BikeRigError
from ..core.period import FitOptions, WindowPolicy
from ..core.trial_columns import TIME_UNITS, ColumnChoice

__all__ = [
    "THRESHOLDS",
    "Threshold",
    "add_column_options",
    "add_com_method_option",
    "add_feedback_option",
    "add_strict_option",
    "add_threshold_options",
    "add_window_options",
    "columns_from_args",
    "thresholds_from_args",
    "window_from_args",
]

#: Makes a command's usage error from its message.
UsageError = Callable[[str], BikeRigError]


@dataclass(frozen=True)
class Threshold:
    """One quality threshold option (a keyword of :func:`bike_rig.core.period.fit_period`).

    Attributes:
        name: The keyword, and the option's dest (``--min-cycles`` → ``min_cycles``).
        metavar: The option's value in the help.
        help: The help without the default.
        fit_help: ``bike-rig fit``'s help, "" for :attr:`help` (each adds ``(default X)``).
    """

    name: str
    metavar: str
    help: str
    fit_help: str = ""

    @property
    def default(self) -> float:
        """``bike-rig fit``'s default: the fitter's (:class:`bike_rig.core.period.FitOptions`)."""
        return float(getattr(FitOptions(), self.name))

    @property
    def flag(self) -> str:
        """The option, e.g. ``--min-cycles``."""
        return "--" + self.name.replace("_", "-")


#: The quality thresholds, in order (a flagged trial should be redone).
THRESHOLDS: tuple[Threshold, ...] = (
    Threshold("min_cycles", "N", "flag fewer cycles"),
    Threshold("min_r2", "R2", "flag a lower r²"),
    Threshold(
        "max_modulation",
        "M",
        "flag beating above this modulation",
        "flag beating above this relative envelope modulation",
    ),
    Threshold("max_drift", "D", "flag a drift above D × the swing"),
)


def add_window_options(group: argparse._ActionsContainer, overrides: bool = False) -> None:
    """Add ``--lead-in``, ``--start``, ``--stop``, ``--envelope`` and ``--no-whole-cycles``.

    Args:
        group: The parser or argument group to add them to.
        overrides: Word the help as overrides of a recorded window (``replay``) instead of
            ``fit``'s.
    """
    if overrides:
        group.add_argument("--lead-in", type=float, metavar="S", help="window: the record minus its first S seconds")
        group.add_argument("--start", type=float, metavar="S", help="window: from S seconds after the first sample")
        group.add_argument("--stop", type=float, metavar="S", help="window: up to S seconds after the first sample")
        group.add_argument(
            "--envelope", type=float, metavar="F", help="window: from the largest swing until it decays to F"
        )
    else:
        group.add_argument("--lead-in", type=float, metavar="S", help="seconds dropped at the start (default 1)")
        group.add_argument("--start", type=float, metavar="S", help="fit from this time (s from the first sample)")
        group.add_argument("--stop", type=float, metavar="S", help="fit up to this time (s from the first sample)")
        group.add_argument(
            "--envelope",
            type=float,
            metavar="FRACTION",
            help="BicycleParameters' window: from the largest swing until it decays to FRACTION of it",
        )
    group.add_argument("--no-whole-cycles", action="store_true", help="do not cut the window to whole cycles")


def add_threshold_options(group: argparse._ActionsContainer, overrides: bool = False) -> None:
    """Add the :data:`THRESHOLDS` options.

    Args:
        group: The parser or argument group to add them to.
        overrides: Default None (keep the recorded value) instead of ``fit``'s defaults.
    """
    for t in THRESHOLDS:
        if overrides:
            group.add_argument(t.flag, type=float, metavar=t.metavar, help=t.help)
        else:
            help_ = f"{t.fit_help or t.help} (default {t.default:g})"
            group.add_argument(t.flag, type=float, default=t.default, metavar=t.metavar, help=help_)


def window_from_args(args: argparse.Namespace, error: UsageError) -> WindowPolicy | None:
    """The window the options ask for, or None when no window option is given.

    Args:
        args: Parsed options of :func:`add_window_options`.
        error: The command's usage error class.

    Returns:
        The window, cut to whole cycles unless ``--no-whole-cycles``; None without
        ``--lead-in``, ``--start``/``--stop`` or ``--envelope``.

    Raises:
        BikeRigError: Of the class ``error``: more than one window, or an invalid one.
    """
    span = args.start is not None or args.stop is not None
    chosen = [
        name
        for name, given in (
            ("--lead-in", args.lead_in is not None),
            ("--start/--stop", span),
            ("--envelope", args.envelope is not None),
        )
        if given
    ]
    if len(chosen) > 1:
        raise error(f"choose one window: {' or '.join(chosen)}")
    whole = not args.no_whole_cycles
    try:
        if span:
            return WindowPolicy.span(0.0 if args.start is None else args.start, args.stop, whole_cycles=whole)
        if args.envelope is not None:
            return WindowPolicy.envelope(args.envelope, whole_cycles=whole)
        if args.lead_in is not None:
            return WindowPolicy.lead_in(args.lead_in, whole_cycles=whole)
    except ValueError as exc:
        raise error(f"window: {exc}") from None
    return None


def thresholds_from_args(args: argparse.Namespace, error: UsageError) -> dict[str, float | None]:
    """The quality thresholds the options give, checked.

    Args:
        args: Parsed options of :func:`add_threshold_options`.
        error: The command's usage error class.

    Returns:
        Each threshold's keyword → its value (None: not given, with ``overrides``).

    Raises:
        BikeRigError: Of the class ``error``: a value that is negative or not finite.
    """
    values: dict[str, float | None] = {t.name: getattr(args, t.name) for t in THRESHOLDS}
    for key, value in values.items():
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise error(f"--{key.replace('_', '-')} must be a non-negative number, got {value}")
    return values


def add_column_options(group: argparse._ActionsContainer) -> None:
    """Add ``--time``, ``--signal`` and ``--time-unit``: which columns of a trial file to read.

    Args:
        group: The parser or argument group to add them to.
    """
    group.add_argument(
        "--time",
        metavar="COLUMN",
        help="the time column: its header name or 0-based index (default: the column named t, time, time_ms...)",
    )
    group.add_argument(
        "--signal",
        metavar="COLUMN",
        help="the gyro column: its header name or 0-based index (default: the other column, or the one named rate)",
    )
    group.add_argument(
        "--time-unit",
        choices=list(TIME_UNITS),
        help="unit of the times (default: the header's, e.g. time_ms, else told from the spacing)",
    )


def columns_from_args(args: argparse.Namespace) -> ColumnChoice:
    """The columns the options choose (:func:`add_column_options`).

    Args:
        args: Parsed options.

    Returns:
        The choice; a column given as digits is a 0-based index, anything else a header name.
    """
    return ColumnChoice.from_text(args.time, args.signal, args.time_unit)


def add_com_method_option(group: argparse._ActionsContainer) -> None:
    """Add ``--com-method``: the mass-centre method for raw readings (absent: None, the input's own).

    Args:
        group: The parser or argument group to add it to.
    """
    group.add_argument(
        "--com-method",
        choices=[m.value for m in ComMethod],
        default=None,
        help="mass-centre method for raw readings: centroid (paper) or lstsq (default: centroid; a bag: as recorded)",
    )


def add_feedback_option(group: argparse._ActionsContainer) -> None:
    """Add ``--feedback FILE``: a feedback file (``format: bike_rig-feedback/1``) for the closed loop.

    The value is resolved by :func:`bike_rig.cli.common.feedback_from_spec`; absent, ``""`` or
    ``none``: the open loop.

    Args:
        group: The parser or argument group to add it to.
    """
    group.add_argument(
        "--feedback",
        metavar="FILE",
        help="steer-torque state feedback (a bike_rig-feedback/1 YAML file): results of the closed loop A - B K",
    )


def add_strict_option(group: argparse._ActionsContainer) -> None:
    """Add ``--strict``: a value outside its plausible range that a wrong unit explains is an error (exit 2).

    Without it each such value is a warning on stderr naming the likely unit and the corrected
    value (:func:`bike_rig.cli.common.apply_unit_policy`).
    """
    group.add_argument(
        "--strict",
        action="store_true",
        help="refuse (exit 2) a value that looks like a wrong unit (a wheelbase in mm, a mass in grams, "
        "an angle in radians) instead of warning",
    )
