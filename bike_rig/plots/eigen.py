"""Eigenvalues versus speed (paper Figs 13 and 16), with σ bands and the critical speeds marked.

One panel per bicycle (a grid for several), all on the same axes limits: real parts solid,
imaginary parts (``Im λ ≥ 0`` only, where the mode oscillates) dashed, coloured by mode; the
capsize–caster complex pair, where it exists, in its own colour over a light span; ±σ bands of
the real parts; the weave and capsize speeds as vertical lines with a ±σ span.

Every artist that carries data has a ``gid`` (``"<panel>:<what>"``) so tests can find it:
``re:<column>``, ``im:<column>``, ``band:<column>``, ``weave``, ``capsize``, ``weave-sigma``,
``capsize-sigma``, ``pair:<k>`` (span of the k-th complex capsize–caster interval) and
``re-pair:<column>`` (the pair's common real part, drawn over ``re:<column>`` there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import NDArray

from ..core.feedback import Feedback
from ..offline.subjects import Subject
from .model_data import COMPLEX_TOL, EigenCurves, FigureInputError, eigen_curves, rider_title
from .style import MODE_COLOURS, closed_loop_text, new_figure

__all__ = ["PAIR_COLOUR", "Y_LIMITS", "eigen_vs_speed", "panel_grid"]

#: Colour of the capsize–caster complex pair (its span and its imaginary part).
PAIR_COLOUR = "C4"
#: Vertical range of every panel, 1/s (as the paper's figures: the caster root leaves it).
Y_LIMITS = (-10.0, 10.0)


def panel_grid(n: int) -> tuple[int, int]:
    """Rows and columns of a grid of panels, up to 3 per row.

    Args:
        n: The number of panels (one per bicycle).

    Returns:
        (rows, columns).

    Raises:
        FigureInputError: ``n`` < 1.
    """
    if n < 1:
        raise FigureInputError("a figure needs at least one bicycle")
    cols = min(n, 3)
    return math.ceil(n / cols), cols


def _oscillating(z: NDArray[np.complex128]) -> NDArray[np.float64]:
    """``Im λ`` where it is > 0 (an oscillating mode's frequency, rad/s), NaN elsewhere."""
    osc = np.abs(z.imag) > COMPLEX_TOL * np.maximum(1.0, np.abs(z))
    return np.where(osc & (z.imag > 0.0), z.imag, np.nan)


def _draw_panel(ax: Axes, c: EigenCurves, bands: bool) -> None:
    v = c.speeds
    for k, (lo, hi) in enumerate(c.capsize_caster_complex):
        ax.axvspan(lo, hi, color=PAIR_COLOUR, alpha=0.08, lw=0, gid=f"{c.bicycle}:pair:{k}")
    for j, label in enumerate(c.labels):
        colour = MODE_COLOURS[label]
        z = c.eigenvalues[:, j]
        if bands:
            sig = c.sigma_real[:, j]
            ok = np.isfinite(sig)
            ax.fill_between(
                v,
                z.real - np.where(ok, sig, 0.0),
                z.real + np.where(ok, sig, 0.0),
                where=ok,
                color=colour,
                alpha=0.25,
                lw=0,
                gid=f"{c.bicycle}:band:{j}",
            )
        ax.plot(v, z.real, color=colour, lw=1.4, gid=f"{c.bicycle}:re:{j}")
        if label != "weave" and c.capsize_caster_complex:  # the pair's common real part
            pair = np.abs(z.imag) > COMPLEX_TOL * np.maximum(1.0, np.abs(z))
            ax.plot(v, np.where(pair, z.real, np.nan), color=PAIR_COLOUR, lw=1.6, gid=f"{c.bicycle}:re-pair:{j}")
        im = _oscillating(z)
        if label != "weave":  # capsize/caster oscillate only as their complex pair
            ax.plot(v, im, color=PAIR_COLOUR, lw=1.2, ls="--", gid=f"{c.bicycle}:im:{j}")
        else:
            ax.plot(v, im, color=colour, lw=1.2, ls="--", gid=f"{c.bicycle}:im:{j}")
    text = []
    for name, crit in (("weave", c.weave), ("capsize", c.capsize)):
        if crit is None or not (v[0] <= crit.speed <= v[-1]):
            text.append(f"$v_{{{name[0]}}}$: none in {v[0]:g}–{v[-1]:g} m/s")
            continue
        colour = MODE_COLOURS[name]
        if math.isfinite(crit.sigma):
            ax.axvspan(
                crit.speed - crit.sigma,
                crit.speed + crit.sigma,
                color=colour,
                alpha=0.18,
                lw=0,
                gid=f"{c.bicycle}:{name}-sigma",
            )
        ax.axvline(crit.speed, color=colour, lw=0.9, ls=":", gid=f"{c.bicycle}:{name}")
        sigma = f" ± {crit.sigma:.2f}" if math.isfinite(crit.sigma) else ""
        text.append(f"$v_{{{name[0]}}}$ = {crit.speed:.2f}{sigma} m/s")
    ax.text(
        0.98,
        0.97,
        "\n".join(text),
        transform=ax.transAxes,
        ha="right",
        va="top",
        fontsize=7.5,
        bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.8", "alpha": 0.9},
    )
    ax.axhline(0.0, color="0.3", lw=0.6)
    ax.set_ylim(*Y_LIMITS)
    ax.set_title(c.bicycle, fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)


def _legend(fig: Figure, bands: bool, any_pair: bool, cols: int) -> None:
    handles: list[Line2D | Patch] = [
        Line2D([], [], color=MODE_COLOURS["weave"], label="weave"),
        Line2D([], [], color=MODE_COLOURS["capsize"], label="capsize"),
        Line2D([], [], color=MODE_COLOURS["caster"], label="caster"),
        Line2D([], [], color="0.3", label="Re λ (solid)"),
        Line2D([], [], color="0.3", ls="--", label="Im λ > 0 (dashed)"),
    ]
    if any_pair:
        handles.append(Patch(color=PAIR_COLOUR, alpha=0.35, label="capsize–caster complex pair"))
    if bands:
        handles.append(Patch(color="0.5", alpha=0.35, label="±σ of Re λ"))
    handles.append(Line2D([], [], color="0.3", ls=":", label="weave / capsize speed (±σ span)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=4 if cols > 1 else 2, fontsize=8, frameon=False)


def eigen_vs_speed(
    subjects: Sequence[Subject],
    rider: str = "",
    speeds: NDArray[np.float64] | None = None,
    bands: bool = True,
    feedback: Feedback | None = None,
) -> Figure:
    """Eigenvalues versus speed for one or several bicycles (paper Figs 13 and 16).

    Args:
        subjects: The bicycles, one panel each (up to three panels per row, shared axes).
        rider: "" (none) or "paper" (the paper's Table 1 rider).
        speeds: Speeds, m/s (default 0 to 10 m/s in 0.02 m/s steps).
        bands: Draw ±σ bands of the real parts (first-order, from the parameter covariance;
            left out near branch points where the linearisation fails).
        feedback: Steer-torque state feedback: the closed loop's eigenvalues (the title
            names it); None: the open loop.

    Returns:
        The figure (Agg canvas). Each panel's data are :func:`.model_data.eigen_curves`.

    Raises:
        FigureInputError: No bicycles or bad speeds.
        ModelError: Unknown rider.
    """
    curves = [eigen_curves(s, rider, speeds, feedback=feedback) for s in subjects] if subjects else []
    rows, cols = panel_grid(len(curves))
    fig = new_figure(4.2 * cols + 0.6, 3.3 * rows + 0.9)
    axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= len(curves):
            ax.set_visible(False)
            continue
        _draw_panel(ax, curves[k], bands)
        if k % cols == 0:
            ax.set_ylabel("eigenvalue (1/s)")
        if k >= len(curves) - cols:
            ax.set_xlabel("speed v (m/s)")
    rider_text = rider_title(curves[0].rider) + closed_loop_text(curves[0].feedback)
    fig.suptitle(f"Eigenvalues versus speed, {rider_text}", fontsize=11)
    _legend(fig, bands, any(c.capsize_caster_complex for c in curves), cols)
    return fig
