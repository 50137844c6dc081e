"""The report with ``--feedback``: the closed loop's section and figures, and nothing else changed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.offline.subjects import load_subject
from bike_rig.report import build_report

ASSIST_YAML = config_file("feedback/balance_assist.yaml")
WHEN = "2026-01-01 00:00:00 UTC"


def _section(html: str) -> str:
    start = html.index('<section id="closed-loop">')
    return html[start : html.index("</section>", start)]


def test_report_adds_the_closed_loop() -> None:
    """The closed-loop speeds with σ (both variants) and two closed-loop figures; the rest as without feedback."""
    subject = load_subject(config_file("bicycles/browser.yaml"))
    fb = load_feedback(ASSIST_YAML)
    closed = build_report(subject, WHEN, workers=1, feedback=fb)
    plain = build_report(subject, WHEN, workers=1)
    assert "closed-loop" not in plain.html and plain.results.closed_loop is None
    text = _section(closed.html)
    for ps in (subject.parameters, add_rider(subject.parameters, PAPER_RIDER)):
        cs = critical_speeds_with_sigma(ps, feedback=fb)
        for speed in (cs.weave, cs.capsize):
            if speed is not None:
                assert f'data-value="{speed.speed!r}" data-sigma="{speed.sigma!r}"' in text
    assert "-50 at 0 m/s, 0 at 5 m/s" in text
    keys = {f.key: f for f in closed.figures}
    assert keys["eigen-closed-loop"].uri is not None and keys["bode-closed-loop"].uri is not None
    assert "closed loop (balance assist)" in keys["eigen-closed-loop"].title
    assert [f.key for f in plain.figures] == [f.key for f in closed.figures if "closed-loop" not in f.key]
    # Every open-loop number is the same with the feedback (only the section and figures are added).
    strip = re.compile(r'<section id="closed-loop">.*?</section>\n?|<li><a href="#closed-loop">.*?</li>', re.S)
    figures = re.compile(r"<figure.*?</figure>|(?<=data-figures=\")\d+|(?<=<dt>figures</dt><dd>)\d+", re.S)

    def rest(html: str) -> list[str]:
        return [line for line in figures.sub("", strip.sub("", html)).splitlines() if line.strip()]

    assert rest(closed.html) == rest(plain.html)


def test_report_command_bad_feedback_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A bad feedback file is one line, exit 2, before anything is written."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-feedback/1\nk_delta: {speeds: [0, 1], values: [1]}\n")
    out = tmp_path / "out"
    assert main(["report", str(config_file("bicycles/browser.yaml")), "-o", str(out), "--feedback", str(bad)]) == 2
    assert "key 'k_delta.values': 1 values for 2 speeds" in capsys.readouterr().err
    assert not out.exists()
