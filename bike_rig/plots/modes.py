"""Eigenvector components of one mode at one speed, as phasors (paper Fig 15).

One polar panel per bicycle. The eigenvector ``[φ, δ, φ̇, δ̇]`` is scaled so that the larger
angle component is 1 at 0° (:func:`.model_data.mode_shape`); the angles are drawn as solid
arrows from the origin. The rates (``λ`` times the angles) are drawn dashed and divided by
``|λ|`` so they share the angles' scale: a rate phasor is its angle phasor turned by ``arg λ``.
For a complex pair the member with ``Im λ > 0`` is drawn, so a component at a larger phase
leads (reaches its peak earlier).

The speed: as asked, or by default for ``capsize``/``caster`` each bicycle's own speed inside
the interval where the capsize and caster roots form the complex pair the paper's Fig 15 shows
(:func:`.model_data.capsize_caster_speed`, computed from its model; a bicycle without that pair,
e.g. with the rider, at :data:`FALLBACK_SPEED`), and for ``weave`` :data:`FALLBACK_SPEED`. Each
panel's title and the figure's title say which speed and why.

Every phasor is a line ``(0, 0) → (phase in rad, length)`` with ``gid``
``"<bicycle>:phasor:<component>"`` (0 roll angle, 1 steer angle, 2 roll rate, 3 steer rate).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from ..offline.subjects import Subject
from .eigen import panel_grid
from .model_data import ModeShape, capsize_caster_speed, mode_shape, rider_title
from .style import new_figure

__all__ = ["COMPONENT_COLOURS", "FALLBACK_SPEED", "default_mode_speed", "eigenvector_figure", "phasor_lengths"]

#: Colour of each component: roll (angle and rate) and steer (angle and rate).
COMPONENT_COLOURS = ("C0", "C3", "C0", "C3")
#: Speed of a mode's eigenvector when no better one is known, m/s (the weave, or a bicycle
#: without a capsize–caster complex pair).
FALLBACK_SPEED = 2.0
_PAIR_MODES = ("capsize", "caster")


def default_mode_speed(subject: Subject, mode: str = "capsize", rider: str = "") -> tuple[float, str]:
    """The speed to show ``mode``'s eigenvector at when none is asked for, and why.

    Args:
        subject: The bicycle.
        mode: ``weave``, ``capsize`` or ``caster``.
        rider: "" (none) or "paper".

    Returns:
        (speed in m/s, why in a few words, "" for the weave): for ``capsize``/``caster`` the
        middle of the bicycle's capsize–caster complex interval
        (:func:`.model_data.capsize_caster_speed`), else :data:`FALLBACK_SPEED`.

    Raises:
        ModelError: Unknown rider.
    """
    if mode not in _PAIR_MODES:
        return FALLBACK_SPEED, ""
    pair = capsize_caster_speed(subject, rider)
    if pair is None:
        return FALLBACK_SPEED, "no capsize–caster complex pair"
    _, (lo, hi) = pair
    return pair[0], f"capsize–caster pair from {lo:.2f} to {hi:.2f} m/s"


def _title_speeds(shapes: Sequence[ModeShape], reasons: Sequence[str]) -> str:
    """The speed part of the figure's title: one speed and why, or "each at its own speed"."""
    if len({sh.speed for sh in shapes}) == 1 and len(set(reasons)) == 1:
        why = f" ({reasons[0]})" if reasons[0] else ""
        return f"at {shapes[0].speed:g} m/s{why}"
    return "at each bicycle's own speed (panel titles)"


def phasor_lengths(shape: ModeShape) -> np.ndarray:
    """Drawn length of each phasor: ``|angle|`` for the angles, ``|rate| / |λ|`` for the rates.

    Args:
        shape: The mode's eigenvector.

    Returns:
        Shape (4,): roll and steer angle (rad), then roll and steer rate over ``|λ|`` (rad), per
        unit reference angle.
    """
    scale = abs(shape.eigenvalue) or 1.0
    mag = shape.magnitude
    return np.concatenate([mag[:2], mag[2:] / scale])


def eigenvector_figure(
    subjects: Sequence[Subject],
    mode: str = "capsize",
    speed: float | None = None,
    rider: str = "",
) -> Figure:
    """Phasor diagram of a mode's eigenvector for one or several bicycles (paper Fig 15).

    Args:
        subjects: The bicycles, one polar panel each.
        mode: ``weave``, ``capsize`` or ``caster`` (labels of the eigenvalue figure; inside a
            complex capsize–caster interval ``capsize`` and ``caster`` are the same pair).
        speed: Forward speed, m/s; None: each bicycle's :func:`default_mode_speed`.
        rider: "" (none) or "paper".

    Returns:
        The figure; each panel draws :func:`.model_data.mode_shape`.

    Raises:
        FigureInputError: No bicycles, unknown mode or bad speed.
        ModelError: Unknown rider.
    """
    chosen = [(speed, "") if speed is not None else default_mode_speed(s, mode, rider) for s in subjects]
    shapes = [mode_shape(s, mode, v, rider) for s, (v, _) in zip(subjects, chosen, strict=True)] if subjects else []
    reasons = [why for _, why in chosen]
    own_speeds = len(set(reasons)) > 1 or len({v for v, _ in chosen}) > 1
    rows, cols = panel_grid(len(shapes))
    fig = new_figure(3.6 * cols + 0.4, 3.6 * rows + 1.0)
    axes = fig.subplots(rows, cols, squeeze=False, subplot_kw={"projection": "polar"})
    for k, ax in enumerate(axes.flat):
        if k >= len(shapes):
            ax.set_visible(False)
            continue
        sh = shapes[k]
        lengths = phasor_lengths(sh)
        phases = np.angle(sh.components)
        for i, name in enumerate(sh.names):
            rate = i >= 2
            ax.plot(
                [0.0, phases[i]],
                [0.0, lengths[i]],
                color=COMPONENT_COLOURS[i],
                lw=1.2 if rate else 2.0,
                ls="--" if rate else "-",
                marker="o",
                markevery=[1],
                ms=3,
                label=f"{name} ÷ |λ|" if rate else name,
                gid=f"{sh.bicycle}:phasor:{i}",
            )
        ax.set_rmax(max(1.05, float(lengths.max()) * 1.05))
        ax.set_rlabel_position(135)
        ax.tick_params(labelsize=7)
        lam = sh.eigenvalue
        kind = "oscillatory" if sh.oscillatory else "real"
        sign = "+" if lam.imag >= 0 else "−"
        why = f"\n({reasons[k]})" if reasons[k] and own_speeds else ""
        ax.set_title(
            f"{sh.bicycle} at {sh.speed:g} m/s{why}\nλ = {lam.real:.2f} {sign} {abs(lam.imag):.2f}i 1/s ({kind})",
            fontsize=9,
        )
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=4 if cols > 1 else 2, fontsize=8, frameon=False)
    rider_text = rider_title(shapes[0].rider)
    fig.suptitle(
        f"Eigenvector of the {mode} mode {_title_speeds(shapes, reasons)}, {rider_text}\n"
        "(larger angle = 1 at 0°; counter-clockwise leads)",
        fontsize=10,
        wrap=True,
    )
    return fig
