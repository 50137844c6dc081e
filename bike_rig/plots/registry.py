"""The figure registry: every kind of figure once, for ``bike-rig plot`` and for the report.

Each :class:`FigureKind` says what ``bike-rig plot KIND`` and the report need to know: its name,
its drawing function (``module:function`` under :mod:`bike_rig.plots`, imported only when a
figure is drawn, so that nothing here loads matplotlib), what one figure shows (:class:`Scope`),
which plot options the function takes, the stem of its file names, and the report's figures of
it (:class:`ReportEntry`, with their options). Both consumers iterate :data:`FIGURES`:
:mod:`bike_rig.cli.plot_cmd` and :mod:`bike_rig.report.figures`.

Adding a figure is one module under ``bike_rig/plots/`` and one entry in :data:`FIGURES`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .output import slug

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "BODE_SPEEDS",
    "FIGURES",
    "FIT_DPI",
    "FIT_FIGURE_SIZE_IN",
    "KINDS",
    "PAIR_SPEED",
    "PLOT_OPTIONS",
    "STABLE_SPEED",
    "FigureKind",
    "ReportEntry",
    "Scope",
    "figure_stem",
    "report_entries",
]

#: The plot options a kind may take: keywords of its drawing function, and fields of
#: :class:`bike_rig.cli.plot_cmd.PlotOptions` (``rider``: one figure per rider asked for;
#: ``feedback``: the closed loop of a steer-torque feedback, :class:`bike_rig.core.feedback.Feedback`;
#: ``ride``: ride records, a kind that takes them is drawn only when some are given).
PLOT_OPTIONS: tuple[str, ...] = ("rider", "speeds", "speed", "mode", "input", "output", "feedback", "ride")
#: A report option value: a speed inside the bicycle's stable range, m/s (the report computes it).
STABLE_SPEED = "stable"
#: A report option value: a speed inside the interval where the bicycle's capsize and caster
#: roots form a complex pair (paper Fig 15), m/s, computed from its model by the report (inside
#: the stable range when there is no such pair, and the caption says so).
PAIR_SPEED = "capsize-caster pair"
#: The report's Bode diagrams' speeds, m/s, a line each: the paper's Figs 17/18 are at 2 m/s;
#: 5 m/s shows the same bicycle faster.
BODE_SPEEDS = (2.0, 5.0)
#: Size of each of the report's trial fit figures, inches (the plot's default is 10 × 6).
FIT_FIGURE_SIZE_IN = (8.0, 4.0)
#: Resolution of the report's trial fit figures (many, and simple), dots per inch.
FIT_DPI = 75


class Scope(Enum):
    """What one figure of a kind shows, and so what its drawing function takes first."""

    #: Every input in one figure (a panel or a line each): takes a sequence of subjects.
    BICYCLES = "bicycles"
    #: One figure per input that has trials: takes a :class:`bike_rig.offline.subjects.Subject`.
    SUBJECT = "subject"
    #: One figure per trial: takes a trial record of :class:`bike_rig.offline.subjects.Subject`.
    TRIAL = "trial"


@dataclass(frozen=True)
class ReportEntry:
    """One figure of the report, of a registered kind.

    Attributes:
        page: Position on the report's page (the entries are drawn in this order; a
            :attr:`Scope.TRIAL` kind's entry stands for one figure per trial, in trial order).
        key: Its id on the page (``fig-<key>``); for a trial, a template with ``{n}``, the
            trial's 1-based number.
        title: Heading: a :meth:`str.format` template with ``{rider}`` ("without rider" or
            "with the <rider's name>"), ``{speed}`` (the figure's speed, m/s) and, for a trial,
            ``{trial_id}`` and ``{key}`` (its period key).
        caption: What it shows.
        options: Keywords of the drawing function (only those given are passed);
            ``speed=STABLE_SPEED`` asks for a speed inside the stable range, ``speed=PAIR_SPEED``
            one inside the capsize–caster complex interval.
        size_in: (width, height) to draw it at, inches; None keeps the figure's own size.
        dpi: Its resolution, dots per inch; None for the report's.
    """

    page: int
    key: str
    title: str
    caption: str
    options: Mapping[str, Any] = field(default_factory=dict)
    size_in: tuple[float, float] | None = None
    dpi: float | None = None


@dataclass(frozen=True)
class FigureKind:
    """One kind of figure.

    Attributes:
        name: The kind as in ``bike-rig plot KIND``.
        function: Its drawing function, ``module:function`` under :mod:`bike_rig.plots`. It
            takes the target of :attr:`scope` first, then the keywords of :attr:`options`, and
            returns a :class:`matplotlib.figure.Figure`.
        scope: What one figure shows.
        help: What it is, for ``bike-rig plot --help`` ("" for the name alone).
        options: The :data:`PLOT_OPTIONS` it takes.
        stem: First part of its files' names (default: :attr:`name`).
        report: The report's figures of this kind (none: not in the report).
    """

    name: str
    function: str
    scope: Scope
    help: str = ""
    options: tuple[str, ...] = ()
    stem: str = ""
    report: tuple[ReportEntry, ...] = ()

    @property
    def file_stem(self) -> str:
        """First part of its files' names."""
        return self.stem or self.name

    @property
    def per_rider(self) -> bool:
        """Drawn from the Whipple model, once per rider asked for."""
        return "rider" in self.options

    @property
    def needs_trials(self) -> bool:
        """Drawn from trials only (an input without trials has none of these figures)."""
        return self.scope is not Scope.BICYCLES

    def drawer(self) -> Callable[..., Figure]:
        """Import and return the drawing function.

        Returns:
            The function (see :attr:`function`).

        Raises:
            ModuleNotFoundError: Its module is not installed (``name`` is the module's).
        """
        module, function = self.function.split(":")
        drawer: Callable[..., Figure] = getattr(importlib.import_module(f"{__package__}.{module}"), function)
        return drawer

    def draw(self, target: Any, **options: Any) -> Figure:
        """Draw one figure.

        Args:
            target: What it shows (see :class:`Scope`).
            **options: Keywords of the drawing function.

        Returns:
            The figure.
        """
        return self.drawer()(target, **options)


def _both_riders(pages: tuple[int, int], key: str, title: str, caption: str, **options: Any) -> tuple[ReportEntry, ...]:
    """A model figure without (``key``) and with the paper's rider (``key-rider``)."""
    return (
        ReportEntry(pages[0], key, title, caption, {**options, "rider": ""}),
        ReportEntry(pages[1], f"{key}-rider", title, caption, {**options, "rider": "paper"}),
    )


def _mode(page: int, mode: str, speed: str, caption: str) -> ReportEntry:
    """A mode's eigenvector without rider, at ``speed`` (:data:`STABLE_SPEED` or :data:`PAIR_SPEED`)."""
    return ReportEntry(
        page,
        f"mode-{mode}",
        f"{mode.capitalize()} eigenvector at {{speed:g}} m/s, without rider",
        caption,
        {"mode": mode, "speed": speed, "rider": ""},
    )


def _speeds_text(speeds: tuple[float, ...]) -> str:
    """``(2.0, 5.0)`` → ``"2 and 5 m/s"``."""
    names = [f"{v:g}" for v in speeds]
    return (", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1 else names[0]) + " m/s"


_EIGEN_CAPTION = (
    "Real and imaginary parts of the eigenvalues with σ bands; weave and capsize speeds marked (paper Figs 13 and 16)."
)
_LOCUS_CAPTION = "Eigenvalues in the complex plane with speed as the parameter (paper Fig 14)."
_WEAVE_CAPTION = "Components of the weave mode's eigenvector as phasors, at a speed inside the stable range."
_PAIR_CAPTION = (
    "Components of the capsize mode's eigenvector as phasors (paper Fig 15 shows the complex pair the capsize "
    "and caster roots form at low speed)."
)
_BODE_TITLE = "Steer torque to roll angle at " + _speeds_text(BODE_SPEEDS) + ", {rider}"
_BODE_CAPTION = (
    "Bode magnitude and phase, a line per speed: "
    + " and ".join(f"{v:g} m/s" for v in BODE_SPEEDS)
    + "; the paper's Figs 17 and 18 are at 2 m/s."
)
_SIDE_CAPTION = "Wheels, steer axis and mass centres with their uncertainty ellipses (magnified as stated)."
_OVERVIEW_CAPTION = "Each trial's period against its key's combined period, its r² and its cycles."
_FIT_CAPTION = "Samples with the Eq 23 fit over its window, and the residuals."

#: Every kind of figure, in the order ``bike-rig plot all`` draws them. One entry per kind.
_KINDS = (
    FigureKind(
        "eigen",
        "eigen:eigen_vs_speed",
        Scope.BICYCLES,
        "eigenvalues vs speed",
        ("rider", "speeds", "feedback"),
        report=_both_riders((10, 30), "eigen", "Eigenvalues against speed, {rider}", _EIGEN_CAPTION),
    ),
    FigureKind(
        "locus",
        "locus:root_locus",
        Scope.BICYCLES,
        "root locus",
        ("rider", "speeds", "feedback"),
        report=_both_riders((20, 40), "locus", "Root locus, {rider}", _LOCUS_CAPTION),
    ),
    FigureKind(
        "modes",
        "modes:eigenvector_figure",
        Scope.BICYCLES,
        "eigenvector of a mode",
        ("rider", "mode", "speed"),
        report=(_mode(50, "weave", STABLE_SPEED, _WEAVE_CAPTION), _mode(60, "capsize", PAIR_SPEED, _PAIR_CAPTION)),
    ),
    FigureKind(
        "bode",
        "bode:bode_figure",
        Scope.BICYCLES,
        "",
        ("rider", "speed", "input", "output", "feedback"),
        report=_both_riders((70, 80), "bode", _BODE_TITLE, _BODE_CAPTION, speed=BODE_SPEEDS),
    ),
    FigureKind(
        "side",
        "sideview:side_view",
        Scope.BICYCLES,
        "side view",
        report=(ReportEntry(0, "side-view", "Side view", _SIDE_CAPTION),),
    ),
    FigureKind(
        "trials",
        "trials:trial_overview",
        Scope.SUBJECT,
        "trial-quality overview",
        report=(ReportEntry(90, "trial-overview", "Trial quality", _OVERVIEW_CAPTION),),
    ),
    FigureKind(
        "fits",
        "trials:fit_figure",
        Scope.TRIAL,
        "one figure per trial",
        stem="fit",
        report=(
            ReportEntry(
                100, "fit-{n}", "Trial {trial_id} ({key})", _FIT_CAPTION, size_in=FIT_FIGURE_SIZE_IN, dpi=FIT_DPI
            ),
        ),
    ),
    FigureKind(
        "ride",
        "ride:ride_figure",
        Scope.BICYCLES,
        "measured weave eigenvalues of --ride records over the model's, one bicycle",
        ("rider", "speeds", "feedback", "ride"),
    ),
)
#: Every kind of figure, by name, in the order ``bike-rig plot all`` draws them.
FIGURES: Mapping[str, FigureKind] = {k.name: k for k in _KINDS}
#: Every kind's name, in the order ``bike-rig plot all`` draws them.
KINDS: tuple[str, ...] = tuple(FIGURES)


def report_entries() -> Iterator[tuple[FigureKind, ReportEntry]]:
    """Every figure of the report with its kind, in page order (registry order on a tie).

    Yields:
        (kind, entry) pairs.
    """
    pairs = [(kind, entry) for kind in FIGURES.values() for entry in kind.report]
    yield from sorted(pairs, key=lambda pair: pair[1].page)


def figure_stem(out_dir: Path, kind: str, bicycle: str = "", rider: str = "", trial: str = "") -> Path:
    """Where a figure is written, without its extension.

    Args:
        out_dir: The output directory.
        kind: The figure's kind (an unregistered name is used as it is).
        bicycle: The bicycle's file-name form (see :func:`~.output.unique_names`), or "".
        rider: The rider ("" for none; any other gives ``_rider``).
        trial: The trial's name (made a file name with :func:`~.output.slug`), or "".

    Returns:
        ``out_dir/<stem>[_<bicycle>][_<trial>][_rider]``, ``<stem>`` the kind's
        :attr:`FigureKind.file_stem` (``fits`` files are named ``fit_...``).
    """
    parts = [FIGURES[kind].file_stem if kind in FIGURES else kind]
    if bicycle:
        parts.append(bicycle)
    if trial:
        parts.append(slug(trial))
    if rider:
        parts.append("rider")
    return out_dir / "_".join(parts)
