"""Labels beside an axes that never overlap: placed in rows, as many as the labels need.

:class:`RowLabels` writes each label centred on its x (data coordinates) above the axes, or
below it (under its x axis' ticks and tick labels). At every draw, and whenever a layout engine
asks for its extent, it measures the labels with the renderer at the axes' current size and
puts each in the row nearest the axes where it clears the labels already there by a gap; rows
are stacked away from the axes. However many labels, however long, and at whatever figure size
or resolution, no two overlap, and constrained layout keeps them inside the figure (their
extent is part of the axes'). A heading, if given, sits beyond the outermost row, its lines
wrapped to the axes' width; :class:`SettlingLayout` runs constrained layout until rows and
heading, whose height follows the axes' width, have settled. The legend of a
:class:`LegendFittingFigure` is made again at every draw in as few columns (and, on a small
figure, as small a font) as let it fit the figure, at whatever size it is drawn.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from typing import Any

import matplotlib as mpl
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backend_bases import RendererBase
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.legend import Legend
from matplotlib.text import Text
from matplotlib.transforms import Bbox, ScaledTranslation

__all__ = ["LegendFittingFigure", "RowLabels", "SettlingLayout", "label_rows"]

#: Gap between neighbouring labels of a row, and between rows, points.
GAP_PT = 3.0
#: Space between the axes' top and the first row, points.
PAD_PT = 3.0
#: Fewest characters a line of a heading is wrapped to.
_MIN_TITLE_CHARS = 20
#: Most times a heading is wrapped narrower to fit the axes' width.
_MAX_WRAPS = 8
#: Most passes of :class:`SettlingLayout`.
_MAX_PASSES = 5
#: Move of an axes' corner, figure fraction, below which :class:`SettlingLayout` has settled.
_SETTLED = 1e-4
#: Widest a fitted legend may be, fraction of the figure's width, before its font gets smaller.
LEGEND_MAX_WIDTH = 0.3
#: Smallest font a fitted legend gets, points.
LEGEND_MIN_FONTSIZE = 5.0
#: Step of a fitted legend's font, points.
_LEGEND_FONT_STEP = 0.5


def label_rows(extents: Sequence[tuple[float, float]], gap: float) -> list[int]:
    """Rows for labels of horizontal extents ``extents`` so that no two of a row are closer than ``gap``.

    Labels are taken from left to right (by centre) and each goes in the lowest row whose last
    label ends at least ``gap`` before it starts (a new row when none does).

    Args:
        extents: (left, right) of each label, any unit.
        gap: Smallest clearance between two labels of a row, same unit.

    Returns:
        Each label's 0-based row, in the order of ``extents``.
    """
    ends: list[float] = []
    rows = [0] * len(extents)
    for i in sorted(range(len(extents)), key=lambda k: extents[k][0] + extents[k][1]):
        left, right = extents[i]
        row = next((r for r, end in enumerate(ends) if end + gap <= left), len(ends))
        if row == len(ends):
            ends.append(right)
        else:
            ends[row] = right
        rows[i] = row
    return rows


class SettlingLayout(ConstrainedLayoutEngine):
    """Constrained layout, run again until the axes stop moving.

    The height of :class:`RowLabels` depends on the axes' width (narrower axes, more rows), which
    the layout sets: one pass of constrained layout may leave rows or a heading off the figure.
    Keywords are :class:`matplotlib.layout_engine.ConstrainedLayoutEngine`'s.
    """

    def execute(self, fig: Figure) -> dict[str, Any]:  # type: ignore[override]
        """Lay ``fig`` out, up to a few passes, until no axes moves."""
        done: dict[str, Any] = {}
        for _ in range(_MAX_PASSES):
            before = [ax.get_position().get_points().copy() for ax in fig.axes]
            done = super().execute(fig)
            moved = [abs(ax.get_position().get_points() - b).max() for ax, b in zip(fig.axes, before, strict=True)]
            if max(moved, default=0.0) < _SETTLED:
                break
        return done


class RowLabels(Artist):
    """Labels centred on x positions above (or below) an axes, in rows so that none overlap.

    Args:
        ax: The axes (the labels are added to it).
        xs: Each label's centre, data coordinates of ``ax``'s x axis.
        labels: The labels' texts.
        gids: Each label's gid (none: no gid).
        title: A heading beyond the outermost row, centred on the axes and its lines wrapped to
            the axes' width ("": none); above the axes, in place of the axes' title (which would
            not know the rows' height).
        title_size: The heading's font size, points.
        below: Put the rows below the axes (under its x axis' ticks and tick labels), not above.
        **text: Keywords of :class:`matplotlib.text.Text` (e.g. ``fontsize``).
    """

    def __init__(
        self,
        ax: Axes,
        xs: Sequence[float],
        labels: Sequence[str],
        gids: Sequence[str] = (),
        title: str = "",
        title_size: float = 10.0,
        below: bool = False,
        **text: Any,
    ) -> None:
        """Make the labels and add them to ``ax``."""
        super().__init__()
        fig = ax.get_figure()
        assert fig is not None
        self._ax = ax
        self._below = below
        edge, va = (0.0, "top") if below else (1.0, "bottom")
        self._texts: list[Text] = []
        for i, (x, label) in enumerate(zip(xs, labels, strict=True)):
            t = Text(x, edge, label, ha="center", va=va, clip_on=False, **text)
            t.set_figure(fig)
            if i < len(gids):
                t.set_gid(gids[i])
            self._texts.append(t)
        self._title: Text | None = None
        if title:
            self._title = Text(0.5, edge, title, ha="center", va=va, clip_on=False, fontsize=title_size)
            self._title.set_figure(fig)
        self._title_text = title
        self.set_figure(fig)
        self.rows: list[int] = [0] * len(self._texts)
        ax.add_artist(self)
        self.set_clip_on(False)

    @property
    def texts(self) -> list[Text]:
        """The labels, in the order given."""
        return list(self._texts)

    @property
    def title(self) -> Text | None:
        """The heading, if any."""
        return self._title

    def _all(self) -> list[Text]:
        return self._texts + ([self._title] if self._title is not None else [])

    def get_children(self) -> list[Artist]:
        """The labels and the heading (so that ``findobj`` and the layout see them)."""
        return list(self._all())

    def _axis_depth_pt(self, renderer: RendererBase, dpi: float) -> float:
        """How far the x axis (ticks, tick labels, label) reaches below the axes, points."""
        ax = self._ax
        ticks = [t.get_tick_padding() for t in ax.xaxis.majorTicks[:1] if t.tick1line.get_visible()]
        depth = max(ticks, default=0.0)
        box = ax.xaxis.get_tightbbox(renderer)
        if box is not None and box.height > 0:
            depth = max(depth, (ax.get_window_extent(renderer).y0 - box.y0) * 72.0 / dpi)
        return float(depth)

    def _place(self, renderer: RendererBase) -> None:
        """Measure the labels at the axes' current size and put each in its row."""
        fig = self._ax.get_figure()
        assert fig is not None
        base = self._ax.get_xaxis_transform()
        dpi = fig.get_dpi()
        gap_px = GAP_PT * dpi / 72.0
        for t in self._texts:
            t.set_transform(base)
        boxes = [t.get_window_extent(renderer) for t in self._texts]
        self.rows = label_rows([(b.x0, b.x1) for b in boxes], gap_px)
        row_pt = max((b.height for b in boxes), default=0.0) * 72.0 / dpi + GAP_PT
        scale = fig.dpi_scale_trans
        start = PAD_PT + (self._axis_depth_pt(renderer, dpi) if self._below else 0.0)
        sign = -1.0 if self._below else 1.0
        for t, row in zip(self._texts, self.rows, strict=True):
            t.set_transform(base + ScaledTranslation(0.0, sign * (start + row * row_pt) / 72.0, scale))
        if self._title is not None:
            outer = start + (max(self.rows) + 1) * row_pt if self._texts else start
            shift = sign * (outer + GAP_PT) / 72.0
            self._title.set_transform(self._ax.transAxes + ScaledTranslation(0.0, shift, scale))
            self._fit_title(renderer)

    def _fit_title(self, renderer: RendererBase) -> None:
        """Wrap the heading's lines (as given) to the axes' width (it adds no width to the axes)."""
        title = self._title
        assert title is not None
        title.set_text(self._title_text)
        room = float(self._ax.get_window_extent(renderer).width)
        for _ in range(_MAX_WRAPS):
            width = title.get_window_extent(renderer).width
            longest = max(len(line) for line in title.get_text().split("\n"))
            if width <= room or longest <= _MIN_TITLE_CHARS:
                return
            chars = max(_MIN_TITLE_CHARS, min(longest - 1, int(longest * room / width)))
            title.set_text("\n".join(textwrap.fill(line, chars) for line in self._title_text.split("\n")))

    def get_window_extent(self, renderer: RendererBase | None = None) -> Bbox:
        """The labels' extent, laid out at the axes' current size, pixels."""
        fig = self._ax.get_figure()
        assert fig is not None
        r = renderer if renderer is not None else fig.canvas.get_renderer()  # type: ignore[attr-defined]
        if not self._all():
            return Bbox.null()
        self._place(r)
        return Bbox.union([t.get_window_extent(r) for t in self._all()])

    def get_tightbbox(self, renderer: RendererBase | None = None) -> Bbox:
        """Same as :meth:`get_window_extent` (for the layout engine)."""
        return self.get_window_extent(renderer)

    def draw(self, renderer: RendererBase) -> None:
        """Lay the labels out at the axes' current size and draw them."""
        if not self.get_visible() or not self._all():
            return
        self._place(renderer)
        for t in self._all():
            t.draw(renderer)
        self.stale = False


class LegendFittingFigure(Figure):
    """A figure whose legend (:meth:`fitted_legend`) fits it at whatever size it is drawn.

    Before every draw the legend is made again: in as few columns as let it fit the figure's
    height (between the layout's pads), its font made smaller, down to
    :data:`LEGEND_MIN_FONTSIZE`, while it is wider than :data:`LEGEND_MAX_WIDTH` of the
    figure. A layout engine (constrained layout) then makes room for it. Arguments are
    :class:`matplotlib.figure.Figure`'s.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """Make the figure, with no fitted legend yet."""
        super().__init__(*args, **kwargs)
        self._legend_spec: tuple[list[Any], list[str], dict[str, Any]] | None = None
        self._fitted: Legend | None = None
        self._fitted_to: tuple[float, float, float] | None = None  # figure width, height (px), dpi

    def fitted_legend(self, handles: Sequence[Any], labels: Sequence[str], **kwargs: Any) -> Legend:
        """The figure's fitted legend (:meth:`matplotlib.figure.Figure.legend`'s keywords but ``ncols``).

        ``fontsize`` (points; default 7) is its largest font.

        Returns:
            The legend as made now (one column); ``legends`` holds the one last drawn.
        """
        self._legend_spec = (list(handles), list(labels), {"fontsize": 7.0, **kwargs})
        self._fitted_to = None
        return self._make_legend(1, float(self._legend_spec[2]["fontsize"]))

    def _make_legend(self, ncols: int, fontsize: float) -> Legend:
        assert self._legend_spec is not None
        handles, labels, kwargs = self._legend_spec
        if self._fitted is not None and self._fitted in self.legends:
            self._fitted.remove()
        self._fitted = self.legend(handles, labels, **{**kwargs, "ncols": ncols, "fontsize": fontsize})
        return self._fitted

    def _fit_legend(self, renderer: RendererBase) -> None:
        """Make the legend again: the largest font (to the smallest) whose fewest fitting columns are narrow enough.

        Only when the figure's size or resolution changed: ``savefig`` draws twice, the second
        time without the layout engine, and the legend must stay the one the layout made room for.
        """
        assert self._legend_spec is not None
        size = (float(self.bbox.width), float(self.bbox.height), float(self.dpi))
        if size == self._fitted_to:
            return
        self._fitted_to = size
        engine = self.get_layout_engine()
        params = engine.get() if engine is not None else {}
        pad_in = float(params.get("h_pad", mpl.rcParams["figure.constrained_layout.h_pad"]))
        room = self.bbox.height - 2.0 * pad_in * self.dpi
        widest = LEGEND_MAX_WIDTH * self.bbox.width
        n_entries = max(1, len(self._legend_spec[1]))
        fontsize = float(self._legend_spec[2]["fontsize"])
        while True:
            ncols = 1
            box = self._make_legend(ncols, fontsize).get_window_extent(renderer)
            while box.height > room and ncols < n_entries:
                ncols = min(n_entries, max(ncols + 1, math.ceil(ncols * box.height / room)))
                box = self._make_legend(ncols, fontsize).get_window_extent(renderer)
            if box.width <= widest or fontsize - _LEGEND_FONT_STEP < LEGEND_MIN_FONTSIZE:
                return
            fontsize -= _LEGEND_FONT_STEP

    def draw(self, renderer: RendererBase) -> None:
        """Fit the legend to the figure as it is now, then draw."""
        if self._legend_spec is not None and self.get_visible():
            self._fit_legend(renderer)
        super().draw(renderer)
