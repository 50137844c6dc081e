"""Assemble a report: numbers, figures and sections into one self-contained HTML page.

:func:`build_report` makes the page in memory; :func:`write_report` writes it as
``DIR/index.html`` (figures embedded as PNG ``data:`` URIs, so the one file is the whole report;
no network is needed to view it).
"""

from __future__ import annotations

import datetime as dt
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.benchmark import ComMethod
from ..core.feedback import Feedback, resolve_feedback
from ..core.ride.eigen import MeasuredEigenvalue
from ..core.rider import Rider, RiderError, resolve_rider, rider_key
from ..offline.rides import RecordOptions, measure_records
from ..offline.subjects import Subject, load_subject
from ..plots.output import check_out_dir
from . import sections
from .errors import ReportOutputError
from .figures import REPORT_DPI, ReportFigure, draw_figures, figure_specs
from .html import page
from .results import ReportResults, compute_results
from .ride import compute_ride, ride_section

__all__ = ["REPORT_FILE", "Report", "WrittenReport", "build_report", "report_input", "write_report"]

#: The report's file name inside the output directory.
REPORT_FILE = "index.html"


@dataclass(frozen=True)
class Report:
    """A built report.

    Attributes:
        subject: The bicycle it is about.
        results: Its numbers; None for a partial report (an incomplete session).
        figures: Its figures, drawn or with the reason they are not.
        html: The page.
        seconds: Wall time to build it (numbers, figures, page), s.
    """

    subject: Subject
    results: ReportResults | None
    figures: tuple[ReportFigure, ...]
    html: str
    seconds: float

    @property
    def drawn(self) -> int:
        """How many figures the page embeds."""
        return sum(f.uri is not None for f in self.figures)


@dataclass(frozen=True)
class WrittenReport:
    """A report on disk.

    Attributes:
        path: The HTML file.
        report: What it holds.
        seconds: Wall time from opening the input to the written file, s.
    """

    path: Path
    report: Report
    seconds: float


def report_rider(spec: str, subject: Subject) -> Rider:
    """The report's rider variant: ``"paper"`` (Table 1) or a rider file's rider, seated on ``subject``.

    Raises:
        RiderError: No rider named (the report compares the bicycle without and with one), or a
            rider file that cannot be read or seated.
    """
    r = resolve_rider(spec)
    if r is None:
        reason = "the report shows the bicycle without and with a rider: name 'paper' or a rider file"
        raise RiderError(f"{reason}, not '{spec}'")
    return r if isinstance(r, Rider) else r.seated(subject.parameters)


def build_report(
    subject: Subject,
    generated: str | None = None,
    dpi: float = REPORT_DPI,
    workers: int | None = None,
    feedback: Feedback | None = None,
    rider: str = "paper",
    rides: Sequence[MeasuredEigenvalue] = (),
) -> Report:
    """The report of one bicycle.

    Args:
        subject: The bicycle (:func:`bike_rig.offline.subjects.load_subject`).
        generated: The creation time printed on the page (default: now, UTC, to the second).
        dpi: Resolution of the embedded figures, dots per inch.
        workers: Processes to draw the figures in (default: one per CPU, at most
            :data:`~.figures.MAX_WORKERS`; see :func:`~.figures.draw_figures`).
        feedback: A steer-torque feedback: the page adds its closed loop (a section and the
            closed-loop eigenvalue and Bode figures); None: the open loop only.
        rider: The rider variant: ``"paper"`` or a rider file (:func:`report_rider`).
        rides: Measured ride segments (:func:`bike_rig.offline.rides.measure_records`): the page adds
            a ride section (:mod:`.ride`), against the bicycle with the rider (and feedback).

    An incomplete session (no parameters) gets a partial report: its header names what is
    missing, the trials, timeline, readings and trial figures are shown, and the parameters,
    model and budget sections are one line each saying why they are not.

    Returns:
        The report, its page in memory.

    Raises:
        RiderError: A rider that cannot be used (see :func:`report_rider`).
    """
    t0 = time.perf_counter()
    when = generated or dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    if not subject.complete:
        return _partial_report(subject, when, dpi, workers, t0)
    results = compute_results(subject, report_rider(rider, subject), feedback=feedback)
    figures = draw_figures(figure_specs(subject, results, rider_key(rider)), dpi, workers)
    drawn = sum(f.uri is not None for f in figures)
    body = [
        sections.header_section(subject, results, drawn, when),
        sections.parameters_section(results),
        sections.matrices_section(results),
        sections.speeds_section(results),
        *([sections.closed_loop_section(results)] if results.closed_loop is not None else []),
        *([ride_section(compute_ride(results.rider, rides, feedback), dpi)] if rides else []),
        *([_calibration(subject, rides, rider, feedback, dpi)] if rides and feedback is not None else []),
        sections.budget_section(results),
        sections.trials_section(subject),
        sections.timeline_section(subject),
        sections.readings_section(subject),
        sections.figures_section(figures),
    ]
    text = page(f"{subject.name}: bicycle parameter report", body, drawn)
    return Report(subject, results, figures, text, time.perf_counter() - t0)


def _partial_report(subject: Subject, when: str, dpi: float, workers: int | None, t0: float) -> Report:
    """The report of an incomplete session: what its trials show, each missing part said in one line."""
    figures = draw_figures(figure_specs(subject, None), dpi, workers)
    drawn = sum(f.uri is not None for f in figures)
    body = [
        sections.header_section(subject, None, drawn, when),
        sections.omitted_section(subject, "parameters", "Benchmark parameters", "the parameters table"),
        sections.omitted_section(
            subject, "model", "Model", "the canonical matrices, critical speeds, closed loop, rides and model figures"
        ),
        sections.omitted_section(subject, "budget", "Uncertainty budget", "the uncertainty budget"),
        sections.trials_section(subject),
        sections.timeline_section(subject),
        sections.readings_section(subject),
        sections.figures_section(figures),
    ]
    text = page(f"{subject.name}: partial bicycle parameter report", body, drawn)
    return Report(subject, None, figures, text, time.perf_counter() - t0)


def _calibration(
    subject: Subject, rides: Sequence[MeasuredEigenvalue], rider: str, feedback: Feedback, dpi: float
) -> sections.Raw:
    """The ride calibration section (nominal variants, no free parameter), or a note why it is missing."""
    from ..core.errors import BikeRigError
    from ..pipeline.ride_calibrate import calibrate_rides
    from .html import esc, section
    from .ride import calibration_section

    try:
        result = calibrate_rides(subject.parameters, rides, resolve_rider(rider), feedback)
    except (BikeRigError, ValueError, np.linalg.LinAlgError) as exc:
        return section("ride-calibration", "Ride calibration", [f'<p class="note">not computed: {esc(str(exc))}</p>'])
    return calibration_section(result, dpi)


def write_report(
    subject: Subject,
    out_dir: str | Path,
    generated: str | None = None,
    workers: int | None = None,
    feedback: Feedback | None = None,
    rider: str = "paper",
    rides: Sequence[MeasuredEigenvalue] = (),
) -> WrittenReport:
    """Build the report of ``subject`` and write it as ``out_dir/index.html``.

    The directory is created if needed; an existing report in it is replaced.

    Args:
        subject: The bicycle.
        out_dir: The output directory.
        generated: The creation time printed on the page (default: now).
        workers: Processes to draw the figures in (default: one per CPU, at most 4).
        feedback: A steer-torque feedback whose closed loop the page adds, or None.
        rider: The rider variant: ``"paper"`` or a rider file.
        rides: Measured ride segments: the page adds a ride section.

    Returns:
        Where it went, with the report.

    Raises:
        ReportOutputError: The directory cannot be created or the file cannot be written.
    """
    t0 = time.perf_counter()
    report = build_report(subject, generated, workers=workers, feedback=feedback, rider=rider, rides=rides)
    path = _write(Path(out_dir), report.html)
    return WrittenReport(path, report, time.perf_counter() - t0)


def report_input(
    path: str | Path,
    out_dir: str | Path,
    com_method: ComMethod | str | None = None,
    workers: int | None = None,
    feedback: str | None = None,
    rider: str = "paper",
    rides: Sequence[str] = (),
    ride_options: RecordOptions | None = None,
) -> WrittenReport:
    """Open an input (measurement file, parameter file or session bag) and write its report.

    The output directory is checked before the input is opened, and nothing is written for an
    input that cannot be read.

    Args:
        path: The input.
        out_dir: The output directory.
        com_method: Mass-centre method for raw readings (default: centroid; a bag: as recorded).
        workers: Processes to draw the figures in (default: one per CPU, at most 4).
        feedback: A feedback file (:func:`bike_rig.core.feedback.resolve_feedback`; None, ""
            or "none": the open loop only); read before the input.
        rider: The rider variant: ``"paper"`` (Table 1) or a rider file (rigid or Yeadon).
        rides: Ride records (CSV files or bags) for the ride section, read before the input.
        ride_options: How they are read (default: the defaults of ``bike-rig ride``).

    Returns:
        Where it went, with the report; its time counts from opening the input.

    Raises:
        BikeRigError: The input cannot be read (names the file and the reason), or
            :class:`ReportOutputError` for the output.
    """
    t0 = time.perf_counter()
    out = check_out_dir(out_dir, ReportOutputError, create=False)  # before the input: nothing written for a bad one
    fb = resolve_feedback(feedback)
    measured = [m.eigenvalue for m in measure_records(rides, ride_options or RecordOptions())] if rides else []
    subject = load_subject(path, com_method, partial=True)
    written = write_report(subject, out, workers=workers, feedback=fb, rider=rider, rides=measured)
    return WrittenReport(written.path, written.report, time.perf_counter() - t0)


def _write(out: Path, text: str) -> Path:
    check_out_dir(out, ReportOutputError, create=False)
    target = out / REPORT_FILE
    try:
        out.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(f".{REPORT_FILE}.tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(target)
    except OSError as exc:
        raise ReportOutputError(str(exc.filename or target), f"cannot write the report ({exc.strerror})") from None
    return target
