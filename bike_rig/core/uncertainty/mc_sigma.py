"""The parameters' σ to print: a seeded Monte Carlo σ wherever the linear σ misjudges it.

First-order propagation holds while the formulas are nearly linear over the readings' σ; two
hanging lines of a part closer than :data:`NEAR_PARALLEL_DEG` (a nearly singular intersection),
or angle and distance σ large against the lines' spread, break that. So the raw readings are
always drawn as a check (:data:`MC_SAMPLES` seeded normal draws), and every parameter whose Monte
Carlo σ departs from the linear σ by more than :data:`MC_DEPARTURE` (four times the draws' own
relative error) gets the Monte Carlo σ; so does the mass centre that nearly parallel lines locate
(``xB, zB`` for the frame, ``xH, zH`` for the fork or its parts S and G).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .. import com
from ..benchmark import ComMethod, monte_carlo_parameters
from ..measurements import PART_NAMES, Measurements, hung_parts
from .uncertain import UncertainVector

__all__ = [
    "MC_DEPARTURE",
    "MC_SAMPLES",
    "MC_SEED",
    "NEAR_PARALLEL_DEG",
    "PrintedSigmas",
    "line_angles",
    "printed_sigmas",
]

#: Hanging lines closer than this (degrees) call for the Monte Carlo σ.
NEAR_PARALLEL_DEG = 10.0

#: Seeded draws of the Monte Carlo, and the σ ratio departure from which its σ is printed.
MC_SAMPLES = 20000
MC_SEED = 1
MC_DEPARTURE = 0.02

#: The benchmark mass-centre coordinates each hung part's lines locate.
_LOCATED = {"B": ("xB", "zB"), "H": ("xH", "zH"), "S": ("xH", "zH"), "G": ("xH", "zH")}


@dataclass(frozen=True)
class PrintedSigmas:
    """The σ to print for each parameter and where it came from.

    Attributes:
        sigma: ``{parameter: σ}`` (parameter unit), the linear σ unless named in ``monte_carlo``.
        monte_carlo: The parameters whose σ is the Monte Carlo one.
        linear: ``{parameter: linear σ}`` of the parameters in ``monte_carlo``.
        near_parallel: ``{part letter: smallest angle between its hanging lines (deg)}`` of the
            parts below :data:`NEAR_PARALLEL_DEG`.
    """

    sigma: dict[str, float]
    monte_carlo: frozenset[str]
    linear: dict[str, float]
    near_parallel: dict[str, float]

    def note(self) -> str | None:
        """The footnote for the Monte Carlo σ, or None when none is printed."""
        if not self.monte_carlo:
            return None
        if self.near_parallel:
            parts = ", ".join(f"{PART_NAMES[p]} {deg:.1f}°" for p, deg in self.near_parallel.items())
            why = f"nearly parallel hanging lines: {parts}"
        else:
            why = f"the linear σ departs from it by more than {100 * MC_DEPARTURE:g} %"
        return f"σ from a {MC_SAMPLES:,}-draw Monte Carlo ({why})"


def line_angles(m: Measurements) -> dict[str, float]:
    """``{part letter: smallest angle between the part's hanging lines (deg)}`` for each hung part."""
    out = {}
    for part in hung_parts(m.readings):
        slopes = [math.tan(math.radians(m.value(f"alpha{part}{i}"))) for i in m.orientations(part)]
        out[part] = math.degrees(com.line_conditioning(slopes).min_angle)
    return out


def printed_sigmas(
    m: Measurements,
    linear: UncertainVector,
    method: ComMethod = ComMethod.CENTROID,
    lump_flywheel: bool = False,
) -> PrintedSigmas:
    """The σ to print per parameter: Monte Carlo where it departs from the linear σ (module docstring).

    Args:
        m: The raw readings the parameters were computed from.
        linear: The linearly propagated parameters.
        method: The mass-centre method they were computed with.
        lump_flywheel: As they were computed.

    Returns:
        The Monte Carlo σ (:data:`MC_SAMPLES` seeded draws through the raw readings) for each
        parameter whose σ departs from the linear σ by more than :data:`MC_DEPARTURE`, and for
        the mass centre of each part whose lines are under :data:`NEAR_PARALLEL_DEG` apart;
        the linear σ elsewhere.
    """
    sigma = {n: linear.sigma(n) for n in linear.names}
    near = {p: deg for p, deg in line_angles(m).items() if deg < NEAR_PARALLEL_DEG}
    in_key_order = dataclasses.replace(m, readings=dict(sorted(m.readings.items())))  # same draws, any file format
    draws = monte_carlo_parameters(in_key_order, MC_SAMPLES, MC_SEED, method, lump_flywheel)
    located = {n for p in near for n in _LOCATED[p]}
    chosen, lin = set(), {}
    for name, s in list(sigma.items()):
        if s > 0.0 and name in draws:
            s_mc = float(np.std(draws[name], ddof=1))
            if math.isfinite(s_mc) and (name in located or abs(s_mc / s - 1.0) > MC_DEPARTURE):
                chosen.add(name)
                lin[name] = s
                sigma[name] = s_mc
    return PrintedSigmas(sigma, frozenset(chosen), lin, near)
