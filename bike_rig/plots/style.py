"""Shared look and output of every figure.

A new Agg figure, colours per bicycle and per mode, and writing a figure to PNG/SVG files.

matplotlib is imported here and in the figure modules only, never by the core.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..core.errors import InputFileError

__all__ = [
    "FORMATS",
    "MODE_COLOURS",
    "bicycle_colour",
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


def new_figure(width_in: float = 8.0, height_in: float = 5.0) -> Figure:
    """A figure with an Agg canvas and constrained layout.

    Args:
        width_in: Width, inches.
        height_in: Height, inches.

    Returns:
        The empty figure.
    """
    fig = Figure(figsize=(width_in, height_in), layout="constrained")
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
    for fmt in formats:
        path = stem.with_name(f"{stem.name}.{fmt}")
        try:
            fig.savefig(path, format=fmt, dpi=PNG_DPI)
        except OSError as exc:
            raise InputFileError(str(path), f"cannot write the figure ({exc.strerror})") from None
        written.append(path)
    return written

