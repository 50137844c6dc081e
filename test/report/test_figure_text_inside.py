"""Every report figure, as the report draws it (size and dpi), is laid out for a reader.

The renderer's boxes of what it draws (tick labels, axis labels, titles, legends, annotations)
must lie inside the canvas and not overlap, and no legend may cover the data
(:func:`test.support.figure_layout.layout_faults`): a y label cut off at the left edge, a title
off the top, two labels on each other or a legend over the points fails.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import pytest

from bike_rig.offline.subjects import load_subject
from bike_rig.report.build import report_rider
from bike_rig.report.figures import REPORT_DPI, figure_specs
from bike_rig.report.results import compute_results
from test.support.figure_layout import layout_faults

SUBJECT = load_subject("browser")
SPECS = figure_specs(SUBJECT, compute_results(SUBJECT, report_rider("paper", SUBJECT)), "paper")


@pytest.mark.parametrize("spec", SPECS, ids=[s.key for s in SPECS])
def test_every_text_of_the_figure_is_inside_its_canvas_and_apart(spec) -> None:  # type: ignore[no-untyped-def]
    fig = spec.draw()
    try:
        if spec.size_in is not None:
            fig.set_size_inches(*spec.size_in)
        fig.set_dpi(spec.dpi or REPORT_DPI)
        faults = layout_faults(fig)
        assert not faults, f"{spec.key}: " + "\n".join(faults)
    finally:
        plt.close(fig)
