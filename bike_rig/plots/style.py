"""Shared look and output of every figure.

A new Agg figure, colours per bicycle and per mode, and writing a figure to PNG/SVG files.

matplotlib is imported here and in the figure modules only, never by the core.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text

from ..core.errors import InputFileError
from ..core.textfmt import terminal_safe

__all__ = [
    "closed_loop_text",
    "FORMATS",
    "LINE_STYLES",
    "MARKERS",
    "MODE_COLOURS",
    "LineStyle",
    "bicycle_colour",
    "bicycle_line_style",
    "escape_figure_text",
    "new_figure",
    "save_figure",
]

#: File formats a figure can be written in.
FORMATS = ("png", "svg")
#: Resolution of PNG output, dots per inch.
PNG_DPI = 110
#: One colour per mode label of :data:`bike_rig.core.whipple.MODE_LABELS`.
MODE_COLOURS = {"weave": "C0", "capsize": "C3", "caster": "C2"}
_CYCLE = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C7", "C8", "C9")
#: Line styles of overlapping curves, one per bicycle in turn.
LINE_STYLES = ("-", "--", "-.", ":")
#: Markers of overlapping curves, one per bicycle in turn (8: with 4 line styles every bicycle of
#: a figure of up to 8 has its own style and marker, besides its own colour up to 10).
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
#: Widest line of overlapping curves (the first bicycle's), points; each next one is thinner.
_WIDEST = 2.8
_THINNEST = 1.0
_WIDTH_STEP = 0.35
#: Markers per curve of overlapping curves.
_MARKS_PER_LINE = 10


def new_figure(width_in: float = 8.0, height_in: float = 5.0, figure_class: type[Figure] = Figure) -> Figure:
    """A figure with an Agg canvas and constrained layout.

    Args:
        width_in: Width, inches.
        height_in: Height, inches.
        figure_class: The figure's class (a subclass of :class:`~matplotlib.figure.Figure`).

    Returns:
        The empty figure.
    """
    fig = figure_class(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def bicycle_colour(index: int) -> str:
    """The colour of a bicycle of a figure (matplotlib's default cycle).

    Args:
        index: The bicycle's 0-based place in the figure.

    Returns:
        A matplotlib colour (``C0``...``C9``, repeating).
    """
    return _CYCLE[index % len(_CYCLE)]


@dataclass(frozen=True)
class LineStyle:
    """How one bicycle's curve is drawn where curves of several bicycles overlap.

    Curves that coincide stay visible: each has its own colour, line style, marker and width;
    earlier curves are wider and drawn below later, thinner ones (``zorder``), and the markers of
    successive curves are staggered along the line, so they do not sit on each other.

    Attributes:
        color: A matplotlib colour.
        linestyle: A matplotlib line style.
        marker: A matplotlib marker.
        linewidth: Points.
        markevery: ``(start, step)``: a marker on every ``step``-th point from ``start``.
        zorder: Drawing order (later on top).
    """

    color: str
    linestyle: str
    marker: str
    linewidth: float
    markevery: tuple[int, int]
    zorder: float

    def kwargs(self) -> dict[str, Any]:
        """The style as keywords of :meth:`matplotlib.axes.Axes.plot`."""
        return {
            "color": self.color,
            "linestyle": self.linestyle,
            "marker": self.marker,
            "linewidth": self.linewidth,
            "markevery": self.markevery,
            "markersize": 4.5,
            "markerfacecolor": "white",
            "markeredgewidth": 1.0,
            "zorder": self.zorder,
        }


def bicycle_line_style(index: int, count: int, points: int) -> LineStyle:
    """The style of a bicycle's curve among ``count`` overlapping ones of ``points`` points each.

    Args:
        index: The bicycle's 0-based place in the figure.
        count: How many bicycles the figure draws.
        points: Points per curve.

    Returns:
        Its style: colour :func:`bicycle_colour`, line style and marker in turn from
        :data:`LINE_STYLES` and :data:`MARKERS`, a width falling with ``index``, and markers
        staggered by ``step / count`` points from one bicycle to the next.
    """
    step = max(1, points // _MARKS_PER_LINE)
    start = (index * step) // max(1, count) % step
    width = max(_THINNEST, _WIDEST - _WIDTH_STEP * index)
    return LineStyle(
        color=bicycle_colour(index),
        linestyle=LINE_STYLES[index % len(LINE_STYLES)],
        marker=MARKERS[index % len(MARKERS)],
        linewidth=width,
        markevery=(start, step),
        zorder=2.0 + 0.01 * index,
    )


def escape_figure_text(fig: Figure) -> None:
    r"""Write every control character of the figure's texts (a bicycle's name from a file) as ``\xNN``.

    No font has a glyph for them: matplotlib would draw boxes and warn, quoting the raw character.
    """
    for text in fig.findobj(Text):
        if isinstance(text, Text):
            text.set_text(terminal_safe(text.get_text()))


def save_figure(fig: Figure, stem: Path, formats: Sequence[str] = FORMATS) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each format (PNG at :data:`PNG_DPI`).

    Args:
        fig: The figure.
        stem: The path without its extension.
        formats: Formats of :data:`FORMATS`, in order.

    Returns:
        The files written, in the order of ``formats``.

    Raises:
        InputFileError: A file cannot be written (names the file and the reason).
    """
    written: list[Path] = []
    escape_figure_text(fig)
    for fmt in formats:
        path = stem.with_name(f"{stem.name}.{fmt}")
        try:
            fig.savefig(path, format=fmt, dpi=PNG_DPI)
        except OSError as exc:
            raise InputFileError(str(path), f"cannot write the figure ({exc.strerror})") from None
        written.append(path)
    return written


def closed_loop_text(feedback: str) -> str:
    """A title's closed-loop suffix: ``", closed loop (<feedback>)"``, or "" for the open loop.

    Args:
        feedback: The feedback's name ("" for none).
    """
    return f", closed loop ({feedback})" if feedback else ""
