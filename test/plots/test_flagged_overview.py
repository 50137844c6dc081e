"""The trial-quality figure of a heavily flagged session: flags in rows, each named by the legend.

Two sessions: one of 4 s trials (too short for the rig's periods: the fitter flags every
trial, about half without a period) and one whose trials carry every flag code, three each,
several in a row off the deviation scale. Drawn at ``bike-rig plot``'s size and at the report's
(and smaller and larger), no two texts overlap and none leaves the canvas
(:func:`test.support.figure_layout.layout_faults`), and every flagged trial's short codes, read
back from what was drawn, name its flags through the legend.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import matplotlib.pyplot as plt
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.core.period import PeriodFit
from bike_rig.core.period.result import Flag, FlagCode
from bike_rig.offline.subjects import SessionTrial, Subject, load_subject
from bike_rig.plots.labels import RowLabels
from bike_rig.plots.registry import FIGURES
from bike_rig.plots.style import new_figure
from bike_rig.plots.trials import flag_key, overview_data, short_code
from bike_rig.report.figures import REPORT_DPI
from test.support.figure_layout import drawn_layout_faults, drawn_texts, layout_faults
from test.support.simulated import short_session

#: Trial length of the session too short to fit, s (the rig's periods are 0.3-2.7 s, 4 cycles asked).
SHORT_TRIAL_S = 4.0
#: Flags each flagged trial of the every-flag session carries.
FLAGS_PER_TRIAL = 3


def _every_flag(subject: Subject) -> Subject:
    """``subject`` with two trials of three flagged, cycling through every flag code.

    Of each three trials the first stays used (the deviation scale stays narrow), the second is
    2 % long and the third 3 % short (both off the scale), every other third trial has no period.
    """
    codes = list(FlagCode)
    trials: list[SessionTrial] = []
    for i, t in enumerate(subject.trials):
        if i % 3 == 0:
            trials.append(t)
            continue
        flags = tuple(Flag(codes[(FLAGS_PER_TRIAL * i + k) % len(codes)], "test") for k in range(FLAGS_PER_TRIAL))
        if i % 6 == 2:
            fit = PeriodFit.invalid(flags, t.fit.window_policy)
        else:
            fit = dataclasses.replace(t.fit, period=t.fit.period * (1.02 if i % 3 == 1 else 0.97), flags=flags)
        trials.append(dataclasses.replace(t, result=dataclasses.replace(t.result, fit=fit), used=False))
    return dataclasses.replace(subject, trials=tuple(trials))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Subject]:
    """The two heavily flagged sessions and the clean one of the second, as subjects of session bags."""
    tmp = tmp_path_factory.mktemp("flagged")
    short = load_subject(write_simulated_bag(tmp / "short", short_session(duration_s=SHORT_TRIAL_S)), partial=True)
    n_flagged = sum(bool(t.fit.flag_codes) for t in short.trials)
    assert n_flagged == len(short.trials) and sum(not t.fit.valid for t in short.trials) >= 10
    full = load_subject(write_simulated_bag(tmp / "full", short_session()))
    every = _every_flag(full)
    assert {c for t in every.trials for c in t.fit.flag_codes} == {c.value for c in FlagCode}
    return {"short trials": short, "every flag": every, "clean": full}


def _drawings(subject: Subject) -> Iterator[tuple[str, Figure]]:
    """The trial-quality figure as ``bike-rig plot`` draws it, then at each of the report's sizes."""
    kind = FIGURES["trials"]
    yield "plot", kind.draw(subject)
    for entry in kind.report:
        fig = kind.draw(subject)
        if entry.size_in is not None:
            fig.set_size_inches(*entry.size_in)
        fig.set_dpi(entry.dpi or REPORT_DPI)
        yield "report", fig


def _legend_key(fig: Figure) -> dict[str, str]:
    """Short code → flag code, as the figure's legend names them (a short code is drawn as its handle)."""
    key: dict[str, str] = {}
    for legend in fig.legends:
        for handle, label in zip(legend.legend_handles, legend.get_texts(), strict=True):
            if isinstance(handle, Text) and handle.get_text():
                key[handle.get_text()] = label.get_text().rsplit(" (", 1)[0]
    return key


def _flag_label(fig: Figure, trial: SessionTrial) -> Text:
    found = fig.findobj(lambda a: a.get_gid() == f"flags:{trial.trial_id}")
    assert len(found) == 1 and isinstance(found[0], Text), f"{trial.trial_id}: {len(found)} flag labels"
    return found[0]


@pytest.mark.parametrize("name", ["short trials", "every flag"])
def test_a_heavily_flagged_session_s_overview_is_laid_out_and_names_every_flag(
    name: str, sessions: dict[str, Subject]
) -> None:
    subject = sessions[name]
    flagged = [t for t in subject.trials if t.fit.flag_codes]
    for size, fig in _drawings(subject):
        try:
            texts = drawn_texts(fig)
            faults = drawn_layout_faults(fig, texts)
            assert not faults, f"{name} at the {size} size: " + "\n".join(faults)
            drawn = [t.text for t in texts]
            renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
            key = _legend_key(fig)
            assert set(key.values()) == {c for t in flagged for c in t.fit.flag_codes}  # every code named
            for short, code in key.items():
                assert short in drawn and any(d.startswith(f"{code} (") for d in drawn), (short, code)
            data_bottom = fig.axes[0].get_window_extent(renderer).y0
            for trial in flagged:
                label = _flag_label(fig, trial)
                assert label.get_text() in drawn
                shorts = label.get_text().split("\n")[0].split(",")
                assert [key[s] for s in shorts] == list(dict.fromkeys(trial.fit.flag_codes)), trial.trial_id
                assert label.get_window_extent(renderer).y1 <= data_bottom  # outside the data, under the panel
        finally:
            plt.close(fig)


def test_a_trial_off_the_scale_has_its_deviation_under_it(sessions: dict[str, Subject]) -> None:
    subject = sessions["every flag"]
    ov = overview_data(subject)
    fig = FIGURES["trials"].draw(subject)
    try:
        low, high = fig.axes[0].get_ylim()
        off = [p for p in ov.points if p.status != "no period" and not low <= p.deviation_ppm <= high]
        assert len(off) == sum(1 for i in range(len(subject.trials)) if i % 3 and i % 6 != 2)
        for p in off:
            assert _flag_label(fig, p.trial).get_text().split("\n")[1] == f"{p.deviation_ppm:+.3g} ppm"
    finally:
        plt.close(fig)


def test_flag_key_counts_each_code_once_per_trial_in_order_of_first_appearance(
    sessions: dict[str, Subject],
) -> None:
    subject = sessions["every flag"]
    trial = subject.trials[1]
    doubled = dataclasses.replace(trial.fit, flags=trial.fit.flags + trial.fit.flags[:1])
    again = dataclasses.replace(trial, result=dataclasses.replace(trial.result, fit=doubled))
    trials = (subject.trials[0], again, *subject.trials[2:])
    key = flag_key(overview_data(dataclasses.replace(subject, trials=trials)))
    order = list(dict.fromkeys(c for t in trials for c in t.fit.flag_codes))
    assert [k.code for k in key] == order
    assert [k.short for k in key] == [chr(ord("A") + i) for i in range(len(order))]
    for k in key:
        assert k.n_trials == sum(k.code in t.fit.flag_codes for t in trials)


def test_short_codes_go_on_past_z() -> None:
    assert [short_code(i) for i in (0, 1, 25, 26, 27, 51, 52, 701, 702)] == [
        "A",
        "B",
        "Z",
        "AA",
        "AB",
        "AZ",
        "BA",
        "ZZ",
        "AAA",
    ]


def test_an_unflagged_session_has_no_flag_key(sessions: dict[str, Subject]) -> None:
    subject = sessions["clean"]
    assert not any(t.fit.flag_codes for t in subject.trials)
    fig = FIGURES["trials"].draw(subject)
    try:
        assert _legend_key(fig) == {}
        assert not fig.findobj(lambda a: str(a.get_gid()).startswith("flags:"))
        assert "flags, under each trial:" not in [t.text for t in drawn_texts(fig)]
    finally:
        plt.close(fig)


@pytest.mark.parametrize("size_in", [(6.0, 4.0), (11.0, 7.5)])
def test_row_labels_below_an_axes_clear_its_ticks_and_tick_labels(size_in: tuple[float, float]) -> None:
    fig = new_figure(*size_in)
    ax = fig.subplots()
    ax.plot(range(60), [0.0] * 60, ".")
    ax.set_xlabel("x label")
    rows = RowLabels(ax, list(range(60)), [f"L{i}" * (1 + i % 3) for i in range(60)], below=True, fontsize=6)
    try:
        faults = layout_faults(fig)
        assert not faults, "\n".join(faults)
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        ticks = ax.xaxis.get_tightbbox(renderer)
        assert ticks is not None
        tick_bottom = min([ticks.y0, *(t.get_window_extent(renderer).y0 for t in ax.get_xticklabels())])
        assert max(rows.rows) >= 1  # crowded: more than one row
        for label in rows.texts:
            assert label.get_window_extent(renderer).y1 <= tick_bottom  # under the x axis and its label
    finally:
        plt.close(fig)


@pytest.mark.parametrize("size_in", [(6.0, 4.0), (7.0, 5.0), (9.0, 6.0), (14.0, 9.0)])
@pytest.mark.parametrize("name", ["short trials", "every flag"])
def test_the_flagged_overview_is_laid_out_at_other_sizes(
    name: str, size_in: tuple[float, float], sessions: dict[str, Subject]
) -> None:
    fig = FIGURES["trials"].draw(sessions[name])
    fig.set_size_inches(*size_in)
    try:
        texts = drawn_texts(fig)
        faults = drawn_layout_faults(fig, texts)
        assert not faults, f"{name} at {size_in} in: " + "\n".join(faults)
        heading = [t.text for t in texts if t.text.startswith(sessions[name].name + ":")]
        assert len(heading) == 1  # wrapped to the panel's width, nothing dropped
        assert all(k in heading[0].split() or k + "," in heading[0].split() for k in sessions[name].missing)
    finally:
        plt.close(fig)
