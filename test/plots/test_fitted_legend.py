"""A :class:`~bike_rig.plots.labels.LegendFittingFigure`'s legend fits the figure at any size it is drawn."""

from __future__ import annotations

import io

import matplotlib.pyplot as plt
import pytest
from matplotlib.figure import Figure

from bike_rig.plots.labels import LEGEND_MAX_WIDTH, LEGEND_MIN_FONTSIZE, LegendFittingFigure
from bike_rig.plots.style import new_figure
from test.support.figure_layout import layout_faults

#: Entries of the legend: as many as the trial overview's with every flag code.
N_ENTRIES = 36


def crowded(size_in: tuple[float, float]) -> Figure:
    """A figure of ``N_ENTRIES`` lines, their legend fitted, drawn at 11 × 7.5 in then set to ``size_in``."""
    fig = new_figure(11.0, 7.5, LegendFittingFigure)
    assert isinstance(fig, LegendFittingFigure)
    ax = fig.subplots()
    lines = [ax.plot([0, 1], [i, i + 0.5])[0] for i in range(N_ENTRIES)]
    fig.fitted_legend(lines, [f"entry number {i} ({i % 4})" for i in range(N_ENTRIES)], loc="outside right upper")
    fig.canvas.draw()
    fig.set_size_inches(*size_in)
    return fig


@pytest.mark.parametrize("size_in", [(6.0, 4.0), (5.0, 3.0), (7.0, 5.0), (11.0, 7.5), (14.0, 9.0)])
def test_the_legend_fits_at_every_size(size_in: tuple[float, float]) -> None:
    fig = crowded(size_in)
    try:
        faults = layout_faults(fig)
        assert not faults, f"{size_in} in: " + "\n".join(faults)
        assert len(fig.legends) == 1
        legend = fig.legends[0]
        box = legend.get_window_extent(fig.canvas.get_renderer())  # type: ignore[attr-defined]
        assert fig.bbox.y0 <= box.y0 and box.y1 <= fig.bbox.y1
        fontsize = legend.get_texts()[0].get_fontsize()
        assert LEGEND_MIN_FONTSIZE <= fontsize <= 7.0
        if fontsize > LEGEND_MIN_FONTSIZE:  # shrunk only while too wide
            assert box.width <= LEGEND_MAX_WIDTH * fig.bbox.width
    finally:
        plt.close(fig)


def columns(fig: Figure) -> int:
    """The columns of the figure's legend, as drawn (its entries' left edges)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    return len({round(t.get_window_extent(renderer).x0) for t in fig.legends[0].get_texts()})


def test_a_large_figure_keeps_one_column_at_the_full_font() -> None:
    fig = crowded((11.0, 7.5))
    try:
        fig.canvas.draw()
        legend = fig.legends[0]
        assert columns(fig) == 1 and legend.get_texts()[0].get_fontsize() == 7.0
    finally:
        plt.close(fig)


def test_a_small_figure_gets_columns_or_a_smaller_font() -> None:
    fig = crowded((6.0, 4.0))
    try:
        fig.canvas.draw()
        legend = fig.legends[0]
        assert columns(fig) > 1 or legend.get_texts()[0].get_fontsize() < 7.0
    finally:
        plt.close(fig)


def test_savefig_keeps_the_legend_the_layout_made_room_for() -> None:
    """``savefig`` draws again without the layout engine: the legend must not change then."""
    fig = crowded((6.0, 4.0))
    try:
        fig.canvas.draw()
        drawn = fig.legends[0]
        axes_right = fig.axes[0].get_position().x1
        fig.savefig(io.BytesIO(), format="png")
        assert fig.legends == [drawn]
        assert fig.axes[0].get_position().x1 == axes_right
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        assert fig.axes[0].get_window_extent(renderer).x1 <= drawn.get_window_extent(renderer).x0
    finally:
        plt.close(fig)
