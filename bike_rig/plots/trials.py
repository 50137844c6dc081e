"""Trial figures: one trial's fit, and a session's trial-quality overview.

The fit figure shows the data, the Eq 23 fit over the window and the residuals; the overview
every trial's period against its key's combined period, r² and cycles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.legend_handler import HandlerBase
from matplotlib.patches import Patch
from matplotlib.text import Text
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import Transform
from numpy.typing import NDArray

from ..core.period import FitOptions, combine_periods
from ..core.textfmt import format_value_sigma
from ..offline.subjects import SessionTrial, Subject, is_bag_path
from ..offline.timeline import TIME_BASE
from .labels import LegendFittingFigure, RowLabels, SettlingLayout
from .style import new_figure

__all__ = [
    "STATUS_LABELS",
    "FlagKey",
    "KeyReference",
    "OverviewPoint",
    "TrialOverview",
    "fit_figure",
    "fit_title",
    "flag_key",
    "incomplete_text",
    "overview_data",
    "short_code",
    "trial_overview",
    "trial_status",
]

FloatArray = NDArray[np.float64]

#: Status of a trial → legend label, marker, colour of the overview.
STATUS_LABELS: dict[str, tuple[str, str, str]] = {
    "used": ("used in the combined period", "o", "C0"),
    "left out": ("left out (flagged or rejected)", "s", "C3"),
    "no period": ("no period", "X", "0.2"),
}
#: Smallest half-range of the deviation axis, ppm.
_MIN_RANGE_PPM = 10.0
#: Margin of the deviation axis around the used trials' error bars.
_RANGE_MARGIN = 1.6
#: Colour of the flag codes and of the values of trials off the deviation scale.
_FLAG_COLOUR = "C3"


def incomplete_text(missing: Sequence[str]) -> str:
    """What an incomplete session lacks, for a figure: its keys without a usable trial.

    Args:
        missing: The measurement keys without a usable trial.
    """
    return f"incomplete session: no usable trial yet for {', '.join(missing) or 'unknown keys'}"


def trial_status(trial: SessionTrial) -> str:
    """A trial's status in its session.

    Args:
        trial: The trial.

    Returns:
        ``used``, ``left out`` (a period, but not in the combined one) or ``no period``.
    """
    if not trial.fit.valid:
        return "no period"
    return "used" if trial.used else "left out"


def fit_title(trial: SessionTrial) -> str:
    """Title of a trial's fit figure.

    Args:
        trial: The trial.

    Returns:
        Id, key, T ± σ (s), ζ, r², cycles, status and flags.
    """
    fit = trial.fit
    head = f"{trial.trial_id} ({trial.key})"
    if fit.valid:
        value, sigma = format_value_sigma(fit.period, fit.period_sigma, digits=None)
        head += f": T = {value} ± {sigma} s, ζ = {fit.zeta:.2e}, r² = {fit.r2:.5f}, {fit.n_cycles:.1f} cycles"
    else:
        head += ": no period"
    lines = [head]
    status = trial_status(trial)
    if fit.flags:
        lines.append(f"{status}; flags: " + "; ".join(str(f) for f in fit.flags))
    elif status != "used":
        lines.append(status)
    if trial.note:
        lines.append(trial.note)
    return "\n".join(lines)


def _time_axis(trial: SessionTrial) -> FloatArray:
    """Each sample's time on the fit's own time axis (what ``fit.predict`` expects), s."""
    assert trial.samples is not None
    if trial.times is not None:
        return np.asarray(trial.times, dtype=float)
    rate = trial.sample_rate_hz if trial.sample_rate_hz else 1.0
    return np.arange(trial.samples.size, dtype=float) / float(rate)


def fit_figure(trial: SessionTrial) -> Figure:
    """One trial: samples with the Eq 23 fit over its window (top), residuals (bottom).

    Without samples (a period given as a number, or a trial whose samples were not recorded)
    the figure says so in place of the data and keeps the fit's numbers in the title.

    Args:
        trial: The trial.

    Returns:
        The figure. Artists carry gids: ``samples``, ``fit``, ``window``, ``residuals``.
    """
    fig = new_figure(10.0, 6.0)
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    top.set_title(fit_title(trial), fontsize=9, wrap=True)
    unit = "rad/s" if is_bag_path(trial.source) else "file units"
    top.set_ylabel(f"angular rate [{unit}]")
    bottom.set_ylabel(f"residual [{unit}]")
    bottom.set_xlabel("time from the first sample [s]")
    if trial.samples is None or trial.samples.size == 0:
        top.text(
            0.5,
            0.5,
            "no samples recorded for this trial",
            transform=top.transAxes,
            ha="center",
            va="center",
            gid="no-samples",
        )
        return fig
    t = _time_axis(trial)
    y = np.asarray(trial.samples, dtype=float)
    top.plot(t, y, ".", markersize=1.5, color="0.55", label="samples", gid="samples", rasterized=True)
    fit = trial.fit
    start, stop = fit.window
    if fit.valid and 0 <= start < stop <= y.size:
        tw = t[start:stop]
        model = fit.predict(tw)
        top.plot(tw, model, "-", color="C0", linewidth=1.0, label="Eq 23 fit", gid="fit")
        top.axvspan(float(tw[0]), float(tw[-1]), color="C0", alpha=0.06, label="fit window", gid="window")
        bottom.plot(tw, y[start:stop] - model, ".", markersize=1.5, color="C3", gid="residuals", rasterized=True)
        bottom.axhline(0.0, color="0.3", linewidth=0.6)
    else:
        bottom.text(0.5, 0.5, "no fit", transform=bottom.transAxes, ha="center", va="center")
    fig.legend(handles=top.get_legend_handles_labels()[0], loc="outside right upper", fontsize=8)
    return fig


@dataclass(frozen=True)
class KeyReference:
    """What a measurement key's trials are compared with in the overview.

    Attributes:
        key: The measurement key (``TtB1``...).
        period: The reference period, s: the weighted mean of the used trials (the combined
            period), else the median of the valid trials, else NaN.
        sigma: Its standard uncertainty, s (NaN unless it is the combined period).
        basis: ``combined`` (used trials), ``median`` (no used trial) or ``none`` (no period).
        n_used: Trials used in the combined period.
    """

    key: str
    period: float
    sigma: float
    basis: str
    n_used: int


@dataclass(frozen=True)
class OverviewPoint:
    """One trial in the overview.

    Attributes:
        trial: The trial.
        status: See :func:`trial_status`.
        x: Its place on the horizontal axis: start time (bags; s,
            :data:`bike_rig.offline.timeline.TIME_BASE`), or its position in session order.
        deviation_ppm: (T − T_ref) / T_ref of its key, ppm (NaN without a period).
        sigma_ppm: σ_T / T_ref, ppm (NaN without a period).
    """

    trial: SessionTrial
    status: str
    x: float
    deviation_ppm: float
    sigma_ppm: float


@dataclass(frozen=True)
class TrialOverview:
    """The numbers behind :func:`trial_overview`.

    Attributes:
        references: One per measurement key, in first-appearance order.
        points: One per trial, in session order.
        time_axis: Whether ``x`` is the start time (s) instead of the session order.
    """

    references: tuple[KeyReference, ...]
    points: tuple[OverviewPoint, ...]
    time_axis: bool


def _reference(key: str, trials: Sequence[SessionTrial]) -> KeyReference:
    used = [t.fit for t in trials if t.used and t.fit.valid]
    if used:
        cp = combine_periods(used, include_flagged=True)
        if math.isfinite(cp.value):
            return KeyReference(key, cp.value, cp.sigma, "combined", cp.n_used)
    valid = [t.fit.period for t in trials if t.fit.valid and math.isfinite(t.fit.period)]
    if valid:
        return KeyReference(key, float(np.median(valid)), math.nan, "median", 0)
    return KeyReference(key, math.nan, math.nan, "none", 0)


def overview_data(subject: Subject) -> TrialOverview:
    """Every trial's period relative to its key's reference period (see :class:`KeyReference`).

    Args:
        subject: A bicycle with trials.

    Returns:
        The overview's numbers, one point per trial.

    Raises:
        ValueError: The subject has no trials.
    """
    trials = subject.trials
    if not trials:
        raise ValueError(f"{subject.path}: no trials")
    keys: dict[str, list[SessionTrial]] = {}
    for t in trials:
        keys.setdefault(t.key, []).append(t)
    refs = {k: _reference(k, ts) for k, ts in keys.items()}
    time_axis = all(t.start_s is not None for t in trials)
    points = []
    for i, t in enumerate(trials):
        ref = refs[t.key].period
        x = float(t.start_s) if time_axis and t.start_s is not None else float(i)
        if t.fit.valid and math.isfinite(ref) and ref > 0:
            dev = (t.fit.period - ref) / ref * 1e6
            sig = t.fit.period_sigma / ref * 1e6
        else:
            dev = sig = math.nan
        points.append(OverviewPoint(t, trial_status(t), x, dev, sig))
    return TrialOverview(tuple(refs.values()), tuple(points), time_axis)


@dataclass(frozen=True)
class FlagKey:
    """A flag code of the overview and the short code written under its trials.

    Attributes:
        code: The flag code (``too_few_cycles``...).
        short: Its short code on the figure: ``A``, ``B``, … ``Z``, ``AA``… in order of first
            appearance in the session.
        n_trials: Trials flagged with it.
    """

    code: str
    short: str
    n_trials: int


def short_code(index: int) -> str:
    """The ``index``-th (0-based) short code of a flag: A to Z, then AA, AB and so on.

    Args:
        index: The flag's place in the session's order of first appearance, ≥ 0.
    """
    out = ""
    n = index + 1
    while n:
        n, r = divmod(n - 1, 26)
        out = chr(ord("A") + r) + out
    return out


def flag_key(ov: TrialOverview) -> tuple[FlagKey, ...]:
    """The flag codes of a session's trials with their short codes, in order of first appearance.

    Args:
        ov: The overview's numbers.
    """
    counts: dict[str, int] = {}
    for p in ov.points:
        for code in dict.fromkeys(p.trial.fit.flag_codes):
            counts[code] = counts.get(code, 0) + 1
    return tuple(FlagKey(code, short_code(i), n) for i, (code, n) in enumerate(counts.items()))


def _trial_note(p: OverviewPoint, half: float, shorts: dict[str, str]) -> str:
    """What is written under a trial: its flags' short codes, and its deviation when off the scale."""
    lines = []
    if p.trial.fit.flag_codes:
        lines.append(",".join(shorts[c] for c in dict.fromkeys(p.trial.fit.flag_codes)))
    if p.status != "no period" and math.isfinite(p.deviation_ppm) and abs(p.deviation_ppm) > half:
        lines.append(f"{p.deviation_ppm:+.3g} ppm")
    return "\n".join(lines)


class _ShortCode:
    """A legend handle: a flag's short code, drawn in place of a marker."""

    def __init__(self, short: str) -> None:
        self.short = short


class _ShortCodeHandler(HandlerBase):
    """Draws a :class:`_ShortCode` handle as its text, centred in the handle box."""

    def create_artists(
        self,
        legend: Legend,
        orig_handle: Any,
        xdescent: float,
        ydescent: float,
        width: float,
        height: float,
        fontsize: float,
        trans: Transform,
    ) -> Sequence[Artist]:
        """The short code as a text in the legend's handle box."""
        text = Text(
            width / 2 - xdescent,
            height / 2 - ydescent,
            orig_handle.short,
            ha="center",
            va="center",
            fontsize=fontsize,
            color=_FLAG_COLOUR,
            fontweight="bold",
            transform=trans,
        )
        return [text]


def _deviation_range(points: Sequence[OverviewPoint]) -> float:
    """Half-range of the deviation axis: the used trials' error bars with a margin, ppm."""
    core = [p for p in points if p.status == "used" and math.isfinite(p.deviation_ppm)]
    if not core:
        core = [p for p in points if math.isfinite(p.deviation_ppm)]
    reach = [abs(p.deviation_ppm) + (p.sigma_ppm if math.isfinite(p.sigma_ppm) else 0.0) for p in core]
    return max([_MIN_RANGE_PPM, *(_RANGE_MARGIN * r for r in reach)])


def _key_groups(ov: TrialOverview) -> list[tuple[str, float, float]]:
    """(key, x_min, x_max) of each run of consecutive trials of one key, in order."""
    groups: list[tuple[str, float, float]] = []
    for p in ov.points:
        x1 = p.x
        if ov.time_axis and p.trial.stop_s is not None:
            x1 = float(p.trial.stop_s)
        if groups and groups[-1][0] == p.trial.key:
            k, a, b = groups[-1]
            groups[-1] = (k, min(a, p.x), max(b, x1))
        else:
            groups.append((p.trial.key, p.x, x1))
    return groups


def _draw_deviation(ax: Axes, ov: TrialOverview, title: str) -> tuple[FlagKey, ...]:
    """The deviation panel; returns the flag codes written under its trials."""
    half = _deviation_range(ov.points)
    refs = {r.key: r for r in ov.references}
    pad = 0.4 if not ov.time_axis else 0.0
    centres, labels, gids = [], [], []
    for j, (key, a, b) in enumerate(_key_groups(ov)):
        if j % 2:
            ax.axvspan(a - 0.5 if not ov.time_axis else a, b + 0.5 if not ov.time_axis else b, color="0.93", zorder=0)
        ref = refs[key]
        if ref.basis == "combined" and math.isfinite(ref.sigma):
            s = ref.sigma / ref.period * 1e6
            ax.fill_between([a - pad, b + pad], [-s, -s], [s, s], color="C2", alpha=0.25, linewidth=0, zorder=1)
        centres.append((a + b) / 2)
        labels.append(key if ref.basis == "combined" else f"{key} ({ref.basis})")
        gids.append(f"key:{key}")
    RowLabels(ax, centres, labels, gids, title=title, fontsize=7)
    for status, (label, marker, colour) in STATUS_LABELS.items():
        pts = [p for p in ov.points if p.status == status]
        if not pts:
            continue
        xs = np.array([p.x for p in pts])
        if status == "no period":
            ys = np.full(xs.size, -0.9 * half)
            ax.plot(
                xs,
                ys,
                marker,
                linestyle="",
                color=colour,
                markersize=6,
                label=f"{label} ({len(pts)})",
                gid=f"overview:{status}",
                zorder=4,
            )
        else:
            dev = np.array([p.deviation_ppm for p in pts])
            sig = np.array([p.sigma_ppm for p in pts])
            inside = np.abs(dev) <= half
            face = colour if status == "used" else "white"
            cont = ax.errorbar(
                xs[inside],
                dev[inside],
                yerr=sig[inside],
                fmt=marker,
                color=colour,
                markerfacecolor=face,
                markersize=5,
                elinewidth=0.8,
                capsize=2,
                label=f"{label} ({len(pts)})",
                zorder=4,
            )
            cont.lines[0].set_gid(f"overview:{status}")
            for p in (q for q, ok in zip(pts, inside) if not ok):
                edge = math.copysign(0.95 * half, p.deviation_ppm)
                ax.plot(
                    [p.x],
                    [edge],
                    "^" if edge > 0 else "v",
                    color=colour,
                    markerfacecolor=face,
                    markersize=7,
                    gid=f"offscale:{p.trial.trial_id}",
                    zorder=4,
                )
    flags = flag_key(ov)
    shorts = {k.code: k.short for k in flags}
    notes = [(p, _trial_note(p, half, shorts)) for p in ov.points]
    notes = [(p, note) for p, note in notes if note]
    RowLabels(
        ax,
        [p.x for p, _ in notes],
        [note for _, note in notes],
        [f"flags:{p.trial.trial_id}" for p, _ in notes],
        below=True,
        fontsize=6,
        color=_FLAG_COLOUR,
    )
    ax.axhline(0.0, color="0.3", linewidth=0.6)
    ax.set_ylim(-half, half)
    ax.set_ylabel("(T − T_key) / T_key\n[ppm]")
    return flags


def trial_overview(subject: Subject) -> Figure:
    """A session's trial quality at a glance.

    Top: each trial's period relative to its key's combined period (ppm, error bars σ_T),
    so keys of very different periods share one axis, with the combined period's σ as a
    band; used, left-out and period-less trials have distinct markers and periods off the
    scale are drawn at its edge. Under the panel, in rows that never overlap, each flagged
    trial's flags as short codes (``A,B``; the legend names them, see :func:`flag_key`) and
    each off-scale trial's deviation. Middle: 1 − r² (log). Bottom: cycles in the fit window. Trials are placed by their
    start time for a bag, else in session order. The legend fits the figure at whatever size it
    is drawn (:class:`~bike_rig.plots.labels.LegendFittingFigure`: columns, a smaller font).

    Args:
        subject: A bicycle with trials.

    Returns:
        The figure; see :func:`overview_data` for its numbers. The markers of each status are
        one line with gid ``overview:<status>``.

    Raises:
        ValueError: The subject has no trials.
    """
    ov = overview_data(subject)
    fig = new_figure(11.0, 7.5, LegendFittingFigure)
    fig.set_layout_engine(SettlingLayout())
    dev_ax, r2_ax, cyc_ax = fig.subplots(3, 1, sharex=True, height_ratios=(3, 1.3, 1.3))
    n = len(ov.points)
    used = sum(p.status == "used" for p in ov.points)
    title = f"{subject.name}: {n} trials, {used} used, {len(ov.references)} periods ({subject.path})"
    if not subject.complete:
        title += "\n" + incomplete_text(subject.missing)
    flags = _draw_deviation(dev_ax, ov, title)
    defaults = FitOptions()
    valid = [p for p in ov.points if p.trial.fit.valid]
    xs = np.array([p.x for p in valid])
    colours = [STATUS_LABELS[p.status][2] for p in valid]
    one_minus = np.array([max(1.0 - p.trial.fit.r2, 1e-12) for p in valid])
    r2_ax.scatter(xs, one_minus, s=12, c=colours, gid="overview:r2")
    r2_ax.axhline(
        1.0 - defaults.min_r2,
        color="C3",
        linestyle=":",
        linewidth=0.8,
        label=f"default flag threshold (r² < {defaults.min_r2:g})",
    )
    if one_minus.size and np.all(np.isfinite(one_minus)):
        r2_ax.set_yscale("log")
    r2_ax.set_ylabel("1 − r²", rotation=0, ha="right", va="center")
    cycles = np.array([p.trial.fit.n_cycles for p in valid])
    cyc_ax.scatter(xs, cycles, s=12, c=colours, gid="overview:cycles")
    cyc_ax.axhline(
        defaults.min_cycles,
        color="C3",
        linestyle=":",
        linewidth=0.8,
        label=f"default flag threshold ({defaults.min_cycles:g} cycles)",
    )
    cyc_ax.set_ylim(bottom=0.0)
    # as the default (AutoLocator), but a panel too short for two tick labels gets one
    cyc_ax.yaxis.set_major_locator(MaxNLocator("auto", steps=[1, 2, 2.5, 5, 10], min_n_ticks=1))
    cyc_ax.set_ylabel("cycles in\nwindow", rotation=0, ha="right", va="center")
    handles: list[Any] = []
    labels: list[str] = []
    for ax in (dev_ax, r2_ax, cyc_ax):
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
        if ax is dev_ax:
            handles.append(Patch(color="C2", alpha=0.25))
            labels.append("σ of the key's combined period")
    if flags:
        handles.append(_ShortCode(""))
        labels.append("flags, under each trial:")
        handles += [_ShortCode(k.short) for k in flags]
        labels += [f"{k.code} ({k.n_trials})" for k in flags]
    assert isinstance(fig, LegendFittingFigure)
    fig.fitted_legend(
        handles, labels, loc="outside right upper", fontsize=7, handler_map={_ShortCode: _ShortCodeHandler()}
    )
    if ov.time_axis:
        cyc_ax.set_xlabel(f"trial start [{TIME_BASE}]")
    else:
        cyc_ax.set_xlabel("trial, in session order")
    return fig
