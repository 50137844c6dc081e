"""Frequency response (Bode magnitude and phase) at one or several speeds (paper Figs 17 and 18).

Per speed a column of two panels sharing the frequency axis (log scale, rad/s): magnitude in dB
relative to one output unit per N m, and the phase in degrees (unwrapped along frequency), one
line per bicycle. Any input/output pair of :mod:`bike_rig.core.frequency`; the paper shows steer
torque → roll angle at 2 m/s (the default).

Curves of different bicycles often lie on each other (the paper's Browser and Browserins), so
each bicycle has its own colour, line style, marker and width (:func:`.style.bicycle_line_style`;
the same in every panel) and one legend below the panels names them.

Each line has ``gid`` ``"<bicycle>:magnitude"`` or ``"<bicycle>:phase"`` at one speed, and
``"<bicycle>:magnitude:<v>"`` / ``"<bicycle>:phase:<v>"`` (``v`` in m/s, ``%g``) at several.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ..core.frequency import output_unit
from ..subjects import Subject
from .model_data import BodeCurves, FigureInputError, bode_curves
from .style import bicycle_line_style, new_figure

__all__ = ["PAPER_BODE_SPEED", "bode_figure", "speeds_text"]

#: The speed of the paper's Figs 17 and 18, m/s.
PAPER_BODE_SPEED = 2.0
_RIDER_TEXT = {"": "without rider", "paper": "with the paper's rider"}


def speeds_text(speeds: Sequence[float]) -> str:
    """``[2.0]`` → ``"2 m/s"``, ``[2.0, 5.0]`` → ``"2 and 5 m/s"``, ``[1, 2, 3]`` → ``"1, 2 and 3 m/s"``."""
    names = [f"{v:g}" for v in speeds]
    joined = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"{joined} m/s"


def _speeds(speed: float | Sequence[float]) -> list[float]:
    speeds = [float(v) for v in speed] if isinstance(speed, Sequence) else [float(speed)]
    if not speeds:
        raise FigureInputError("a Bode figure needs at least one speed")
    return list(dict.fromkeys(speeds))


def bode_figure(
    subjects: Sequence[Subject],
    speed: float | Sequence[float] = PAPER_BODE_SPEED,
    rider: str = "",
    input: str = "steer torque",
    output: str = "roll angle",
    omega: NDArray[np.float64] | None = None,
) -> Figure:
    """Bode diagram of ``input → output`` for one or several bicycles, one column per speed.

    Args:
        subjects: The bicycles, one line each.
        speed: Forward speed, m/s, or several (one column each, in the order given); default
            the paper's 2 m/s.
        rider: "" (none) or "paper".
        input: ``roll torque`` or ``steer torque``.
        output: ``roll angle``, ``steer angle``, ``roll rate`` or ``steer rate``.
        omega: Angular frequencies, rad/s (default 0.1 to 100 rad/s, log-spaced).

    Returns:
        The figure; each line draws :func:`.model_data.bode_curves`. The title names the speeds.

    Raises:
        FigureInputError: No bicycles, no speed, unknown input or output, bad speed or
            frequencies.
        ModelError: Unknown rider.
    """
    if not subjects:
        raise FigureInputError("a figure needs at least one bicycle")
    speeds = _speeds(speed)
    columns = [[bode_curves(s, v, rider, input, output, omega) for s in subjects] for v in speeds]
    n = len(subjects)
    fig = new_figure(max(7.5, 1.5 + 5.0 * len(speeds)), 6.0 + 0.25 * ((n + 3) // 4))
    axes = fig.subplots(2, len(speeds), sharex=True, sharey="row", squeeze=False)
    for col, (v, curves) in enumerate(zip(speeds, columns, strict=True)):
        _draw_column(axes[0, col], axes[1, col], curves, f":{v:g}" if len(speeds) > 1 else "")
        if len(speeds) > 1:
            axes[0, col].set_title(f"{v:g} m/s", fontsize=10)
        axes[1, col].set_xlabel("frequency ω (rad/s)")
    axes[0, 0].set_ylabel(f"magnitude (dB re 1 {output_unit(output)})")
    axes[1, 0].set_ylabel("phase (deg)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(n, 4), fontsize=8, frameon=False)
    first = columns[0][0]
    rider_text = _RIDER_TEXT.get(first.rider, first.rider)
    fig.suptitle(f"{input} → {output} at {speeds_text(speeds)}, {rider_text}", fontsize=11)
    return fig


def _draw_column(ax_mag: Axes, ax_ph: Axes, curves: Sequence[BodeCurves], suffix: str) -> None:
    """One speed's magnitude and phase panels, a line per bicycle (``suffix`` ends the gids)."""
    for k, c in enumerate(curves):
        style = bicycle_line_style(k, len(curves), c.omega.size).kwargs()
        ax_mag.plot(c.omega, c.magnitude_db, label=c.bicycle, gid=f"{c.bicycle}:magnitude{suffix}", **style)
        ax_ph.plot(c.omega, c.phase_deg, gid=f"{c.bicycle}:phase{suffix}", **style)
    for ax in (ax_mag, ax_ph):
        ax.set_xscale("log")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
