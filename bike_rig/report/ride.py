"""The report's ride section: measured weave eigenvalues against the model (``report --ride``).

Given ride records (:mod:`bike_rig.rides`), the bicycle with the report's rider (the paper's,
:class:`~bike_rig.report.results.ReportResults` ``.rider``) and, with ``--feedback``, its closed
loop is compared with every segment (:func:`bike_rig.pipeline.ride.compare_ride`): a table per
speed (measured and predicted eigenvalue with σ, normalised deviation), the overall normalised
deviation, and the validation figure (:func:`bike_rig.plots.ride.ride_validation`) embedded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..core.feedback import Feedback
from ..core.ride.eigen import MeasuredEigenvalue
from ..pipeline.ride import PredictedWeave, RideComparison, validate_ride
from .html import Raw, esc, number_cell, section, table, value_sigma_cells
from .results import Variant

__all__ = ["RideResults", "compute_ride", "ride_section"]


@dataclass(frozen=True)
class RideResults:
    """Rides against one variant of the bicycle.

    Attributes:
        label: The variant ("with the paper's rider", ...).
        comparison: Measured against predicted.
        curve: The predicted weave eigenvalue over speed, for the figure.
        feedback: The closed loop's feedback name, or "" (the open loop).
    """

    label: str
    comparison: RideComparison
    curve: PredictedWeave
    feedback: str


def compute_ride(variant: Variant, segments: Sequence[MeasuredEigenvalue], feedback: Feedback | None) -> RideResults:
    """Compare the segments with ``variant`` (its parameters with the rider), open or closed loop.

    Raises:
        RideSpeedError: A segment without a speed. ModelError: a singular model.
    """
    comparison, curve = validate_ride(variant.parameters, segments, feedback)
    return RideResults(variant.label, comparison, curve, "" if feedback is None else feedback.name)


def ride_section(rides: RideResults, dpi: float) -> Raw:
    """The section: per-speed table, overall deviation, the figure."""
    import matplotlib.pyplot as plt

    from ..plots.ride import ride_validation
    from .figures import png_data_uri

    c = rides.comparison
    rows = []
    for s in c.speeds:
        cb = s.combined
        rows.append([
            number_cell(cb.speed, ".2f"), Raw(f'<td class="num">{cb.n_used} ({cb.n_left_out} left out)</td>'),
            value_sigma_cells(cb.real, cb.real_sigma), value_sigma_cells(s.predicted_real, s.predicted_real_sigma),
            value_sigma_cells(cb.imag, cb.imag_sigma), value_sigma_cells(s.predicted_imag, s.predicted_imag_sigma),
            number_cell(s.deviation, ".2f"),
        ])  # fmt: skip
    head = ["speed [m/s]", "segments", "measured Re λ [1/s]", "σ", "model Re λ [1/s]", "σ", "measured Im λ [rad/s]",
            "σ", "model Im λ [rad/s]", "σ", "normalised deviation"]  # fmt: skip
    loop = f"the closed loop with feedback '{rides.feedback}'" if rides.feedback else "the open loop"
    overall = f"{c.overall:.2f}" if math.isfinite(c.overall) else "none (no clean segment)"
    fig = ride_validation(c, rides.curve, rides.label)
    uri = png_data_uri(fig, dpi)
    plt.close(fig)
    flagged = sum(1 for r in c.segments if not r.segment.clean)
    body = [
        f"<p>{len(c.segments)} segments ({flagged} flagged or without an eigenvalue, left out of the means) "
        f"against the weave eigenvalue of the bicycle {esc(rides.label)}, {esc(loop)}. Normalised deviation: "
        f"(measured − model) / sqrt(σ_m² + σ_model²), the RMS of the real and imaginary parts; overall (RMS over the "
        f"clean segments): <b>{esc(overall)}</b>.</p>",
        table(head, rows, "ride", "table-ride", "Measured and model weave eigenvalues, segments combined per speed"),
        *[f'<p class="note">{esc(n)}</p>' for n in c.notes],
        f'<figure id="fig-ride" class="report-figure"><img src="{esc(uri)}" alt="ride validation">'
        "<figcaption><b>Ride validation.</b> Measured eigenvalues (±σ) over the model's weave eigenvalue with its "
        "±σ band from the parameter covariance.</figcaption></figure>",
    ]
    return section("ride", "Ride validation", body)
