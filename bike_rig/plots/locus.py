"""Root locus with speed as the parameter (paper Fig 14).

One panel per bicycle: every eigenvalue ``λ(v)`` in the complex plane (Re λ across, Im λ up,
1/s), each point coloured by its speed on one shared colour scale, with a black marker and
label at every whole m/s (labels on the weave branch with ``Im λ ≥ 0`` and on the
capsize–caster pair with ``Im λ > 0``).

Every data-carrying artist has a ``gid``: ``"<bicycle>:locus:<column>"`` (a scatter whose
offsets are ``(Re λ, Im λ)`` and whose colour array is the speed) and
``"<bicycle>:ticks:<column>"`` (the whole-speed markers).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ..core.feedback import Feedback
from ..offline.subjects import Subject
from .eigen import panel_grid
from .model_data import eigen_curves, rider_title
from .style import closed_loop_text, new_figure

__all__ = ["X_LIMITS", "root_locus"]

#: Real-axis range of every panel, 1/s (the fast caster root leaves it at higher speed).
X_LIMITS = (-10.0, 6.0)


def root_locus(
    subjects: Sequence[Subject],
    rider: str = "",
    speeds: NDArray[np.float64] | None = None,
    feedback: Feedback | None = None,
) -> Figure:
    """Root loci of one or several bicycles, speed as the parameter (paper Fig 14).

    Args:
        subjects: The bicycles, one panel each (up to three per row, shared axes).
        rider: "" (none) or "paper".
        speeds: Speeds, m/s (default 0 to 10 m/s in 0.02 m/s steps).
        feedback: Steer-torque state feedback: the closed loop's loci; None: the open loop.

    Returns:
        The figure; each panel draws :func:`.model_data.eigen_curves` (without σ bands).

    Raises:
        FigureInputError: No bicycles or bad speeds.
        ModelError: Unknown rider.
    """
    curves = [eigen_curves(s, rider, speeds, feedback=feedback) for s in subjects] if subjects else []
    rows, cols = panel_grid(len(curves))
    fig = new_figure(4.2 * cols + 1.2, 3.6 * rows + 0.6)
    axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    vmax = max(float(c.speeds[-1]) for c in curves)
    norm = Normalize(vmin=min(float(c.speeds[0]) for c in curves), vmax=vmax)
    scatter = None
    for k, ax in enumerate(axes.flat):
        if k >= len(curves):
            ax.set_visible(False)
            continue
        c = curves[k]
        whole = np.flatnonzero(np.isclose(c.speeds, np.round(c.speeds), atol=1e-9))
        for j in range(c.eigenvalues.shape[1]):
            z = c.eigenvalues[:, j]
            scatter = ax.scatter(
                z.real, z.imag, c=c.speeds, cmap="viridis", norm=norm, s=3, lw=0, gid=f"{c.bicycle}:locus:{j}"
            )
            zw = z[whole]
            ax.plot(zw.real, zw.imag, "o", ms=3, mfc="none", mec="k", mew=0.6, gid=f"{c.bicycle}:ticks:{j}")
            if j in (0, 2):  # label the weave (Im ≥ 0) and the capsize–caster pair (Im > 0)
                for i, zi in zip(whole, zw):
                    shown = zi.imag >= 0.0 if j == 0 else zi.imag > 0.0
                    if shown and X_LIMITS[0] <= zi.real <= X_LIMITS[1]:
                        ax.annotate(
                            f"{c.speeds[i]:g}",
                            (zi.real, zi.imag),
                            xytext=(3, 2),
                            textcoords="offset points",
                            fontsize=6,
                            color="0.25",
                        )
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.axvline(0.0, color="0.3", lw=0.6)
        ax.set_xlim(*X_LIMITS)
        ax.set_title(c.bicycle, fontsize=10)
        ax.grid(True, lw=0.3, alpha=0.5)
        if k % cols == 0:
            ax.set_ylabel("Im λ (rad/s)")
        if k >= len(curves) - cols:
            ax.set_xlabel("Re λ (1/s)")
    if scatter is not None:
        fig.colorbar(scatter, ax=axes, label="speed v (m/s); markers every 1 m/s", shrink=0.8)
    rider_text = rider_title(curves[0].rider) + closed_loop_text(curves[0].feedback)
    fig.suptitle(f"Root locus, speed as the parameter, {rider_text}", fontsize=11)
    return fig
