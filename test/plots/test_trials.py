"""Trial figures: a trial's fit figure draws its samples, fit and residuals.

The overview places every trial against its key's combined period, and shows a flagged or
period-less trial as such, its flags' short codes under it.

Numbers are read back from the figure's artists (by gid), never pixels.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Text

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.core.period import PeriodFit
from bike_rig.core.period.result import Flag, FlagCode
from bike_rig.core.sim import write_session
from bike_rig.offline.subjects import SessionTrial, Subject, load_subject
from bike_rig.plots.registry import FIT_DPI, FIT_FIGURE_SIZE_IN
from bike_rig.plots.trials import fit_figure, fit_title, overview_data, trial_overview
from test.support.simulated import short_session


@pytest.fixture(scope="module")
def session_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated Browser session (session.yaml, 39 trial files) and its bag beside it."""
    root = tmp_path_factory.mktemp("plots_trials")
    session = short_session()
    write_session(session, root / "session")
    write_simulated_bag(root / "bag", session)
    return root


@pytest.fixture(scope="module")
def file_subject(session_dir: Path) -> Subject:
    return load_subject(session_dir / "session" / "session.yaml")


@pytest.fixture(scope="module")
def bag_subject(session_dir: Path) -> Subject:
    return load_subject(session_dir / "bag")


def artist(fig: Figure, gid: str) -> object:
    """The one artist of ``fig`` with this gid."""
    found = fig.findobj(lambda a: a.get_gid() == gid)
    assert len(found) == 1, f"{len(found)} artists with gid {gid!r}"
    return found[0]


def line(fig: Figure, gid: str) -> Line2D:
    got = artist(fig, gid)
    assert isinstance(got, Line2D)
    return got


def flagged(trial: SessionTrial, factor: float, *codes: FlagCode) -> SessionTrial:
    """The trial left out with these flags, its period multiplied by ``factor``."""
    flags = tuple(Flag(c, f"test {c.value}") for c in codes)
    fit = dataclasses.replace(trial.fit, period=trial.fit.period * factor, flags=flags)
    return dataclasses.replace(trial, result=dataclasses.replace(trial.result, fit=fit), used=False)


def without_period(trial: SessionTrial) -> SessionTrial:
    fit = PeriodFit.invalid((Flag(FlagCode.NO_OSCILLATION, "test: nothing"),), trial.fit.window_policy)
    return dataclasses.replace(trial, result=dataclasses.replace(trial.result, fit=fit), used=False)


# ------------------------------------------------------------------ fit figure


def test_fit_figure_draws_the_samples_fit_and_residuals(bag_subject: Subject) -> None:
    trial = bag_subject.trials[4]
    assert trial.samples is not None and trial.sample_rate_hz
    fig = fit_figure(trial)
    samples = line(fig, "samples")
    t = np.arange(trial.samples.size) / trial.sample_rate_hz
    np.testing.assert_array_equal(samples.get_ydata(), trial.samples)
    np.testing.assert_allclose(samples.get_xdata(), t)
    start, stop = trial.fit.window
    fit = line(fig, "fit")
    np.testing.assert_allclose(fit.get_xdata(), t[start:stop])
    np.testing.assert_allclose(fit.get_ydata(), trial.fit.predict(t[start:stop]))
    resid = np.asarray(line(fig, "residuals").get_ydata())
    np.testing.assert_allclose(resid, trial.samples[start:stop] - trial.fit.predict(t[start:stop]))
    # the fit follows the data: residuals far below the signal
    assert np.std(resid) < 0.1 * np.std(trial.samples[start:stop])
    title = fig.axes[0].get_title()
    assert trial.trial_id in title and trial.key in title
    assert f"r² = {trial.fit.r2:.5f}" in title
    m = re.search(r"T = ([0-9.]+) ± ([0-9.]+) s", title)  # σ to 1-2 significant digits, T to σ's last digit
    assert m is not None, title
    value, sigma = m.groups()
    assert len(sigma.lstrip("0.")) in (1, 2) and len(value.split(".")[1]) == len(sigma.split(".")[1])
    assert abs(float(sigma) - trial.fit.period_sigma) <= 0.2 * trial.fit.period_sigma
    assert abs(float(value) - trial.fit.period) <= 0.5 * 10.0 ** -len(value.split(".")[1])
    assert "rad/s" in fig.axes[0].get_ylabel()


def test_fit_figure_of_a_flagged_trial_and_of_one_without_period(bag_subject: Subject) -> None:
    bad = flagged(bag_subject.trials[0], 1.0, FlagCode.BEATING)
    title = fit_figure(bad).axes[0].get_title()
    assert "left out" in title and "beating: test beating" in title
    none = without_period(bag_subject.trials[0])
    fig = fit_figure(none)
    assert "no period" in fig.axes[0].get_title() and "no_oscillation" in fig.axes[0].get_title()
    assert not fig.findobj(lambda a: a.get_gid() == "fit")
    line(fig, "samples")  # the data are still shown


#: A long flag reason, as the fitter writes them (several clauses and advice).
LONG_REASON = (
    "the envelope/phase wanders by up to 143 % of the amplitude from Eq 23 (limit 2 %): two close modes "
    "(swinging with the torsion?); steady the part, hang it again so it swings in one plane and record again"
)


def test_fit_figure_title_wraps_inside_the_figure_at_the_reports_size(bag_subject: Subject) -> None:
    trial = bag_subject.trials[0]
    fit = dataclasses.replace(
        trial.fit, flags=(Flag(FlagCode.BEATING, LONG_REASON), Flag(FlagCode.POOR_FIT, "r² = 0.636 < 0.9: " * 3))
    )
    trial = dataclasses.replace(trial, result=dataclasses.replace(trial.result, fit=fit), used=False)
    for size_in, dpi in ((FIT_FIGURE_SIZE_IN, FIT_DPI), ((10.0, 6.0), 110)):  # the report's, the plot's own
        fig = fit_figure(trial)
        fig.set_size_inches(*size_in)
        fig.set_dpi(dpi)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        title = fig.axes[0].title
        box = title.get_window_extent(renderer)
        page = fig.bbox
        assert title.get_text() == fit_title(trial) and LONG_REASON in title.get_text()  # nothing dropped
        assert page.x0 <= box.x0 and box.x1 <= page.x1 and box.y1 <= page.y1, (size_in, box, page)
        assert box.y0 >= fig.axes[0].get_window_extent(renderer).y1  # above the plot, not over it
        size_pt = float(title.get_fontsize())
        assert size_pt >= 8
        line_px = 1.2 * size_pt * dpi / 72.0  # matplotlib's line spacing
        assert box.height > (fit_title(trial).count("\n") + 1.5) * line_px  # the long line was wrapped
        # the data panel keeps most of its height
        assert fig.axes[0].get_window_extent(renderer).height > 0.35 * page.height


def test_fit_figure_without_samples_says_so(file_subject: Subject) -> None:
    first = file_subject.trials[0]
    trial = dataclasses.replace(first, result=dataclasses.replace(first.result, samples=None))
    fig = fit_figure(trial)
    note = artist(fig, "no-samples")
    assert isinstance(note, Text) and "no samples" in note.get_text()
    assert not fig.findobj(lambda a: a.get_gid() == "samples")
    assert f"{trial.fit.r2:.5f}" in fig.axes[0].get_title()


# ------------------------------------------------------------------ overview


def test_overview_numbers_are_relative_to_the_weighted_mean_of_used_trials(file_subject: Subject) -> None:
    ov = overview_data(file_subject)
    assert not ov.time_axis
    assert [p.x for p in ov.points] == list(range(len(file_subject.trials)))
    assert len(ov.references) == 13
    for ref in ov.references:
        fits = [t.fit for t in file_subject.trials if t.key == ref.key and t.used]
        w = np.array([1.0 / f.period_sigma**2 for f in fits])
        mean = float(np.sum(w * [f.period for f in fits]) / np.sum(w))
        assert ref.basis == "combined" and ref.n_used == len(fits) == 3
        assert ref.period == pytest.approx(mean, rel=1e-12)
        for p in ov.points:
            if p.trial.key == ref.key:
                assert p.deviation_ppm == pytest.approx((p.trial.fit.period - mean) / mean * 1e6, abs=1e-6)
                assert p.sigma_ppm == pytest.approx(p.trial.fit.period_sigma / mean * 1e6)


def test_overview_draws_used_left_out_and_period_less_trials_apart(bag_subject: Subject) -> None:
    trials = list(bag_subject.trials)
    trials[1] = flagged(trials[1], 1 + 2e-4, FlagCode.POOR_FIT, FlagCode.DRIFT)  # TcR1, on scale
    trials[4] = flagged(trials[4], 1.01, FlagCode.BEATING)  # TtR1, 10 000 ppm: off the scale
    trials[7] = without_period(trials[7])  # TcF1
    subject = dataclasses.replace(bag_subject, trials=tuple(trials))
    ov = overview_data(subject)
    assert ov.time_axis
    assert [p.x for p in ov.points] == [t.start_s for t in trials]
    status = {p.trial.trial_id: p.status for p in ov.points}
    assert status[trials[1].trial_id] == status[trials[4].trial_id] == "left out"
    assert status[trials[7].trial_id] == "no period"
    # the left-out trial is not in its key's reference: the mean of the two others
    ref = next(r for r in ov.references if r.key == trials[1].key)
    others = [trials[0].fit, trials[2].fit]
    w = np.array([1 / f.period_sigma**2 for f in others])
    assert ref.n_used == 2
    assert ref.period == pytest.approx(np.sum(w * [f.period for f in others]) / np.sum(w), rel=1e-12)

    fig = trial_overview(subject)
    used = line(fig, "overview:used")
    want = [(p.x, p.deviation_ppm) for p in ov.points if p.status == "used"]
    assert len(want) == 36
    np.testing.assert_allclose(np.column_stack([used.get_xdata(), used.get_ydata()]), want)
    left = line(fig, "overview:left out")
    assert list(left.get_xdata()) == [trials[1].start_s]  # the off-scale one is drawn apart
    p1 = next(p for p in ov.points if p.trial is trials[1])
    assert left.get_ydata()[0] == pytest.approx(p1.deviation_ppm)
    assert p1.deviation_ppm == pytest.approx((trials[1].fit.period / ref.period - 1) * 1e6, rel=1e-9)
    off = line(fig, f"offscale:{trials[4].trial_id}")
    low, high = fig.axes[0].get_ylim()
    assert off.get_xdata()[0] == trials[4].start_s and low < off.get_ydata()[0] < high
    assert off.get_ydata()[0] > 0.9 * high  # at the top edge: the trial is 1 % long
    gone = line(fig, "overview:no period")
    assert list(gone.get_xdata()) == [trials[7].start_s]
    # flags as short codes under their trial, in order of first appearance, named by the legend
    p4 = next(p for p in ov.points if p.trial is trials[4])
    assert p4.deviation_ppm == pytest.approx(1e4, rel=5e-3)  # (the other trials' mean: tens of ppm off)
    for i, codes in ((1, "A,B"), (4, f"C\n{p4.deviation_ppm:+.3g} ppm"), (7, "D")):  # the off-scale value too
        note = artist(fig, f"flags:{trials[i].trial_id}")
        assert isinstance(note, Text) and note.get_text() == codes
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    for code in ("poor_fit (1)", "drift (1)", "beating (1)", "no_oscillation (1)"):
        assert code in legend
    # r² and cycles panels: one point per trial with a period
    r2 = artist(fig, "overview:r2")
    assert len(r2.get_offsets()) == 38  # type: ignore[attr-defined]
    np.testing.assert_allclose(
        np.asarray(r2.get_offsets())[:, 1],  # type: ignore[attr-defined]
        [max(1 - t.fit.r2, 1e-12) for t in trials if t.fit.valid],
    )


def test_overview_of_a_subject_without_trials_is_refused(file_subject: Subject) -> None:
    with pytest.raises(ValueError, match="no trials"):
        trial_overview(dataclasses.replace(file_subject, trials=()))
