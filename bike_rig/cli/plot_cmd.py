"""``bike-rig plot KIND INPUT... -o DIR``: the paper's section-10 figures and the lab's own views.

::

    bike-rig plot KIND INPUT... -o DIR [--format png,svg] [--rider none|paper|both|RIDER.yaml]
                  [--speed V] [--speeds START STOP N] [--mode LABEL]
                  [--input NAME] [--output NAME] [--com-method centroid|lstsq] [--feedback FILE]

KIND is one of :data:`KINDS`, or ``all`` for every kind. Each INPUT is a measurement file, a
parameter file or a session bag (:func:`bike_rig.offline.subjects.load_subject`). The model figures
(``eigen``, ``locus``, ``modes``, ``bode``, once per rider asked for) and ``side`` draw every
input in one figure (a panel or a line each); ``trials`` and ``fits`` draw each input that
has trials on its own (with ``all``, inputs without trials are skipped with a note on stderr;
asked for by name, an input without trials is an error). A bag of a session that did not finish
has trials but no parameters: its trial figures are drawn (the overview names the keys still
without a usable trial) with a note on stderr saying what is missing; ``all`` leaves it out of
the model figures and ``side``, which refuse it when asked for by name. Files written (see
:func:`figure_stem`)::

    DIR/<kind>[_rider].<fmt>              eigen, locus, modes, bode (``_rider``: the paper's rider)
    DIR/side.<fmt>
    DIR/trials_<bicycle>.<fmt>
    DIR/fit_<bicycle>_<trial>.<fmt>       (<trial>: the trial's id, or its file's name without extension)

``<bicycle>`` is the bicycle's name in lower case with anything but letters, digits, ``-``
and ``.`` replaced by ``-`` (``-2``, ``-3``... when two inputs share a name). Every written
file's path is printed on standard output, one per line. DIR is created when missing.
``--feedback FILE`` draws ``eigen``, ``locus`` and ``bode`` of the closed loop ``A − B K`` of that
steer-torque feedback (:mod:`bike_rig.core.feedback`; the titles name it).
User mistakes (unknown kind, format, mode, input or output, bad speeds, an unwritable DIR, an
input without trials for ``trials``/``fits``) raise :class:`PlotUsageError` or
:class:`~bike_rig.core.errors.InputFileError` before anything is drawn.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..core.errors import BikeRigError
from ..core.feedback import Feedback
from ..core.frequency import INPUTS, OUTPUTS
from ..core.whipple import MODE_LABELS
from ..plots.model_data import MAX_SPEED
from ..plots.output import check_out_dir, trial_name, unique_names
from ..plots.registry import FIGURES, KINDS, FigureKind, Scope, figure_stem
from .commands import HELP
from .common import feedback_from_spec
from .options import add_com_method_option, add_feedback_option

if TYPE_CHECKING:
    from ..offline.subjects import Subject

__all__ = [
    "DEFAULT_MODE",
    "DEFAULT_SPEED_TEXT",
    "KINDS",
    "FigureJob",
    "PlotOptions",
    "PlotUsageError",
    "add_parser",
    "figure_jobs",
    "figure_stem",
    "options_from_args",
    "parse_formats",
    "run",
    "unique_names",
]

#: Kinds that need trials (a session bag, or a measurement file whose periods are trial files);
#: :data:`KINDS` is every kind, in the order ``all`` draws them (:data:`bike_rig.plots.registry.FIGURES`).
TRIAL_KINDS: tuple[str, ...] = tuple(k.name for k in FIGURES.values() if k.needs_trials)
#: What ``modes`` and ``bode`` are drawn at unless ``--speed`` is given: ``bode`` at the paper's
#: 2 m/s (Figs 17 and 18); ``modes`` of the capsize or caster mode at each bicycle's own speed
#: inside its capsize–caster complex interval (Fig 15, computed from its model), of the weave at
#: 2 m/s (:func:`bike_rig.plots.modes.default_mode_speed`).
DEFAULT_SPEED_TEXT = (
    "bode: 2 m/s as the paper's Figs 17-18; modes: capsize/caster inside each bicycle's capsize-caster "
    "complex interval, weave 2 m/s"
)
#: Mode of the ``modes`` figure unless ``--mode`` is given (Fig 15: the capsize–caster pair).
DEFAULT_MODE = "capsize"
_RIDERS = {"none": ("",), "paper": ("paper",), "both": ("", "paper")}


class PlotUsageError(BikeRigError):
    """An argument of ``bike-rig plot`` is invalid, or asks for a figure an input cannot give."""


def _riders(spec: str) -> tuple[str, ...]:
    """The riders of ``--rider``: none, paper, both, or a rider file (read now, so a bad one stops the run early).

    Raises:
        RiderError: The rider file is missing or malformed.
    """
    if spec in _RIDERS:
        return _RIDERS[spec]
    from ..core.rider import resolve_rider

    resolve_rider(spec)
    return (spec,)


@dataclass(frozen=True)
class FigureJob:
    """One figure to draw and where to write it.

    Attributes:
        stem: The output path without its extension.
        draw: Makes the figure.
    """

    stem: Path
    draw: Callable[[], Any]


@dataclass(frozen=True)
class PlotOptions:
    """The checked options of one ``bike-rig plot`` call.

    Attributes:
        formats: File formats to write (``png``, ``svg``).
        riders: Riders of the model figures: "" (none) and/or "paper", or a rider file.
        speeds: Speeds of ``eigen`` and ``locus``, m/s, or None for the figures' default.
        speed: Speed of ``modes`` and ``bode``, m/s, or None for the figures' default
            (:data:`DEFAULT_SPEED_TEXT`).
        mode: Mode of ``modes``.
        input: Input of ``bode`` (one of :data:`bike_rig.core.frequency.INPUTS`).
        output: Output of ``bode`` (one of :data:`bike_rig.core.frequency.OUTPUTS`).
        feedback: Steer-torque feedback of ``eigen``, ``locus`` and ``bode`` (their closed
            loop), or None.
        ride: Ride records of ``ride`` (CSV files or bags; none: no ``ride`` figure).
    """

    formats: tuple[str, ...]
    riders: tuple[str, ...]
    speeds: NDArray[np.float64] | None
    speed: float | None
    mode: str
    input: str
    output: str
    feedback: Feedback | None = None
    ride: tuple[str, ...] = ()


def options_from_args(args: argparse.Namespace) -> PlotOptions:
    """Check every option (before any input is loaded).

    Args:
        args: The parsed arguments of ``bike-rig plot``.

    Returns:
        The checked options, defaults filled in.

    Raises:
        PlotUsageError: An invalid option, named with the reason.
    """
    if args.speed is not None and not (math.isfinite(args.speed) and 0 <= args.speed <= MAX_SPEED):
        raise PlotUsageError(f"--speed must be a finite number from 0 to {MAX_SPEED:g} m/s, got {args.speed}")
    return PlotOptions(
        formats=parse_formats(args.format),
        riders=_riders(args.rider),
        speeds=_parse_speeds(args.speeds),
        speed=None if args.speed is None else float(args.speed),
        mode=args.mode,
        input=_pair_name(args.input, INPUTS, "--input") or INPUTS[1],
        output=_pair_name(args.output, OUTPUTS, "--output") or OUTPUTS[0],
        feedback=feedback_from_spec(getattr(args, "feedback", None)),
        ride=tuple(getattr(args, "ride", None) or ()),
    )


def parse_formats(spec: str) -> tuple[str, ...]:
    """``"png,svg"`` → ``("png", "svg")`` (each once, in order).

    Args:
        spec: Comma-separated formats, as given to ``--format``.

    Returns:
        The formats, lower case, each once.

    Raises:
        PlotUsageError: An unknown or empty format.
    """
    from ..plots.style import FORMATS

    out: list[str] = []
    for part in spec.split(","):
        f = part.strip().lower()
        if f not in FORMATS:
            raise PlotUsageError(f"--format: unknown format '{part.strip()}' (expected {', '.join(FORMATS)})")
        if f not in out:
            out.append(f)
    return tuple(out)


def _parse_speeds(spec: Sequence[str] | None) -> NDArray[np.float64] | None:
    if spec is None:
        return None
    try:
        start, stop, n = float(spec[0]), float(spec[1]), int(spec[2])
    except ValueError:
        raise PlotUsageError(f"--speeds START STOP N: numbers expected, got {' '.join(spec)}") from None
    if not (math.isfinite(start) and math.isfinite(stop)) or start < 0 or start >= stop or stop > MAX_SPEED or n < 2:
        raise PlotUsageError(
            f"--speeds START STOP N needs 0 <= START < STOP <= {MAX_SPEED:g} m/s and N >= 2, got {' '.join(spec)}"
        )
    return np.linspace(start, stop, n)


def _pair_name(value: str | None, allowed: Sequence[str], option: str) -> str | None:
    """``steer-torque`` / ``steer_torque`` / ``steer torque`` → ``steer torque``."""
    if value is None:
        return None
    name = re.sub(r"[-_\s]+", " ", value.strip().lower())
    if name not in allowed:
        raise PlotUsageError(f"{option}: unknown '{value}' (expected one of: {', '.join(allowed)})")
    return name


def _no_trials_reason(subject: Subject) -> str:
    if subject.kind == "parameters":
        return "it is a parameter file, which holds no trials"
    if subject.kind == "measurements":
        return "its periods are numbers, not trial files (give a session bag or a session.yaml with trial files)"
    return "it has no trials"


def _complete_for_kinds(subjects: list[Subject], kinds: Sequence[str], ride: bool) -> list[Subject]:
    """Check the incomplete sessions among ``subjects`` against the kinds asked for, and say what they lack.

    An incomplete session (a bag of a session that did not finish) has trials but no parameters:
    its trial figures are drawn and a note on stderr names the keys without a usable trial; the
    figures drawn from the parameters leave it out (``all``: with the note) or, asked for by name,
    are refused.

    Args:
        subjects: The inputs.
        kinds: The kinds to draw.
        ride: Ride records are given (else the ``ride`` kind draws nothing).

    Returns:
        ``subjects``, in order.

    Raises:
        SubjectError: A figure drawn from the parameters is asked for by name and an input is
            incomplete (names it and its missing keys).
    """
    from ..offline.subjects import SubjectError, incomplete_reason

    model_kinds = [k for k in kinds if not FIGURES[k].needs_trials and (ride or "ride" not in FIGURES[k].options)]
    for subject in subjects:
        if subject.complete:
            continue
        reason = incomplete_reason(subject.missing)
        if model_kinds and len(kinds) == 1:
            raise SubjectError(subject.path, f"{reason}; the {kinds[0]} figure needs its parameters")
        skipped = f"; no {', '.join(model_kinds)} figures for it (they need its parameters)" if model_kinds else ""
        drawn = "drawing the trials it has" if subject.trials else "no trial to draw yet"
        print(f"bike-rig plot: note: {subject.path}: {reason}: {drawn}{skipped}", file=sys.stderr)
    return subjects


def _kind_jobs(kind: FigureKind, subjects: list[Subject], opts: PlotOptions, out: Path) -> Iterator[FigureJob]:
    """The figures of one kind: one of every input (per rider), or one per input or trial."""
    draw = kind.drawer()  # imported here, so a figure's time (--timings) is its drawing only
    if "ride" in kind.options and not opts.ride:
        return  # (drawn only for ride records)
    if not kind.needs_trials:
        subjects = [s for s in subjects if s.complete]  # (an incomplete session has no parameters)
        if not subjects:
            return
    options = {name: getattr(opts, name) for name in kind.options if name != "rider"}
    if options.get("speed", 0.0) is None:
        del options["speed"]  # the figure's own default (see DEFAULT_SPEED_TEXT)
    if kind.scope is Scope.BICYCLES:
        for rider in opts.riders if kind.per_rider else ("",):
            ridden = {"rider": rider} if kind.per_rider else {}
            yield FigureJob(figure_stem(out, kind.name, rider=rider), partial(draw, subjects, **ridden, **options))
        return
    for subject, bicycle in zip(subjects, unique_names([s.name for s in subjects]), strict=True):
        if kind.scope is Scope.SUBJECT:
            if subject.trials:
                yield FigureJob(figure_stem(out, kind.name, bicycle), partial(draw, subject, **options))
            continue
        names = unique_names([trial_name(t.trial_id) for t in subject.trials])
        for trial, name in zip(subject.trials, names, strict=True):
            yield FigureJob(figure_stem(out, kind.name, bicycle, trial=name), partial(draw, trial, **options))


def figure_jobs(kinds: Sequence[str], subjects: list[Subject], opts: PlotOptions, out: Path) -> Iterator[FigureJob]:
    """Every figure of ``kinds`` (inputs without trials give no ``trials``/``fits`` figure).

    Args:
        kinds: Names of :data:`bike_rig.plots.registry.FIGURES`, in drawing order.
        subjects: The inputs.
        opts: The checked options.
        out: The output directory.

    Yields:
        One job per figure, in order.
    """
    for kind in kinds:
        yield from _kind_jobs(FIGURES[kind], subjects, opts, out)


def run(args: argparse.Namespace) -> int:
    """Draw the figures and print each written file.

    Args:
        args: The parsed arguments of ``bike-rig plot``.

    Returns:
        The exit status, 0 (errors raise).

    Raises:
        PlotUsageError: A user mistake, before anything is drawn.
        InputFileError: An input cannot be read, or the output directory or a file cannot be
            written.
    """
    from ..offline.subjects import load_subject
    from ..plots.style import save_figure

    if args.kind not in (*KINDS, "all"):
        raise PlotUsageError(f"unknown figure kind '{args.kind}' (expected one of: {', '.join(KINDS)}, all)")
    opts = options_from_args(args)
    if args.kind == "ride" and not opts.ride:
        raise PlotUsageError("the ride figure needs ride records: --ride RECORD (CSV file or bag, repeatable)")
    out = check_out_dir(args.out)
    subjects = [load_subject(p, args.com_method, partial=True) for p in args.inputs]
    kinds = KINDS if args.kind == "all" else (args.kind,)
    for subject in subjects:
        if subject.trials:
            continue
        why = f"{subject.path}: no trials to plot: {_no_trials_reason(subject)}"
        if args.kind in TRIAL_KINDS:
            raise PlotUsageError(why)
        if args.kind == "all":
            print(f"bike-rig plot: note: {why}; no trials or fits figures for it", file=sys.stderr)
    subjects = _complete_for_kinds(subjects, kinds, bool(opts.ride))
    timings: list[str] = []
    for job in figure_jobs(kinds, subjects, opts, out):
        t0 = time.perf_counter()
        fig = job.draw()
        for path in save_figure(fig, job.stem, opts.formats):
            print(path, flush=True)
        timings.append(f"{job.stem.name}: {(time.perf_counter() - t0) * 1e3:.0f} ms")
    if args.timings:
        print("\n".join(timings), file=sys.stderr)
    return 0


def add_parser(sub: Any) -> None:
    """Register ``bike-rig plot``.

    Args:
        sub: ``bike-rig``'s sub-command parsers (``add_subparsers()``).
    """
    q = sub.add_parser(
        "plot",
        help=HELP["plot"],
        description="Draw figures of one or several bicycles (measurement files, parameter files or "
        "session bags) as PNG and/or SVG files in DIR, and print each file written.",
    )
    q.add_argument(
        "kind",
        metavar="KIND",
        help=", ".join(f"{k.name} ({k.help})" if k.help else k.name for k in FIGURES.values()) + ", or all",
    )
    q.add_argument("inputs", metavar="INPUT", nargs="+", help="measurement file, parameter file or session bag")
    q.add_argument("-o", "--out", metavar="DIR", required=True, help="directory for the figures (created if missing)")
    q.add_argument("--format", default="png", help="comma-separated file formats: png, svg (default png)")
    q.add_argument(
        "--rider",
        default="none",
        help="model figures without the rider (none, default), with the paper's rigid rider (Table 1: paper), "
        "both, or with the rider of a rider YAML file (rigid or Yeadon)",
    )
    q.add_argument("--speed", type=float, help=f"speed of modes and bode, m/s (default: {DEFAULT_SPEED_TEXT})")
    q.add_argument("--speeds", nargs=3, metavar=("START", "STOP", "N"), help="speeds of eigen and locus, m/s")
    q.add_argument(
        "--mode",
        choices=tuple(dict.fromkeys(MODE_LABELS)),
        default=DEFAULT_MODE,
        help=f"the mode of the modes figure (default {DEFAULT_MODE})",
    )
    q.add_argument("--input", help=f"input of the bode figure: {', '.join(INPUTS)} (default {INPUTS[1]})")
    q.add_argument("--output", help=f"output of the bode figure: {', '.join(OUTPUTS)} (default {OUTPUTS[0]})")
    add_com_method_option(q)
    add_feedback_option(q)
    q.add_argument(
        "--ride",
        action="append",
        metavar="RECORD",
        help="a ride record of the ride figure (CSV or bag with the speed; repeatable)",
    )
    q.add_argument("--timings", action="store_true", help="print how long each figure took on standard error")
    q.set_defaults(func=run)
