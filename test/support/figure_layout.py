"""A figure's layout as its renderer draws it: text boxes, legends and the data points they may cover.

:func:`layout_faults` draws a figure on its Agg canvas, records the box of every text the
renderer draws (``Text.draw`` wrapped for the draw: tick labels, axis labels, titles, legend
entries, annotations), and lists what a reader would see as a fault: two texts overlapping, a
text outside the canvas, or a legend over plotted data points.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from unittest import mock

import numpy as np
from matplotlib.collections import Collection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.text import Text
from matplotlib.transforms import Bbox

#: Overlap below this many pixels in either direction is anti-aliasing, not an overlap.
TOLERANCE_PX = 1.0
#: Largest fraction of a figure's data points a legend may cover (a ``loc="best"`` legend in a
#: crowded axes); a legend placed outside the axes covers none.
MAX_COVERED = 0.02


@dataclass(frozen=True)
class DrawnText:
    """One text as drawn: its string and its box, pixels."""

    text: str
    box: Bbox


@contextmanager
def _recording(drawn: list[DrawnText]) -> Iterator[None]:
    original = Text.draw

    def draw(self: Text, renderer) -> None:  # type: ignore[no-untyped-def]
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            drawn.append(DrawnText(self.get_text(), self.get_window_extent(renderer).frozen()))

    with mock.patch.object(Text, "draw", draw):
        yield


def drawn_texts(fig: Figure) -> list[DrawnText]:
    """Draw ``fig`` and return every non-empty text the renderer drew, with its box."""
    drawn: list[DrawnText] = []
    with _recording(drawn):
        fig.canvas.draw()
    return drawn


def _overlap(a: Bbox, b: Bbox) -> bool:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return w > TOLERANCE_PX and h > TOLERANCE_PX


def data_points(fig: Figure) -> np.ndarray:
    """Every plotted data point inside its axes' view, display pixels, shape (n, 2).

    The vertices of lines (markers and curves) and the points of collections (scatter, error
    bars); filled areas (bands, spans) are backgrounds, not points.
    """
    out: list[np.ndarray] = []
    for ax in fig.axes:
        view = ax.get_window_extent()
        for artist in ax.get_children():
            if isinstance(artist, Line2D) and artist.get_visible():
                xy = artist.get_transform().transform(np.column_stack(artist.get_data()).astype(float))
            elif isinstance(artist, Collection) and not isinstance(artist, PolyCollection) and artist.get_visible():
                offsets = np.asarray(artist.get_offsets(), dtype=float)
                if offsets.size == 0:
                    continue
                xy = artist.get_offset_transform().transform(offsets)
            else:
                continue
            xy = xy[np.all(np.isfinite(xy), axis=1)]
            inside = (xy[:, 0] >= view.x0) & (xy[:, 0] <= view.x1) & (xy[:, 1] >= view.y0) & (xy[:, 1] <= view.y1)
            out.append(xy[inside])
    return np.concatenate(out) if out else np.empty((0, 2))


def legends(fig: Figure) -> list[Legend]:
    """The figure's legends and its axes'."""
    found = list(fig.legends)
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            found.append(leg)
    return found


def layout_faults(fig: Figure, max_covered: float = MAX_COVERED) -> list[str]:
    """What a reader would see as broken in ``fig``, as drawn: one line per fault (none: fine).

    Args:
        fig: A figure with a canvas, at the size and resolution it is shown at.
        max_covered: Largest fraction of the data points one legend may cover.

    Returns:
        Overlapping texts, texts outside the canvas, legends over more than ``max_covered`` of the
        data points.
    """
    return drawn_layout_faults(fig, drawn_texts(fig), max_covered)


def drawn_layout_faults(fig: Figure, texts: list[DrawnText], max_covered: float = MAX_COVERED) -> list[str]:
    """:func:`layout_faults` of ``fig`` as it was just drawn, ``texts`` its :func:`drawn_texts` (one draw for both)."""
    canvas = fig.bbox
    faults = []
    for t in texts:
        b = t.box
        if (
            b.x0 < canvas.x0 - TOLERANCE_PX
            or b.y0 < canvas.y0 - TOLERANCE_PX
            or b.x1 > canvas.x1 + TOLERANCE_PX
            or b.y1 > canvas.y1 + TOLERANCE_PX
        ):
            faults.append(f"outside the {canvas.width:.0f}×{canvas.height:.0f} canvas: {t.text!r} at {_px(b)}")
    for a, b in itertools.combinations(texts, 2):
        if _overlap(a.box, b.box):
            faults.append(f"overlap: {a.text!r} at {_px(a.box)} and {b.text!r} at {_px(b.box)}")
    covered = legend_coverage(fig)
    if covered > max_covered:
        faults.append(f"a legend covers {covered:.1%} of the {len(data_points(fig))} data points")
    return faults


def _covered(box: Bbox, points: np.ndarray) -> float:
    """The fraction of ``points`` (pixels) inside ``box``."""
    if points.size == 0:
        return 0.0
    x, y = points[:, 0], points[:, 1]
    return float(((x > box.x0) & (x < box.x1) & (y > box.y0) & (y < box.y1)).mean())


def legend_coverage(fig: Figure) -> float:
    """The largest fraction of the data points one legend of ``fig`` covers (after a draw)."""
    points = data_points(fig)
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    return max((_covered(leg.get_window_extent(renderer), points) for leg in legends(fig)), default=0.0)


def _px(b: Bbox) -> tuple[int, int, int, int]:
    return (round(b.x0), round(b.y0), round(b.x1), round(b.y1))
