"""The report's ride section: measured weave eigenvalues against the model (``report --ride``).

Given ride records (:mod:`bike_rig.offline.rides`), the bicycle with the report's rider (the paper's,
:class:`~bike_rig.report.results.ReportResults` ``.rider``) and, with ``--feedback``, its closed
loop is compared with every segment (:func:`bike_rig.pipeline.ride.compare_ride`): a table per
speed (measured and predicted eigenvalue with σ, normalised deviation), the overall normalised
deviation, and the validation figure (:func:`bike_rig.plots.ride.ride_validation`) embedded.
:func:`calibration_section` is the ride calibration's section (the variants, the verdict, the figure).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..core.feedback import Feedback
from ..core.ride.eigen import MeasuredEigenvalue
from ..pipeline.ride import PredictedWeave, RideComparison, validate_ride
from .html import Raw, esc, number_cell, section, table, value_sigma_cells
from .results import Variant

__all__ = ["RideResults", "calibration_section", "compute_ride", "ride_section"]

if TYPE_CHECKING:
    from ..pipeline.ride_calibrate import CalibratedRide


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
        rows.append(
            [
                number_cell(cb.speed, ".2f"),
                Raw(f'<td class="num">{cb.n_used} ({cb.n_left_out} left out)</td>'),
                value_sigma_cells(cb.real, cb.real_sigma),
                value_sigma_cells(s.predicted_real, s.predicted_real_sigma),
                value_sigma_cells(cb.imag, cb.imag_sigma),
                value_sigma_cells(s.predicted_imag, s.predicted_imag_sigma),
                number_cell(s.deviation, ".2f"),
            ]
        )
    head = [
        "speed [m/s]",
        "segments",
        "measured Re λ [1/s]",
        "σ",
        "model Re λ [1/s]",
        "σ",
        "measured Im λ [rad/s]",
        "σ",
        "model Im λ [rad/s]",
        "σ",
        "normalised deviation",
    ]
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


def calibration_section(result: CalibratedRide, dpi: float) -> Raw:
    """The ride calibration (:mod:`bike_rig.pipeline.ride_calibrate`): the variants' table, the verdict, the figure."""
    import matplotlib.pyplot as plt

    from ..plots.ride import ride_calibration
    from .figures import png_data_uri

    cal = result.calibration
    rows = []
    for r in cal.variants:
        p = r.posterior
        scale = (
            value_sigma_cells(p.gain_scale, p.gain_scale_sigma if math.isfinite(p.gain_scale_sigma) else None)
            if p.unknowns.gain_scale
            else Raw('<td class="num">1 (nominal)</td><td></td>')
        )
        rows.append(
            [
                Raw(f"<td>{esc(r.name)}</td>"),
                number_cell(p.chi2, ".1f"),
                Raw(f'<td class="num">{p.dof}</td>'),
                number_cell(r.aic, ".1f"),
                number_cell(r.bic, ".1f"),
                number_cell(r.evidence, ".1f"),
                scale,
            ]
        )
    head = ["variant", "χ²", "dof", "AIC", "BIC", "−2 ln Z (Laplace)", "gain scale", "σ"]
    fig = ride_calibration(result)
    uri = png_data_uri(fig, dpi)
    plt.close(fig)
    body = [
        f"<p>The measured parameters and their covariance are the prior, the weave eigenvalues of "
        f"{len(cal.data.speeds)} speeds the data; each variant's posterior by Gauss–Newton and Laplace, ranked by "
        f"evidence (best first).</p>",
        table(head, rows, "ride-calibration", "table-ride-calibration", "Model variants against the rides"),
        f"<p><b>{esc(cal.verdict)}</b></p>",
        *[f'<p class="note">{esc(n)}</p>' for n in cal.notes],
        f'<figure id="fig-ride-calibration" class="report-figure"><img src="{esc(uri)}" alt="ride calibration">'
        "<figcaption><b>Ride calibration.</b> Measured eigenvalues per speed (±σ) over the best variant's weave "
        "eigenvalue at the prior and at the posterior, each with its ±σ band.</figcaption></figure>",
    ]
    return section("ride-calibration", "Ride calibration", body)
