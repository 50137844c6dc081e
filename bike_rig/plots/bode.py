"""Frequency response (Bode magnitude and phase) at one speed (paper Figs 17 and 18).

Two panels sharing the frequency axis (log scale, rad/s): magnitude in dB relative to one
output unit per N m, and the phase in degrees (unwrapped along frequency), one line per
bicycle in :func:`.style.bicycle_colour` order. Any input/output pair of
:mod:`bike_rig.core.frequency`; the paper shows steer torque → roll angle at 2 m/s.

Each line has ``gid`` ``"<bicycle>:magnitude"`` or ``"<bicycle>:phase"``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ..core.frequency import output_unit
from ..subjects import Subject
from .model_data import FigureInputError, bode_curves
from .style import bicycle_colour, new_figure

__all__ = ["bode_figure"]

_RIDER_TEXT = {"": "without rider", "paper": "with the paper's rider"}


def bode_figure(
    subjects: Sequence[Subject],
    speed: float = 2.0,
    rider: str = "",
    input: str = "steer torque",
    output: str = "roll angle",
    omega: NDArray[np.float64] | None = None,
) -> Figure:
    """Bode diagram of ``input → output`` at ``speed`` for one or several bicycles.

    Args:
        subjects: The bicycles, one line each.
        speed: Forward speed, m/s.
        rider: "" (none) or "paper".
        input: ``roll torque`` or ``steer torque``.
        output: ``roll angle``, ``steer angle``, ``roll rate`` or ``steer rate``.
        omega: Angular frequencies, rad/s (default 0.1 to 100 rad/s, log-spaced).

    Returns:
        The figure; each line draws :func:`.model_data.bode_curves`.

    Raises:
        FigureInputError: No bicycles, unknown input or output, bad speed or frequencies.
        ModelError: Unknown rider.
    """
    if not subjects:
        raise FigureInputError("a figure needs at least one bicycle")
    curves = [bode_curves(s, speed, rider, input, output, omega) for s in subjects]
    fig = new_figure(7.5, 6.0)
    ax_mag, ax_ph = fig.subplots(2, 1, sharex=True)
    for k, c in enumerate(curves):
        colour = bicycle_colour(k)
        ax_mag.plot(c.omega, c.magnitude_db, color=colour, lw=1.3, label=c.bicycle, gid=f"{c.bicycle}:magnitude")
        ax_ph.plot(c.omega, c.phase_deg, color=colour, lw=1.3, gid=f"{c.bicycle}:phase")
    for ax in (ax_mag, ax_ph):
        ax.set_xscale("log")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax_mag.set_ylabel(f"magnitude (dB re 1 {output_unit(output)})")
    ax_ph.set_ylabel("phase (deg)")
    ax_ph.set_xlabel("frequency ω (rad/s)")
    ax_mag.legend(fontsize=8, ncols=2 if len(curves) > 4 else 1)
    rider_text = _RIDER_TEXT.get(curves[0].rider, curves[0].rider)
    fig.suptitle(f"{input} → {output} at {curves[0].speed:g} m/s, {rider_text}", fontsize=11)
    return fig
