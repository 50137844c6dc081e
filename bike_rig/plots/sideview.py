"""Side view of one or several bicycles in the benchmark geometry.

Wheels, ground, steer axis and the mass centres of the rear wheel, the frame B, the fork H, the
front wheel and the whole bicycle, each with its uncertainty ellipse propagated from the
parameter covariance.

The benchmark frame has x forward and z **down**, origin at the rear contact point; the figure
draws height ``y = -z`` upward. Mass-centre uncertainties are millimetres on a metre-sized
bicycle, so the ellipses are drawn magnified by one stated factor (the legend says which).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Ellipse, Patch
from numpy.typing import NDArray

from ..core.benchmark import ParameterSet
from ..core.uncertainty.uncertain import complex_step_jacobian
from ..offline.subjects import Subject
from .style import bicycle_colour, new_figure

__all__ = [
    "ELLIPSE_SIGMA",
    "MASS_CENTRE_LABELS",
    "MassCentre",
    "ellipse_axes",
    "ellipse_magnification",
    "mass_centres",
    "side_view",
]

FloatArray = NDArray[np.float64]

#: The ellipses enclose this many standard deviations (1σ: ~39 % of a 2-D normal).
ELLIPSE_SIGMA = 1.0
#: Mass centres drawn, in order, with their legend label and marker.
MASS_CENTRE_LABELS: Mapping[str, tuple[str, str]] = {
    "R": ("rear wheel", "o"),
    "B": ("frame B", "s"),
    "H": ("fork H", "^"),
    "F": ("front wheel", "D"),
    "T": ("whole bicycle", "*"),
}
#: Magnification factors the ellipses may be drawn with (1, 2, 5 × powers of ten).
_STEPS = (1.0, 2.0, 5.0)
#: The largest drawn semi-axis aims at about this length on the drawing, m.
_TARGET_SEMI_AXIS_M = 0.06


@dataclass(frozen=True)
class MassCentre:
    """One mass centre in drawing coordinates (x forward, y = −z up), with its covariance.

    Attributes:
        key: ``R``, ``B``, ``H``, ``F`` or ``T`` (the whole bicycle).
        x: Forward position, m from the rear contact point.
        y: Height above the ground, m.
        covariance: Covariance of (x, y), m², from the parameter covariance (linear).
    """

    key: str
    x: float
    y: float
    covariance: FloatArray


def _centres(p: Mapping[str, Any]) -> dict[str, Any]:
    """Mass-centre coordinates (drawing frame) from the parameters; complex-step safe."""
    m = p["mR"] + p["mB"] + p["mH"] + p["mF"]
    z_total = (-p["mR"] * p["rR"] + p["mB"] * p["zB"] + p["mH"] * p["zH"] - p["mF"] * p["rF"]) / m
    return {
        "R_x": 0.0 * p["w"],
        "R_y": p["rR"],
        "B_x": p["xB"],
        "B_y": -p["zB"],
        "H_x": p["xH"],
        "H_y": -p["zH"],
        "F_x": p["w"],
        "F_y": p["rF"],
        "T_x": (p["mB"] * p["xB"] + p["mH"] * p["xH"] + p["mF"] * p["w"]) / m,
        "T_y": -z_total,
    }


def mass_centres(ps: ParameterSet) -> tuple[MassCentre, ...]:
    """The five mass centres of a bicycle with their (x, y) covariance.

    The covariance is ``J Σ Jᵀ`` with ``Σ`` the full parameter covariance, so correlations
    between (for example) xB and zB from the hanging-line intersection are kept.

    Args:
        ps: The bicycle's parameters with their covariance.

    Returns:
        One :class:`MassCentre` per :data:`MASS_CENTRE_LABELS` key, in that order (m, m²).
    """
    pv = ps.parameters
    names = tuple(pv.names)
    prop = complex_step_jacobian(_centres, pv.as_dict(), names)
    cov = prop.covariance(np.asarray(pv.covariance, dtype=float))
    index = {n: i for i, n in enumerate(prop.names)}
    out = []
    for key in MASS_CENTRE_LABELS:
        ix, iy = index[f"{key}_x"], index[f"{key}_y"]
        sub = np.array([[cov[ix, ix], cov[ix, iy]], [cov[iy, ix], cov[iy, iy]]])
        out.append(MassCentre(key, float(prop.values[ix]), float(prop.values[iy]), sub))
    return tuple(out)


def ellipse_axes(covariance: FloatArray, n_sigma: float = ELLIPSE_SIGMA) -> tuple[float, float, float]:
    """Semi-major axis, semi-minor axis (m) and angle of the major axis (degrees from +x).

    From the eigen-decomposition of the 2×2 ``covariance`` (m²): semi-axes ``n_sigma √λ``.

    Args:
        covariance: The (x, y) covariance, m².
        n_sigma: The ellipse's size in standard deviations.

    Returns:
        (semi-major axis m, semi-minor axis m, angle of the major axis in degrees from +x).
    """
    vals, vecs = np.linalg.eigh(np.asarray(covariance, dtype=float))
    vals = np.clip(vals, 0.0, None)
    major = vecs[:, 1]
    angle = math.degrees(math.atan2(float(major[1]), float(major[0])))
    return n_sigma * math.sqrt(float(vals[1])), n_sigma * math.sqrt(float(vals[0])), angle


def ellipse_magnification(largest_semi_axis_m: float) -> float:
    """The factor (1, 2, 5 × 10ⁿ, at least 1) that draws the largest semi-axis at about 6 cm.

    Args:
        largest_semi_axis_m: The largest semi-axis of the figure's ellipses, m.

    Returns:
        The magnification (1 for a zero or non-finite axis).
    """
    if not largest_semi_axis_m > 0 or not math.isfinite(largest_semi_axis_m):
        return 1.0
    want = _TARGET_SEMI_AXIS_M / largest_semi_axis_m
    if want <= 1.0:
        return 1.0
    best = 1.0
    for decade in range(0, 7):
        for step in _STEPS:
            f = step * 10.0**decade
            if f <= want:
                best = f
    return best


def _steer_axis(values: Mapping[str, float], top_y: float) -> tuple[list[float], list[float]]:
    """The steer axis from the ground (x = w + c) up to height ``top_y``, tilted back by λ."""
    x0 = values["w"] + values["c"]
    lam = values["lam"]
    return [x0, x0 - top_y * math.tan(lam)], [0.0, top_y]


def side_view(subjects: Sequence[Subject]) -> Figure:
    """Side view of each bicycle, overlaid, one colour per bicycle.

    Draws the ground, both wheels (radius rR and rF, centres at height rR and rF), the steer
    axis (through the ground point a trail c ahead of the front contact, tilted back by λ
    from vertical) and the five mass centres, each with its 1σ uncertainty ellipse from the
    parameter covariance, magnified by a factor stated in the legend.

    Args:
        subjects: The bicycles (at least one).

    Returns:
        The figure; every ellipse has the gid ``ellipse:<bicycle index>:<key>`` and every mass
        centre marker ``centre:<bicycle index>:<key>`` (keys as in :data:`MASS_CENTRE_LABELS`).
    """
    if not subjects:
        raise ValueError("side_view needs at least one bicycle")
    fig = new_figure(10.0, 5.0)
    ax = fig.add_subplot()
    all_centres = [mass_centres(s.parameters) for s in subjects]
    largest = max(ellipse_axes(c.covariance)[0] for cs in all_centres for c in cs)
    mag = ellipse_magnification(largest)
    x_lo, x_hi, y_hi = 0.0, 0.0, 0.0
    for i, (subject, centres) in enumerate(zip(subjects, all_centres)):
        colour = bicycle_colour(i)
        v = subject.parameters.values()
        rR, rF, w = v["rR"], v["rF"], v["w"]
        ax.add_patch(Circle((0.0, rR), rR, fill=False, edgecolor=colour, linewidth=1.4, gid=f"wheel:{i}:R"))
        ax.add_patch(Circle((w, rF), rF, fill=False, edgecolor=colour, linewidth=1.4, gid=f"wheel:{i}:F"))
        top = max(2.0 * rF, -v["zH"], -v["zB"]) + 0.25
        sx, sy = _steer_axis(v, top)
        ax.plot(sx, sy, "-.", color=colour, linewidth=1.0, gid=f"steer:{i}")
        for c in centres:
            label, marker = MASS_CENTRE_LABELS[c.key]
            size = 10 if c.key == "T" else 5
            ax.plot(
                [c.x],
                [c.y],
                marker,
                color=colour,
                markersize=size,
                markeredgecolor="k",
                markeredgewidth=0.5,
                zorder=4,
                gid=f"centre:{i}:{c.key}",
            )
            a, b, angle = ellipse_axes(c.covariance)
            ax.add_patch(
                Ellipse(
                    (c.x, c.y),
                    2 * a * mag,
                    2 * b * mag,
                    angle=angle,
                    facecolor=colour,
                    alpha=0.3,
                    edgecolor=colour,
                    linewidth=0.8,
                    zorder=3,
                    gid=f"ellipse:{i}:{c.key}",
                )
            )
        x_lo = min(x_lo, -rR, sx[1])
        x_hi = max(x_hi, w + rF, sx[0])
        y_hi = max(y_hi, top)
    ax.axhline(0.0, color="0.3", linewidth=1.0)
    ax.set_ylim(-0.05, y_hi + 0.05)
    ax.set_xlim(x_lo - 0.1, x_hi + 0.1)
    ax.set_autoscalex_on(True)  # x widens as the aspect needs: no warning about fixed limits
    ax.set_aspect("equal", adjustable="datalim")  # the box keeps the layout's margins: labels stay inside
    ax.set_xlabel("x, forward from the rear contact [m]")
    ax.set_ylabel("height above the ground [m]")
    sigma_text = f"{ELLIPSE_SIGMA:g}σ ellipses, drawn ×{mag:g}\n(largest semi-axis {largest * 1e3:.1f} mm)"
    handles: list[Any] = [
        Line2D([], [], color=bicycle_colour(i), linewidth=2, label=s.name) for i, s in enumerate(subjects)
    ]
    handles += [
        Line2D([], [], linestyle="", marker=m, color="0.6", markeredgecolor="k", label=lab)
        for lab, m in MASS_CENTRE_LABELS.values()
    ]
    handles.append(Line2D([], [], linestyle="-.", color="0.3", label="steer axis"))
    handles.append(Patch(facecolor="0.6", alpha=0.4, label=sigma_text))
    fig.legend(handles=handles, loc="outside right upper", fontsize=7)
    names = ", ".join(s.name for s in subjects)
    ax.set_title(f"Side view (benchmark geometry): {names}", fontsize=10)
    return fig
