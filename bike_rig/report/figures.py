"""The report's figures: which ones, drawn by :mod:`bike_rig.plots`, embedded as PNG data URIs.

The figures are the report entries of the figure registry (:mod:`bike_rig.plots.registry`),
which ``bike-rig plot`` draws from too. For every input: the side view, eigenvalues against
speed (paper Figs 13/16), the root locus (Fig 14), the weave eigenvector inside the stable
speed range, the capsize–caster pair's eigenvector at a speed inside the interval where that
pair exists (Fig 15; both computed from the bicycle's model, and the caption says which), and
the Bode diagram of steer torque → roll angle at the paper's 2 m/s and at 5 m/s (Figs 17/18),
without and with the paper's rider. With trials: the trial-quality overview and one fit
figure per trial (data, fit, residuals).

The figure modules are imported when a figure is drawn. A figure whose module is not
installed, or that cannot be drawn for this bicycle (a :class:`BikeRigError`, e.g. no such
mode), is listed with the reason instead of an image; any other exception is a bug and
propagates.

Rendering is the report's main cost: the figures are drawn in forked worker processes
(:func:`draw_figures`), the model figures rasterised at :data:`REPORT_DPI` and the many fit
figures smaller than the plot's default, at :data:`FIT_DPI`.
"""

from __future__ import annotations

import base64
import io
import math
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial
from typing import Any

from matplotlib.figure import Figure

from ..core.errors import BikeRigError
from ..core.feedback import Feedback
from ..offline.subjects import Subject
from ..plots.registry import (
    FIGURES,
    FIT_DPI,
    PAIR_SPEED,
    STABLE_SPEED,
    FigureKind,
    ReportEntry,
    Scope,
    report_entries,
)
from ..plots.style import escape_figure_text
from .results import ReportResults

__all__ = [
    "FIT_DPI",
    "MAX_WORKERS",
    "REPORT_DPI",
    "FigureSpec",
    "ReportFigure",
    "default_workers",
    "draw_figures",
    "figure_specs",
    "png_data_uri",
]

#: Resolution of the embedded PNGs, dots per inch.
REPORT_DPI = 100
#: Added to the caption of a closed-loop figure.
_CLOSED_NOTE = " Closed loop A − B K of the steer-torque feedback (σ from the parameters and the gains given with σ)."
#: Fewer figures than this are drawn in this process (a pool costs more than it saves).
MIN_PARALLEL = 4
#: Most processes to draw figures in.
MAX_WORKERS = 4


def default_workers() -> int:
    """Processes to draw in: the CPUs this process may use, at most :data:`MAX_WORKERS` (at least 1)."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # (not on Linux)
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_WORKERS))


@dataclass(frozen=True)
class FigureSpec:
    """A figure to draw.

    Attributes:
        key: Its id on the page (``fig-<key>``).
        title: Heading.
        caption: What it shows.
        draw: Draws it (imports its module).
        size_in: (width, height) to draw it at, inches; None keeps the plot's own size.
        dpi: Its resolution, dots per inch; None for the report's.
    """

    key: str
    title: str
    caption: str
    draw: Callable[[], Figure]
    size_in: tuple[float, float] | None = None
    dpi: float | None = None


@dataclass(frozen=True)
class ReportFigure:
    """A drawn (or undrawable) figure.

    Attributes:
        key: Its id on the page.
        title: Heading.
        caption: What it shows.
        uri: The PNG as a ``data:image/png;base64,`` URI, or None when not drawn.
        unavailable: Why it was not drawn ("" when it was).
        seconds: Time taken to draw and encode it, s.
    """

    key: str
    title: str
    caption: str
    uri: str | None
    unavailable: str
    seconds: float


def png_data_uri(fig: Figure, dpi: float = REPORT_DPI) -> str:
    """A figure as a PNG ``data:`` URI, for a self-contained page.

    Args:
        fig: The figure.
        dpi: Resolution, dots per inch.

    Returns:
        ``data:image/png;base64,...``.
    """
    buf = io.BytesIO()
    escape_figure_text(fig)
    fig.savefig(buf, format="png", dpi=dpi)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _mode_speed(results: ReportResults) -> float:
    """A speed to show the mode shapes at, m/s: inside the stable range, else 5 m/s."""
    for lo, hi in results.bare.stable:
        return 0.5 * (lo + min(hi, lo + 4.0))
    return 5.0


def _pair_speed(subject: Subject, rider: str, stable_speed: float) -> tuple[float, str]:
    """The speed of the capsize–caster pair's eigenvector (m/s), and what the caption adds."""
    from ..plots.model_data import capsize_caster_speed

    pair = capsize_caster_speed(subject, rider)
    if pair is None:
        return stable_speed, (
            f" This bicycle's capsize and caster roots form no complex pair (from its model, 0 to 10 m/s), so "
            f"the capsize mode is shown at {stable_speed:g} m/s, inside the stable speed range."
        )
    speed, (lo, hi) = pair
    return speed, (
        f" This bicycle has the pair from {lo:.2f} to {hi:.2f} m/s (from its model); it is shown at {speed:g} m/s, "
        "the middle of that interval."
    )


def _spec(
    kind: FigureKind, entry: ReportEntry, target: Any, options: dict[str, Any], note: str = "", **fields: Any
) -> FigureSpec:
    """``entry`` of ``kind`` drawn for ``target`` with ``options``; ``fields`` fill its key and title.

    ``note`` is added to the entry's caption.
    """
    return FigureSpec(
        entry.key.format(**fields),
        entry.title.format(**fields),
        entry.caption + note,
        partial(kind.draw, target, **options),
        entry.size_in,
        entry.dpi,
    )


def figure_specs(subject: Subject, results: ReportResults | None, rider_choice: str = "paper") -> list[FigureSpec]:
    """Every figure of the report of ``subject``, in page order.

    The figures are the report entries of :data:`bike_rig.plots.registry.FIGURES`; a trial
    kind's entry gives one figure per trial, and those of kinds drawn from trials are left out
    for a bicycle without trials.

    Args:
        subject: The bicycle.
        results: Its numbers (the rider's name, and the stable range for the mode shapes' speed);
            None for an incomplete session: only the figures drawn from its trials.
        rider_choice: The rider of the figures drawn with a rider: ``"paper"`` or a rider file.

    Returns:
        The specs, in page order.
    """
    rider_name = results.rider.rider.name if results is not None and results.rider.rider is not None else "rider"
    stable_speed = round(_mode_speed(results), 1) if results is not None else math.nan
    specs: list[FigureSpec] = []
    for kind, entry in report_entries():
        if results is None and kind.scope not in (Scope.TRIAL, Scope.SUBJECT):
            continue  # a model figure needs the parameters
        note = ""
        options = dict(entry.options)
        if options.get("rider"):
            options["rider"] = rider_choice
        if options.get("speed") == STABLE_SPEED:
            options["speed"] = stable_speed
        elif options.get("speed") == PAIR_SPEED:
            options["speed"], note = _pair_speed(subject, options.get("rider", ""), stable_speed)
        rider = "without rider" if not options.get("rider") else f"with the {rider_name}"
        if kind.scope is Scope.TRIAL:
            specs += [
                _spec(kind, entry, t, options, n=k + 1, trial_id=t.trial_id, key=t.key)
                for k, t in enumerate(subject.trials)
            ]
        elif kind.scope is Scope.SUBJECT:
            if subject.trials:
                specs.append(_spec(kind, entry, subject, options, rider=rider, speed=options.get("speed")))
        else:
            specs.append(_spec(kind, entry, [subject], options, note, rider=rider, speed=options.get("speed")))
    if results is not None and results.closed_loop is not None:
        specs += _closed_loop_specs(subject, results.closed_loop.feedback)
    return specs


def _closed_loop_specs(subject: Subject, feedback: Feedback) -> list[FigureSpec]:
    """The closed loop's eigenvalues against speed and Bode diagram, without rider."""
    out = []
    for name, key, title in (
        ("eigen", "eigen-closed-loop", "Eigenvalues against speed, closed loop ({feedback}), without rider"),
        ("bode", "bode-closed-loop", "Steer torque to roll angle, closed loop ({feedback}), without rider"),
    ):
        kind = FIGURES[name]
        entry = kind.report[0]
        options = {**entry.options, "feedback": feedback}
        closed = ReportEntry(entry.page, key, title, entry.caption + _CLOSED_NOTE, options, entry.size_in, entry.dpi)
        out.append(_spec(kind, closed, [subject], options, feedback=feedback.name, speed=options.get("speed")))
    return out


def _unavailable(exc: BaseException) -> str | None:
    """Why a figure could not be drawn, or None if ``exc`` is a bug to re-raise."""
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").startswith("bike_rig.plots"):
        return f"not available: {exc.name} is not installed"
    if isinstance(exc, BikeRigError):
        return f"cannot be drawn: {exc}"
    return None


def _draw_one(spec: FigureSpec, dpi: float) -> ReportFigure:
    t0 = time.perf_counter()
    try:
        fig = spec.draw()
    except (ModuleNotFoundError, BikeRigError) as exc:
        why = _unavailable(exc)
        if why is None:
            raise
        return ReportFigure(spec.key, spec.title, spec.caption, None, why, time.perf_counter() - t0)
    if spec.size_in is not None:
        fig.set_size_inches(*spec.size_in)
    return ReportFigure(
        spec.key, spec.title, spec.caption, png_data_uri(fig, spec.dpi or dpi), "", time.perf_counter() - t0
    )


#: The specs of the pool's worker process (inherited through fork, never pickled).
_WORKER_SPECS: Sequence[FigureSpec] = ()


def _worker_init(specs: Sequence[FigureSpec]) -> None:
    global _WORKER_SPECS
    _WORKER_SPECS = specs


def _worker_draw(index: int, dpi: float) -> ReportFigure:
    return _draw_one(_WORKER_SPECS[index], dpi)


def draw_figures(
    specs: Sequence[FigureSpec], dpi: float = REPORT_DPI, workers: int | None = None
) -> tuple[ReportFigure, ...]:
    """Draw and encode each figure, in order (see the module docstring for failures).

    Args:
        specs: The figures.
        dpi: Resolution of the PNGs, dots per inch.
        workers: Processes to draw in (default :func:`default_workers`). With more than one,
            and at least :data:`MIN_PARALLEL` figures, the figures are drawn in forked worker
            processes (each inherits the specs, so nothing large is pickled; each returns its
            PNG); otherwise, or where ``fork`` is not available, in this process.

    Returns:
        One :class:`ReportFigure` per spec, in order.

    Raises:
        Exception: Whatever a figure raised that is a bug (not a missing figure module or a
            :class:`BikeRigError`), re-raised here.
    """
    n = default_workers() if workers is None else max(1, workers)
    if n == 1 or len(specs) < MIN_PARALLEL or "fork" not in mp.get_all_start_methods():
        return tuple(_draw_one(s, dpi) for s in specs)
    ctx = mp.get_context("fork")
    with ProcessPoolExecutor(min(n, len(specs)), mp_context=ctx, initializer=_worker_init, initargs=(specs,)) as pool:
        return tuple(pool.map(_worker_draw, range(len(specs)), [dpi] * len(specs)))
