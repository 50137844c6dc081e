"""Which speed Fig 15 and Figs 17–18 are drawn at, and that overlapping Bode curves stay apart.

* Fig 15 (the capsize–caster pair's eigenvector): by default each bicycle at a speed inside the
  interval where its capsize and caster roots are a complex pair, computed from its model (the
  paper's Browserins has the pair only up to 1.15 m/s, so a fixed 2 m/s would draw a real mode),
  and the figure says which speed; a bicycle without the pair says so.
* Figs 17–18 (Bode, steer torque → roll angle): the paper draws them at 2 m/s (its text, read
  from the shared copy); the report draws that speed and 5 m/s, and says so.
* The Bode curves of several bicycles differ in colour, line style, marker and width, and one
  legend names them.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from bike_rig.config.paths import config_dir
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.bode import bode_figure
from bike_rig.plots.model_data import bode_curves, eigen_curves, mode_shape
from bike_rig.plots.modes import FALLBACK_SPEED, default_mode_speed, eigenvector_figure
from bike_rig.plots.registry import BODE_SPEEDS
from bike_rig.report.figures import figure_specs
from bike_rig.report.results import compute_results

PAPER_BICYCLES = ("browser", "browserins", "crescendo", "fisher", "stratos", "yellow")


@pytest.fixture(scope="module")
def bicycles() -> dict[str, Subject]:
    """Every shipped bicycle (the paper's six and the benchmark bicycle)."""
    return {p.stem: load_subject(p) for p in sorted((config_dir() / "bicycles").glob("*.yaml"))}


def _artist(fig: Figure, gid: str) -> Any:
    found = fig.findobj(lambda a: a.get_gid() == gid)
    assert len(found) == 1, f"{gid}: {len(found)} artists"
    return found[0]


# --------------------------------------------------------------------------------------------
# Fig 15: the capsize–caster pair at a speed where it exists
# --------------------------------------------------------------------------------------------


def test_capsize_caster_pair_drawn_inside_its_interval(bicycles: dict[str, Subject]) -> None:
    with_pair = 0
    for name, subject in bicycles.items():
        intervals = eigen_curves(subject).capsize_caster_complex  # what the eigenvalue figure shades
        speed, why = default_mode_speed(subject, "capsize")
        fig = eigenvector_figure([subject])  # the default speed
        shown = fig.get_suptitle() + " " + fig.axes[0].get_title()
        if not intervals:
            assert name not in PAPER_BICYCLES  # each of the paper's six has the pair without the rider
            assert speed == FALLBACK_SPEED and "no capsize–caster complex pair" in fig.get_suptitle()
            continue
        with_pair += 1
        lo, hi = intervals[0]
        assert lo < speed < hi, name
        assert speed == pytest.approx(0.5 * (lo + hi), abs=0.005)
        assert mode_shape(subject, "capsize", speed).oscillatory  # the complex pair, not a real root
        assert f"at {speed:g} m/s" in shown and f"{lo:.2f} to {hi:.2f} m/s" in why and why in shown
        # the phasors drawn are those of the pair at that speed
        sh = mode_shape(subject, "capsize", speed)
        line = _artist(fig, f"{subject.name}:phasor:1")
        assert list(line.get_xdata()) == [0.0, np.angle(sh.components[1])]
    assert with_pair == len(PAPER_BICYCLES)
    # the paper's Browserins has the pair only up to 1.15 m/s: a fixed 2 m/s would show a real root
    assert not mode_shape(bicycles["browserins"], "capsize", 2.0).oscillatory


def test_several_bicycles_each_at_its_own_speed_and_none_with_the_rider(bicycles: dict[str, Subject]) -> None:
    subjects = [bicycles[n] for n in PAPER_BICYCLES]
    fig = eigenvector_figure(subjects)
    assert "each bicycle's own speed" in fig.get_suptitle()
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible()]
    for subject, title in zip(subjects, titles, strict=True):
        speed, why = default_mode_speed(subject, "capsize")
        assert title.startswith(f"{subject.name} at {speed:g} m/s") and why in title
    ridden = eigenvector_figure(subjects[:2], rider="paper")  # the rider removes the pair
    assert "at 2 m/s (no capsize–caster complex pair), with the paper's rider" in ridden.get_suptitle()
    asked = eigenvector_figure(subjects[:1], speed=0.7)  # a speed asked for is used as it is
    assert "at 0.7 m/s, without rider" in asked.get_suptitle()


def test_report_draws_the_pair_inside_its_interval_and_says_so(bicycles: dict[str, Subject]) -> None:
    for name in ("browserins", "benchmark"):
        subject = bicycles[name]
        spec = next(s for s in figure_specs(subject, compute_results(subject)) if s.key == "mode-capsize")
        speed = spec.draw.keywords["speed"]  # type: ignore[attr-defined]
        intervals = eigen_curves(subject).capsize_caster_complex
        assert f"at {speed:g} m/s" in spec.title
        if intervals:
            lo, hi = intervals[0]
            assert lo < speed < hi and f"from {lo:.2f} to {hi:.2f} m/s" in spec.caption
        else:
            assert "form no complex pair" in spec.caption and f"shown at {speed:g} m/s" in spec.caption


# --------------------------------------------------------------------------------------------
# Figs 17–18: the paper's speed
# --------------------------------------------------------------------------------------------


def _paper_bode_speeds(shared_dir: Path) -> set[float]:
    text = "\n".join(p.read_text(encoding="utf-8", errors="replace") for p in (shared_dir / "paper").glob("*.txt"))
    found = re.findall(r"Figure 1[78]: The frequency response[^\n]*? at ([\d.]+) m/s", text)
    assert len(found) == 2, "the paper's captions of Figs 17 and 18"
    return {float(v) for v in found}


def test_report_bode_at_the_papers_speed_and_says_so(bicycles: dict[str, Subject], shared_dir: Path) -> None:
    paper = _paper_bode_speeds(shared_dir)
    assert paper == {2.0} and paper <= set(BODE_SPEEDS)
    subject = bicycles["yellow"]
    specs = {s.key: s for s in figure_specs(subject, compute_results(subject))}
    for key in ("bode", "bode-rider"):
        spec = specs[key]
        assert tuple(spec.draw.keywords["speed"]) == BODE_SPEEDS  # type: ignore[attr-defined]
        assert "at 2 and 5 m/s" in spec.title and "Figs 17 and 18 are at 2 m/s" in spec.caption
    fig = specs["bode"].draw()
    assert "at 2 and 5 m/s" in fig.get_suptitle()
    for v in BODE_SPEEDS:
        c = bode_curves(subject, v)
        np.testing.assert_array_equal(_artist(fig, f"{subject.name}:magnitude:{v:g}").get_ydata(), c.magnitude_db)
        np.testing.assert_array_equal(_artist(fig, f"{subject.name}:phase:{v:g}").get_ydata(), c.phase_deg)
    # the command line's default is the paper's speed
    assert "at 2 m/s, without rider" in bode_figure([subject]).get_suptitle()


# --------------------------------------------------------------------------------------------
# Overlapping Bode curves stay visible
# --------------------------------------------------------------------------------------------


def _style(line: Line2D) -> tuple[Any, ...]:
    return (line.get_color(), line.get_linestyle(), line.get_marker(), line.get_linewidth())


def test_bode_curves_of_several_bicycles_are_drawn_apart(bicycles: dict[str, Subject]) -> None:
    subjects = [bicycles[n] for n in PAPER_BICYCLES]
    fig = bode_figure(subjects)
    mags = [_artist(fig, f"{s.name}:magnitude") for s in subjects]
    phases = [_artist(fig, f"{s.name}:phase") for s in subjects]
    for a, b in itertools.combinations(mags, 2):
        assert a.get_color() != b.get_color()
        assert (a.get_linestyle(), a.get_marker()) != (b.get_linestyle(), b.get_marker())  # without colour too
        assert a.get_linewidth() != b.get_linewidth()
        assert a.get_markevery()[0] != b.get_markevery()[0]  # markers staggered along the curve
    assert all(m.get_marker() not in (None, "None", "") for m in mags)
    # Browser and Browserins (same frame) nearly coincide: the later, thinner line is on top
    assert mags[1].get_zorder() > mags[0].get_zorder() and mags[1].get_linewidth() < mags[0].get_linewidth()
    for m, p in zip(mags, phases, strict=True):
        assert _style(m) == _style(p)  # a bicycle looks the same in both panels
    # one legend names every bicycle with its line's style
    assert len(fig.legends) == 1
    legend = fig.legends[0]
    assert [t.get_text() for t in legend.get_texts()] == [s.name for s in subjects]
    assert [_style(h) for h in legend.legend_handles] == [_style(m) for m in mags]  # type: ignore[arg-type]
