"""Every report figure's text lies inside its canvas, as the report draws it (size and dpi).

Each axes' tight bounding box (matplotlib's renderer, after a draw: its labels, titles,
legends and the tick labels it draws) and each figure-level text must lie within the figure's
bounding box: a y label cut off at the left edge or a title off the top fails.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import pytest

from bike_rig.offline.subjects import load_subject
from bike_rig.report.build import report_rider
from bike_rig.report.figures import REPORT_DPI, figure_specs
from bike_rig.report.results import compute_results

SUBJECT = load_subject("browser")
SPECS = figure_specs(SUBJECT, compute_results(SUBJECT, report_rider("paper", SUBJECT)), "paper")


@pytest.mark.parametrize("spec", SPECS, ids=[s.key for s in SPECS])
def test_every_text_of_the_figure_is_inside_its_canvas(spec) -> None:  # type: ignore[no-untyped-def]
    fig = spec.draw()
    try:
        if spec.size_in is not None:
            fig.set_size_inches(*spec.size_in)
        fig.set_dpi(spec.dpi or REPORT_DPI)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        box = fig.bbox
        outside = []
        for ax in fig.axes:  # what each axes draws (tick labels inside the view only), in pixels
            e = ax.get_tightbbox(renderer)
            if e is not None and (e.x0 < box.x0 - 1 or e.y0 < box.y0 - 1 or e.x1 > box.x1 + 1 or e.y1 > box.y1 + 1):
                outside.append(f"axes {ax.get_label() or ax.get_title()!r} at {tuple(round(x) for x in e.extents)}")
        for t in fig.texts + ([fig._suptitle] if fig._suptitle is not None else []):  # figure-level text
            e = t.get_window_extent(renderer)
            if t.get_visible() and t.get_text().strip() and (e.x0 < box.x0 - 1 or e.x1 > box.x1 + 1):
                outside.append(f"{t.get_text()!r} at {tuple(round(x) for x in e.extents)}")
        assert not outside, f"{spec.key}: drawn text outside the {box.width:.0f}×{box.height:.0f} canvas: {outside}"
    finally:
        plt.close(fig)
