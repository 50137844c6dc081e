"""Frequency response (Bode magnitude and phase) at one or several speeds (paper Figs 17 and 18).

Two panels sharing the frequency axis (log scale, rad/s): magnitude in dB relative to one output
unit per N m, and the phase in degrees (unwrapped along frequency), one line per bicycle and
speed. Any input/output pair of :mod:`bike_rig.core.frequency`; the paper shows steer torque →
roll angle at 2 m/s (the default).

Curves often lie on each other (the paper's Browser and Browserins), so each line has its own
colour, line style, marker and width (:func:`.style.bicycle_line_style`; the same in both
panels) and one legend below the panels names them.

Each line has ``gid`` ``"<bicycle>:magnitude"`` or ``"<bicycle>:phase"`` at one speed, and
``"<bicycle>:magnitude:<v>"`` / ``"<bicycle>:phase:<v>"`` (``v`` in m/s, ``%g``) at several.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ..core.feedback import Feedback
from ..core.frequency import output_unit
from ..offline.subjects import Subject
from .model_data import BodeCurves, FigureInputError, bode_curves, rider_title
from .style import bicycle_line_style, closed_loop_text, new_figure

__all__ = ["PAPER_BODE_SPEED", "bode_figure", "speeds_text"]

#: The speed of the paper's Figs 17 and 18, m/s.
PAPER_BODE_SPEED = 2.0


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


def _label(curve: BodeCurves, bicycles: int, speeds: int) -> str:
    """A curve's legend label: the bicycle, its speed, or both (whatever tells the curves apart)."""
    if speeds == 1:
        return curve.bicycle
    return f"{curve.speed:g} m/s" if bicycles == 1 else f"{curve.bicycle}, {curve.speed:g} m/s"


def bode_figure(
    subjects: Sequence[Subject],
    speed: float | Sequence[float] = PAPER_BODE_SPEED,
    rider: str = "",
    input: str = "steer torque",
    output: str = "roll angle",
    omega: NDArray[np.float64] | None = None,
    feedback: Feedback | None = None,
) -> Figure:
    """Bode diagram of ``input → output`` for one or several bicycles at one or several speeds.

    Args:
        subjects: The bicycles, one line each per speed.
        speed: Forward speed, m/s, or several (the lines of each bicycle in the order given);
            default the paper's 2 m/s.
        rider: "" (none) or "paper".
        input: ``roll torque`` or ``steer torque``.
        output: ``roll angle``, ``steer angle``, ``roll rate`` or ``steer rate``.
        omega: Angular frequencies, rad/s (default 0.1 to 100 rad/s, log-spaced).
        feedback: Steer-torque state feedback: the closed loop's response (the title names
            it); None: the open loop.

    Returns:
        The figure; each line draws :func:`.model_data.bode_curves`, with its own style
        (:func:`.style.bicycle_line_style`) and a legend entry naming its bicycle and, with
        several speeds, its speed. The title names the speeds.

    Raises:
        FigureInputError: No bicycles, no speed, unknown input or output, bad speed or
            frequencies.
        ModelError: Unknown rider.
    """
    if not subjects:
        raise FigureInputError("a figure needs at least one bicycle")
    speeds = _speeds(speed)
    curves = [bode_curves(s, v, rider, input, output, omega, feedback) for s in subjects for v in speeds]
    fig = new_figure(7.5, 6.0 + 0.25 * ((len(curves) + 3) // 4))
    ax_mag, ax_ph = fig.subplots(2, 1, sharex=True)
    for k, c in enumerate(curves):
        style = bicycle_line_style(k, len(curves), c.omega.size).kwargs()
        suffix = f":{c.speed:g}" if len(speeds) > 1 else ""
        label = _label(c, len(subjects), len(speeds))
        ax_mag.plot(c.omega, c.magnitude_db, label=label, gid=f"{c.bicycle}:magnitude{suffix}", **style)
        ax_ph.plot(c.omega, c.phase_deg, gid=f"{c.bicycle}:phase{suffix}", **style)
    for ax in (ax_mag, ax_ph):
        ax.set_xscale("log")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax_mag.set_ylabel(f"magnitude (dB re 1 {output_unit(output)})")
    ax_ph.set_ylabel("phase (deg)")
    ax_ph.set_xlabel("frequency ω (rad/s)")
    handles, labels = ax_mag.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(curves), 4), fontsize=8, frameon=False)
    rider_text = rider_title(curves[0].rider) + closed_loop_text(curves[0].feedback)
    fig.suptitle(f"{input} → {output} at {speeds_text(speeds)}, {rider_text}", fontsize=11)
    return fig
