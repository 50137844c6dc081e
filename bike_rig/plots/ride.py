"""Ride figures: measured eigenvalues over the predicted curves, and a record's segmentation.

:func:`ride_validation` draws two panels against speed [m/s]: the real parts [1/s] and the
imaginary parts [rad/s] of the model's weave eigenvalue (a line, with its ±σ band from the
parameter covariance) and each segment's measured eigenvalue with ±σ error bars (clean
segments filled, flagged ones hollow), and the segments at one speed combined (diamonds).
:func:`ride_figure` is the registry's ``ride`` kind (``bike-rig plot ride INPUT --ride RECORD``):
the records measured with ``bike-rig ride``'s defaults against one bicycle.
:func:`ride_segments` draws a record's signal with each segment shaded, each kick marked,
and the reason each segment starts and ends written by it.

Artists that carry data have a ``gid`` so tests can find them: ``pred-re``, ``pred-im``,
``band-re``, ``band-im``, ``meas-re``, ``meas-im``, ``comb-re``, ``comb-im``; ``segment:<k>``,
``kick:<k>``, ``signal``; where the model curve changes to another tracked mode (and may
jump), a dotted line ``branch-re:<k>``/``branch-im:<k>`` with a legend entry; at a feedback's
gain-table speeds (where the closed-loop curve kinks), a dashed ``gains-re:<k>``/``gains-im:<k>``.
:func:`ride_calibration` draws the same two panels for ``bike-rig ride calibrate``: the
measured eigenvalues per speed (±σ), the best variant's weave eigenvalue at the prior and at
the posterior, each with its ±σ band (``data-re``, ``prior-re``, ``prior-band-re``, ``post-re``,
``post-band-re`` and the same for ``im``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..core.feedback import Feedback
from ..core.ride.eigen import MeasuredEigenvalue
from ..core.ride.record import RideRecord
from ..core.ride.segment import Segment
from ..offline.subjects import Subject
from ..pipeline.ride import PredictedWeave, RideComparison, validate_ride
from .model_data import FigureInputError
from .style import new_figure

__all__ = ["ride_calibration", "ride_figure", "ride_segments", "ride_validation"]

if TYPE_CHECKING:
    from ..pipeline.ride_calibrate import CalibratedRide


def ride_validation(
    comparison: RideComparison, curve: PredictedWeave, title: str = "", feedback: Feedback | None = None
) -> Figure:
    """Measured eigenvalues with error bars over the predicted curves with ±σ bands (module docstring).

    ``feedback``: the closed loop's feedback, whose gain-table speeds are marked (the model
    curve has a kink there, as the gains change slope).
    """
    fig = new_figure(8.0, 7.0)
    ax_re, ax_im = fig.subplots(2, 1, sharex=True)
    for ax, part, vals, sig in (
        (ax_re, "re", curve.real, curve.real_sigma),
        (ax_im, "im", curve.imag, curve.imag_sigma),
    ):
        ax.plot(curve.speeds, vals, color="C0", lw=1.5, label="model (weave)", gid=f"pred-{part}")
        band = ax.fill_between(curve.speeds, vals - sig, vals + sig, color="C0", alpha=0.25, lw=0, label="model ±σ")
        band.set_gid(f"band-{part}")
    segs = [c.segment for c in comparison.segments if c.segment.valid]
    for clean in (True, False):
        chosen: Sequence[MeasuredEigenvalue] = [s for s in segs if s.clean == clean]
        if not chosen:
            continue
        v = [s.speed for s in chosen]
        face = "C3" if clean else "none"
        label = "segments" if clean else "flagged segments"
        for ax, part, attr in ((ax_re, "re", "real"), (ax_im, "im", "imag")):
            ax.errorbar(
                v,
                [getattr(s, attr) for s in chosen],
                yerr=[getattr(s, attr + "_sigma") for s in chosen],
                fmt="o",
                ms=4,
                color="C3",
                mfc=face,
                capsize=2,
                label=label,
                gid=f"meas-{part}",
            )
    if comparison.speeds:
        v = [c.combined.speed for c in comparison.speeds]
        for ax, part, attr in ((ax_re, "re", "real"), (ax_im, "im", "imag")):
            ax.errorbar(
                v,
                [getattr(c.combined, attr) for c in comparison.speeds],
                yerr=[getattr(c.combined, attr + "_sigma") for c in comparison.speeds],
                fmt="D",
                ms=6,
                color="k",
                mfc="none",
                capsize=3,
                label="combined per speed",
                gid=f"comb-{part}",
            )
    _mark_branch_changes(ax_re, ax_im, curve)
    _mark_gain_breakpoints(ax_re, ax_im, curve, feedback)
    ax_re.axhline(0.0, color="0.5", lw=0.8)
    ax_re.set_ylabel("Re λ [1/s]")
    ax_im.set_ylabel("Im λ [rad/s]")
    ax_im.set_xlabel("speed [m/s]")
    ax_re.legend(loc="best", fontsize=8)
    overall = f"overall normalised deviation {comparison.overall:.2f}" if np.isfinite(comparison.overall) else ""
    ax_re.set_title(" — ".join(x for x in (title, overall) if x))
    return fig


def branch_changes(curve: PredictedWeave) -> list[float]:
    """Speeds (m/s, midway between grid speeds) where the curve switches to another tracked mode."""
    b, v = curve.branches, curve.speeds
    return [
        0.5 * (float(v[i]) + float(v[i + 1]))
        for i in range(len(b) - 1)
        if b[i] >= 0 and b[i + 1] >= 0 and b[i] != b[i + 1]
    ]


def _mark_branch_changes(ax_re: Axes, ax_im: Axes, curve: PredictedWeave) -> None:
    """A dotted line and a legend entry where the model curve changes to another closed-loop mode."""
    for k, speed in enumerate(branch_changes(curve)):
        for ax, part in ((ax_re, "re"), (ax_im, "im")):
            label = "model switches to another mode" if k == 0 else None
            ax.axvline(speed, color="C1", ls=":", lw=1.2, label=label, gid=f"branch-{part}:{k}")


def _mark_gain_breakpoints(ax_re: Axes, ax_im: Axes, curve: PredictedWeave, feedback: Feedback | None) -> None:
    """A dashed line and a legend entry at each gain-table speed inside the curve's range."""
    if feedback is None or not len(curve.speeds):
        return
    lo, hi = float(np.min(curve.speeds)), float(np.max(curve.speeds))
    inside = [b for b in feedback.breakpoints if lo < b < hi]
    for k, speed in enumerate(inside):
        for ax, part in ((ax_re, "re"), (ax_im, "im")):
            label = "feedback gains change slope (model kinks)" if k == 0 else None
            ax.axvline(speed, color="C4", ls="--", lw=1.0, label=label, gid=f"gains-{part}:{k}")


def ride_segments(record: RideRecord, segments: Sequence[Segment], title: str = "") -> Figure:
    """A record's signal with its segments, kicks and the reasons for each start and end."""
    fig = new_figure(10.0, 4.5)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(record.times, record.signal, color="0.2", lw=0.8, gid="signal")
    top = float(np.nanmax(record.signal)) if record.signal.size else 1.0
    for k, seg in enumerate(segments, start=1):
        ax.axvspan(seg.start, seg.stop, color="C2", alpha=0.2, gid=f"segment:{k}")
        ax.axvline(seg.kick.onset, color="C3", lw=1.0, gid=f"kick:{k}")
        ax.text(
            seg.start,
            top,
            f"{k}: start {seg.start_reason.split(' (')[0]}\nend: {seg.stop_reason}",
            fontsize=6,
            va="top",
            ha="left",
            rotation=0,
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{record.signal_name}")
    ax.set_title(title or f"{record.source}: {len(segments)} segments (shaded), kicks (red lines)")
    return fig


def ride_figure(
    subjects: Sequence[Subject],
    rider: str = "",
    speeds: Sequence[float] | None = None,
    feedback: Feedback | None = None,
    ride: Sequence[str] = (),
) -> Figure:
    """The ``ride`` kind: the records ``ride`` against the one bicycle of ``subjects`` (with ``rider``).

    Raises:
        FigureInputError: Not exactly one bicycle, or no records. RideSpeedError: a segment
            without a speed.
    """
    from ..core.rider import add_rider, resolve_rider
    from ..offline.rides import RecordOptions, measure_records

    if len(subjects) != 1 or not ride:
        raise FigureInputError("the ride figure compares ride records (--ride) with exactly one bicycle")
    r = resolve_rider(rider)
    ps = subjects[0].parameters if r is None else add_rider(subjects[0].parameters, r)
    measured = [m.eigenvalue for m in measure_records(ride, RecordOptions())]
    comparison, curve = validate_ride(ps, measured, feedback, speeds=speeds)
    return ride_validation(comparison, curve, subjects[0].name, feedback)


def ride_calibration(result: CalibratedRide, title: str = "") -> Figure:
    """Measured eigenvalues (±σ) per speed over the best variant's prior and posterior bands (module docstring)."""
    fig = new_figure(8.0, 7.0)
    ax_re, ax_im = fig.subplots(2, 1, sharex=True)
    data = result.calibration.data
    best = result.calibration.best
    for ax, part, attr in ((ax_re, "re", "real"), (ax_im, "im", "imag")):
        for band, tag, color, label in (
            (result.prior_band, "prior", "0.5", "prior model"),
            (result.posterior_band, "post", "C0", f"posterior: {best.name}"),
        ):
            vals, sig = getattr(band, attr), getattr(band, attr + "_sigma")
            ax.plot(
                band.speeds,
                vals,
                color=color,
                lw=1.5,
                ls="--" if tag == "prior" else "-",
                label=label,
                gid=f"{tag}-{part}",
            )
            fill = ax.fill_between(
                band.speeds, vals - sig, vals + sig, color=color, alpha=0.25, lw=0, label=f"{label} ±σ"
            )
            fill.set_gid(f"{tag}-band-{part}")
        ax.errorbar(
            data.speeds,
            getattr(data, attr),
            yerr=getattr(data, attr + "_sigma"),
            fmt="D",
            ms=5,
            color="k",
            mfc="none",
            capsize=3,
            label="measured per speed",
            gid=f"data-{part}",
        )
    ax_re.axhline(0.0, color="0.5", lw=0.8)
    ax_re.set_ylabel("Re λ [1/s]")
    ax_im.set_ylabel("Im λ [rad/s]")
    ax_im.set_xlabel("speed [m/s]")
    ax_re.legend(loc="best", fontsize=7)
    fit = best.posterior
    head = f"best: {best.name}, χ² = {fit.chi2:.1f} / {fit.dof} dof"
    ax_re.set_title(" — ".join(x for x in (title, head) if x), fontsize=9)
    return fig
