"""The session report: one bicycle on one self-contained HTML page.

Its parameters, model, uncertainty, trials and figures (``bike-rig report INPUT -o DIR`` writes
``DIR/index.html``).

Modules, one job each: :mod:`.results` computes the numbers (both rider variants, budget),
:mod:`.figures` draws and embeds the figures, :mod:`.sections` renders each section,
:mod:`.html` holds the HTML building blocks, :mod:`.build` assembles and writes the page.
matplotlib is imported by :mod:`.figures` only.
"""

from __future__ import annotations

from .build import REPORT_FILE, Report, WrittenReport, build_report, report_input, write_report
from .errors import ReportOutputError

__all__ = [
    "REPORT_FILE",
    "Report",
    "ReportOutputError",
    "WrittenReport",
    "build_report",
    "report_input",
    "write_report",
]
