"""``bike-rig plot KIND INPUT... -o DIR``: the paper's section-10 figures and the lab's own views.

::

    bike-rig plot KIND INPUT... -o DIR [--format png,svg] [--rider none|paper|both]
                  [--speed V] [--speeds START STOP N] [--mode LABEL]
                  [--input NAME] [--output NAME] [--com-method centroid|lstsq]

KIND is one of :data:`KINDS`, or ``all`` for every kind. Each INPUT is a measurement file, a
parameter file or a session bag (:func:`bike_rig.subjects.load_subject`). The model figures
(``eigen``, ``locus``, ``modes``, ``bode``, once per rider asked for) and ``side`` draw every
input in one figure (a panel or a line each); ``trials`` and ``fits`` draw each input that
has trials on its own (with ``all``, inputs without trials are skipped with a note on stderr;
asked for by name, an input without trials is an error). Files written (see
:func:`figure_stem`)::

    DIR/<kind>[_rider].<fmt>              eigen, locus, modes, bode (``_rider``: the paper's rider)
    DIR/side.<fmt>
    DIR/trials_<bicycle>.<fmt>
    DIR/fit_<bicycle>_<trial>.<fmt>       (<trial>: the trial's id, or its file's name without extension)

``<bicycle>`` is the bicycle's name in lower case with anything but letters, digits, ``-``
and ``.`` replaced by ``-`` (``-2``, ``-3``... when two inputs share a name). Every written
file's path is printed on standard output, one per line. DIR is created when missing.
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

from ..core.benchmark import ComMethod
from ..core.errors import BikeRigError, InputFileError
from ..core.frequency import INPUTS, OUTPUTS
from ..core.whipple import MODE_LABELS
from ..plots.model_data import MAX_SPEED

if TYPE_CHECKING:
    from ..subjects import Subject

__all__ = [
    "DEFAULT_MODE",
    "DEFAULT_SPEED",
    "KINDS",
    "MODEL_KINDS",
    "FigureJob",
    "PlotOptions",
    "PlotUsageError",
    "add_parser",
    "figure_jobs",
    "figure_stem",
    "options_from_args",
    "parse_formats",
    "run",
    "slug",
    "unique_names",
]

#: Every figure kind, in the order ``all`` draws them.
KINDS: tuple[str, ...] = ("eigen", "locus", "modes", "bode", "side", "trials", "fits")
#: Kinds drawn from the Whipple model, once per rider asked for.
MODEL_KINDS: tuple[str, ...] = ("eigen", "locus", "modes", "bode")
#: Kinds that need trials (a session bag, or a measurement file whose periods are trial files).
TRIAL_KINDS: tuple[str, ...] = ("trials", "fits")
#: Speed of the ``modes`` and ``bode`` figures unless ``--speed`` is given, m/s (the paper's
#: Figs 15, 17 and 18: inside the capsize–caster complex-pair range of the rider-less bicycles).
DEFAULT_SPEED = 2.0
#: Mode of the ``modes`` figure unless ``--mode`` is given (Fig 15: the capsize–caster pair).
DEFAULT_MODE = "capsize"
_TRIAL_SUFFIXES = (".npy", ".csv", ".mat", ".txt")
_RIDERS = {"none": ("",), "paper": ("paper",), "both": ("", "paper")}


class PlotUsageError(BikeRigError):
    """An argument of ``bike-rig plot`` is invalid, or asks for a figure an input cannot give."""


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
        riders: Riders of the model figures: "" (none) and/or "paper".
        speeds: Speeds of ``eigen`` and ``locus``, m/s, or None for the figures' default.
        speed: Speed of ``modes`` and ``bode``, m/s.
        mode: Mode of ``modes``.
        input: Input of ``bode`` (one of :data:`bike_rig.core.frequency.INPUTS`).
        output: Output of ``bode`` (one of :data:`bike_rig.core.frequency.OUTPUTS`).
    """

    formats: tuple[str, ...]
    riders: tuple[str, ...]
    speeds: NDArray[np.float64] | None
    speed: float
    mode: str
    input: str
    output: str


def options_from_args(args: argparse.Namespace) -> PlotOptions:
    """Check every option (before any input is loaded).

    Raises:
        PlotUsageError: An invalid option, named with the reason.
    """
    if args.speed is not None and not (math.isfinite(args.speed) and 0 <= args.speed <= MAX_SPEED):
        raise PlotUsageError(f"--speed must be a finite number from 0 to {MAX_SPEED:g} m/s, got {args.speed}")
    return PlotOptions(
        formats=parse_formats(args.format),
        riders=_RIDERS[args.rider],
        speeds=_parse_speeds(args.speeds),
        speed=DEFAULT_SPEED if args.speed is None else float(args.speed),
        mode=args.mode,
        input=_pair_name(args.input, INPUTS, "--input") or INPUTS[1],
        output=_pair_name(args.output, OUTPUTS, "--output") or OUTPUTS[0],
    )


def parse_formats(spec: str) -> tuple[str, ...]:
    """``"png,svg"`` → ``("png", "svg")`` (each once, in order).

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


def slug(name: str) -> str:
    """``name`` in lower case with anything but letters, digits, ``-`` and ``.`` made ``-``."""
    s = re.sub(r"[^a-z0-9.\-]+", "-", name.lower()).strip("-")
    return s or "bicycle"


def _trial_name(trial_id: str) -> str:
    """A trial's id without its file's extension (``frame_compound_t1.npy`` → ``frame_compound_t1``)."""
    p = Path(trial_id)
    return p.stem if p.suffix.lower() in _TRIAL_SUFFIXES else trial_id


def unique_names(names: Sequence[str]) -> list[str]:
    """File-name forms (:func:`slug`) of ``names``, made distinct with ``-2``, ``-3``..."""
    out: list[str] = []
    for name in names:
        base = slug(name)
        name, k = base, 2
        while name in out:
            name, k = f"{base}-{k}", k + 1
        out.append(name)
    return out


def figure_stem(out_dir: Path, kind: str, bicycle: str = "", rider: str = "", trial: str = "") -> Path:
    """``out_dir/<kind>[_<bicycle>][_<trial>][_rider]`` (``fits`` files are named ``fit_...``)."""
    parts = ["fit" if kind == "fits" else kind]
    if bicycle:
        parts.append(bicycle)
    if trial:
        parts.append(slug(trial))
    if rider:
        parts.append("rider")
    return out_dir / "_".join(parts)


def _check_out_dir(path: str) -> Path:
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise InputFileError(str(out), "exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputFileError(str(out), f"cannot create the directory ({exc.strerror or exc})") from None
    return out


def _no_trials_reason(subject: Subject) -> str:
    if subject.kind == "parameters":
        return "it is a parameter file, which holds no trials"
    if subject.kind == "measurements":
        return "its periods are numbers, not trial files (give a session bag or a session.yaml with trial files)"
    return "it has no trials"


def _model_jobs(kind: str, subjects: list[Subject], opts: PlotOptions, out: Path) -> Iterator[FigureJob]:
    for rider in opts.riders:
        stem = figure_stem(out, kind, rider=rider)
        if kind == "eigen":
            from ..plots.eigen import eigen_vs_speed

            yield FigureJob(stem, partial(eigen_vs_speed, subjects, rider=rider, speeds=opts.speeds))
        elif kind == "locus":
            from ..plots.locus import root_locus

            yield FigureJob(stem, partial(root_locus, subjects, rider=rider, speeds=opts.speeds))
        elif kind == "modes":
            from ..plots.modes import eigenvector_figure

            yield FigureJob(stem, partial(eigenvector_figure, subjects, mode=opts.mode, speed=opts.speed, rider=rider))
        else:
            from ..plots.bode import bode_figure

            draw = partial(bode_figure, subjects, speed=opts.speed, rider=rider, input=opts.input, output=opts.output)
            yield FigureJob(stem, draw)


def figure_jobs(kinds: Sequence[str], subjects: list[Subject], opts: PlotOptions, out: Path) -> Iterator[FigureJob]:
    """Every figure of ``kinds`` (inputs without trials give no ``trials``/``fits`` figure)."""
    slugs = unique_names([s.name for s in subjects])
    for kind in kinds:
        if kind in MODEL_KINDS:
            yield from _model_jobs(kind, subjects, opts, out)
        elif kind == "side":
            from ..plots.sideview import side_view

            yield FigureJob(figure_stem(out, "side"), partial(side_view, subjects))
        else:
            from ..plots.trials import fit_figure, trial_overview

            for subject, bicycle in zip(subjects, slugs):
                if kind == "trials" and subject.trials:
                    yield FigureJob(figure_stem(out, "trials", bicycle), partial(trial_overview, subject))
                elif kind == "fits":
                    names = unique_names([_trial_name(t.trial_id) for t in subject.trials])
                    for trial, name in zip(subject.trials, names):
                        yield FigureJob(figure_stem(out, "fits", bicycle, trial=name), partial(fit_figure, trial))


def run(args: argparse.Namespace) -> int:
    """Draw the figures and print each written file; returns the exit status (errors raise)."""
    from ..plots.style import save_figure
    from ..subjects import load_subject

    if args.kind not in (*KINDS, "all"):
        raise PlotUsageError(f"unknown figure kind '{args.kind}' (expected one of: {', '.join(KINDS)}, all)")
    opts = options_from_args(args)
    out = _check_out_dir(args.out)
    subjects = [load_subject(p, args.com_method) for p in args.inputs]
    kinds = KINDS if args.kind == "all" else (args.kind,)
    for subject in subjects:
        if subject.trials:
            continue
        why = f"{subject.path}: no trials to plot: {_no_trials_reason(subject)}"
        if args.kind in TRIAL_KINDS:
            raise PlotUsageError(why)
        if args.kind == "all":
            print(f"bike-rig plot: note: {why}; no trials or fits figures for it", file=sys.stderr)
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
    """Register ``bike-rig plot``."""
    q = sub.add_parser(
        "plot",
        help="figures: eigenvalues, root locus, mode shapes, Bode, side view, trial fits and overview",
        description="Draw figures of one or several bicycles (measurement files, parameter files or "
        "session bags) as PNG and/or SVG files in DIR, and print each file written.",
    )
    q.add_argument(
        "kind",
        metavar="KIND",
        help="eigen (eigenvalues vs speed), locus (root locus), modes (eigenvector of a mode), bode, "
        "side (side view), trials (trial-quality overview), fits (one figure per trial), or all",
    )
    q.add_argument("inputs", metavar="INPUT", nargs="+", help="measurement file, parameter file or session bag")
    q.add_argument("-o", "--out", metavar="DIR", required=True, help="directory for the figures (created if missing)")
    q.add_argument("--format", default="png", help="comma-separated file formats: png, svg (default png)")
    q.add_argument(
        "--rider",
        choices=tuple(_RIDERS),
        default="none",
        help="model figures without the rider, with the paper's rigid rider (Table 1), or both (default none)",
    )
    q.add_argument("--speed", type=float, help=f"speed of modes and bode, m/s (default {DEFAULT_SPEED:g})")
    q.add_argument("--speeds", nargs=3, metavar=("START", "STOP", "N"), help="speeds of eigen and locus, m/s")
    q.add_argument("--mode", choices=tuple(dict.fromkeys(MODE_LABELS)), default=DEFAULT_MODE,
                   help=f"the mode of the modes figure (default {DEFAULT_MODE})")  # fmt: skip
    q.add_argument("--input", help=f"input of the bode figure: {', '.join(INPUTS)} (default {INPUTS[1]})")
    q.add_argument("--output", help=f"output of the bode figure: {', '.join(OUTPUTS)} (default {OUTPUTS[0]})")
    q.add_argument("--com-method", choices=[m.value for m in ComMethod], default=None,
                   help="mass-centre method for raw readings: centroid (paper) or lstsq "
                        "(default: centroid; a bag: as recorded)")  # fmt: skip
    q.add_argument("--timings", action="store_true", help="print how long each figure took on standard error")
    q.set_defaults(func=run)
