"""``bike-rig report INPUT -o DIR``: one bicycle's session report as a self-contained HTML page.

INPUT is a measurement file, a parameter file or a session bag. The page ``DIR/index.html``
embeds every figure, so the one file is the whole report and needs no network to view.
``--feedback FILE`` adds the closed loop ``A − B K`` of a steer-torque feedback: a section (its
gains, the closed loop's weave and capsize speeds with σ and stable speed ranges, without and with
the rider) and the closed loop's eigenvalue and Bode figures. ``--ride RECORD`` (repeatable; a
CSV file or bag with a speed column or topic, read as ``bike-rig ride`` does by default) adds a
ride validation section: the measured weave eigenvalues against the bicycle with the rider
(and the feedback), per speed, with the figure.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..core.textfmt import terminal_safe
from .commands import HELP
from .options import add_com_method_option, add_feedback_option, add_strict_option

__all__ = ["add_parser", "run"]


def run(args: argparse.Namespace) -> int:
    """Write the report; print where it went (stderr) and any figure that could not be drawn.

    Args:
        args: The parsed arguments of ``bike-rig report``.

    Returns:
        The exit status, 0 (errors raise).
    """
    from ..report import report_input

    written = report_input(
        args.input,
        args.output,
        args.com_method,
        workers=args.jobs,
        rider=args.rider,
        feedback=args.feedback,
        rides=args.ride or (),
    )
    rep = written.report
    for f in rep.figures:
        if f.uri is None:
            print(terminal_safe(f"bike-rig report: figure '{f.title}' {f.unavailable}"), file=sys.stderr)
    print(
        terminal_safe(
            f"wrote {written.path}: {rep.subject.name} ({rep.subject.kind}), {rep.drawn} figures, "
            f"{len(rep.subject.trials)} trials, in {written.seconds:.1f} s"
        ),
        file=sys.stderr,
    )
    return 0


def _jobs(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a whole number >= 1 expected, got '{text}'") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"a whole number >= 1 expected, got '{text}'")
    return n


def add_parser(sub: Any) -> None:
    """Register ``bike-rig report``.

    Args:
        sub: ``bike-rig``'s sub-command parsers (``add_subparsers()``).
    """
    q = sub.add_parser(
        "report",
        help=HELP["report"],
        description="Write DIR/index.html: the bicycle and its source, the 25 parameters with σ (Table 2), the "
        "canonical matrices with σ (Table 3) and the weave and capsize speeds with σ, without and with the "
        "paper's rider, the uncertainty budget, every trial with its fit and flags, a bag's timeline, and "
        "every figure (embedded, no network needed).",
    )
    q.add_argument("input", help="measurement file, parameter file or session bag (directory, metadata.yaml, .mcap)")
    q.add_argument("-o", "--output", required=True, metavar="DIR", help="directory to write index.html into")
    add_com_method_option(q)
    add_feedback_option(q)
    add_strict_option(q)
    q.add_argument(
        "--rider",
        default="paper",
        help="the rider variant: 'paper' (Table 1, default) or a rider YAML file (rigid or Yeadon)",
    )
    q.add_argument(
        "--ride",
        action="append",
        metavar="RECORD",
        help="a ride record (CSV or bag, with a speed column or topic; repeatable): adds a ride validation section",
    )
    q.add_argument(
        "-j",
        "--jobs",
        type=_jobs,
        default=None,
        help="processes to draw the figures in (default: one per CPU, at most 4)",
    )
    q.set_defaults(func=run)
