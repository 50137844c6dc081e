"""Every kind of figure, as drawn, of a finished and an unfinished session: nothing overlaps or spills.

Each kind of :data:`bike_rig.plots.registry.FIGURES` is drawn for a full session bag (every
kind) and a partial one (the kinds drawn from trials: a partial session has no parameters), at
``bike-rig plot``'s size and at the report's; the renderer's boxes of what it draws must show no
two texts overlapping, every text inside the canvas and no legend over the data
(:func:`test.support.figure_layout.layout_faults`). The measurement keys' labels over the
trial-quality figure stay apart for any number of keys: a session whose every trial has its own
long key is drawn too.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import pytest
from matplotlib.figure import Figure

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.labels import label_rows
from bike_rig.plots.registry import FIGURES, FigureKind, Scope
from bike_rig.report.figures import REPORT_DPI
from test.support.figure_layout import drawn_texts, layout_faults, legend_coverage
from test.support.simulated import short_session

#: Measurement keys kept in the partial session (the others are missing).
KEPT = 3
#: Trials of a session whose fit figures are drawn (the layout is the same for each).
FITS = 2
TRIAL_KINDS = [k for k in FIGURES.values() if k.needs_trials]


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Subject]:
    """A finished session bag and an unfinished one (the first keys' trials only), as subjects."""
    tmp = tmp_path_factory.mktemp("layout")
    session = short_session()
    keys = list(dict.fromkeys(t.key for t in session.trials))
    kept = set(keys[:KEPT])
    part = dataclasses.replace(session, trials=tuple(t for t in session.trials if t.key in kept))
    full = load_subject(write_simulated_bag(tmp / "full", session))
    partial = load_subject(write_simulated_bag(tmp / "part", part, pause_s=2.0), partial=True)
    assert full.complete and not partial.complete
    return {"full": full, "partial": partial}


@pytest.fixture(scope="module")
def ride_record(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A simulated ride of the Browser with the paper's rider, as a CSV record."""
    out = tmp_path_factory.mktemp("ride") / "ride.csv"
    argv = ["ride", "simulate", "browser", "--rider", "paper", "--speed", "4.5", "--duration", "25", "--seed", "3"]
    assert main([*argv, "--feedback", str(config_file("feedback/balance_assist.yaml")), "-o", str(out)]) == 0
    return str(out)


def _figures(kind: FigureKind, subject: Subject, ride: str) -> Iterator[Figure]:
    """The figures ``bike-rig plot`` draws of one kind for one input (a few fits of a session)."""
    options: dict[str, Any] = {}
    if kind.per_rider:
        options["rider"] = "paper"
    if "ride" in kind.options:
        options["ride"] = (ride,)
    if kind.scope is Scope.BICYCLES:
        yield kind.draw([subject], **options)
    elif kind.scope is Scope.SUBJECT:
        yield kind.draw(subject, **options)
    else:
        for trial in subject.trials[:FITS]:
            yield kind.draw(trial, **options)


def _check(fig: Figure, what: str) -> None:
    try:
        faults = layout_faults(fig)
        assert not faults, f"{what}: " + "\n".join(faults)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("kind", list(FIGURES.values()), ids=list(FIGURES))
def test_a_full_session_s_figures_are_laid_out(
    kind: FigureKind, sessions: dict[str, Subject], ride_record: str
) -> None:
    for fig in _figures(kind, sessions["full"], ride_record):
        _check(fig, kind.name)


@pytest.mark.parametrize("kind", TRIAL_KINDS, ids=[k.name for k in TRIAL_KINDS])
@pytest.mark.parametrize("session", ["full", "partial"])
def test_trial_figures_are_laid_out_at_the_report_s_size(
    kind: FigureKind, session: str, sessions: dict[str, Subject]
) -> None:
    for entry in kind.report:
        for fig in _figures(kind, sessions[session], ""):
            if entry.size_in is not None:
                fig.set_size_inches(*entry.size_in)
            fig.set_dpi(entry.dpi or REPORT_DPI)
            _check(fig, f"{kind.name} at the report's size")


@pytest.mark.parametrize("kind", TRIAL_KINDS, ids=[k.name for k in TRIAL_KINDS])
def test_a_partial_session_s_trial_figures_are_laid_out(kind: FigureKind, sessions: dict[str, Subject]) -> None:
    for fig in _figures(kind, sessions["partial"], ""):
        _check(fig, kind.name)


@pytest.mark.parametrize("size_in", [(11.0, 7.5)])
def test_key_labels_of_many_long_keys_do_not_overlap(
    sessions: dict[str, Subject], size_in: tuple[float, float]
) -> None:
    subject = sessions["full"]
    trials = tuple(
        dataclasses.replace(t, result=dataclasses.replace(t.result, measurement_key=f"{t.key}-{i:02d}-long-key"))
        for i, t in enumerate(subject.trials)
    )
    fig = FIGURES["trials"].draw(dataclasses.replace(subject, trials=trials))
    fig.set_size_inches(*size_in)
    labels = [t for t in drawn_texts(fig) if t.text.endswith("-long-key")]
    assert len(labels) == len(trials)  # every key labelled, none dropped
    _check(fig, f"trials of {len(trials)} keys at {size_in}")


def test_label_rows_stack_only_what_collides() -> None:
    assert label_rows([(0, 10), (12, 20), (30, 40)], gap=1.0) == [0, 0, 0]
    assert label_rows([(0, 10), (5, 15), (8, 18), (16, 30)], gap=1.0) == [0, 1, 2, 0]
    assert label_rows([(20, 30), (0, 10)], gap=15.0) == [1, 0]  # left to right, whatever the order given
    assert label_rows([], gap=1.0) == []


def test_a_fit_legend_covers_no_sample(sessions: dict[str, Subject]) -> None:
    fig = FIGURES["fits"].draw(sessions["full"].trials[0])
    try:
        fig.canvas.draw()
        assert legend_coverage(fig) == 0.0
    finally:
        plt.close(fig)


def test_layout_faults_sees_a_legend_over_the_data_and_overlapping_texts(tmp_path: Path) -> None:
    fig = plt.figure(figsize=(4, 3))
    ax = fig.add_subplot()
    ax.plot(range(100), [1.0] * 100, ".", label="points on the legend's row")
    ax.set_ylim(0.99, 1.01)
    ax.legend(loc="center")
    ax.text(0.1, 0.1, "one text", transform=ax.transAxes)
    ax.text(0.12, 0.1, "another text", transform=ax.transAxes)
    ax.text(1.3, 0.5, "off the canvas", transform=ax.transAxes)
    faults = layout_faults(fig)
    plt.close(fig)
    assert any("legend covers" in f for f in faults)
    assert any(f.startswith("overlap: 'one text'") for f in faults)
    assert any("outside" in f and "off the canvas" in f for f in faults)
