"""Plain-text tables for the terminal: values with σ rounded the way the paper prints them.

Names that come from files (the bicycle, its source) are written with their control characters
escaped (:func:`~bike_rig.core.textfmt.terminal_safe`), whoever prints the table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..core.benchmark import PARAMETER_NAMES, ComEstimate, ParameterSet
from ..core.textfmt import LABELS, TABLE2_ORDER, format_uncertain, format_value_sigma, terminal_safe
from ..core.uncertainty.matrix_sigma import MatrixSet
from ..core.uncertainty.mc_sigma import PrintedSigmas
from ..core.uncertainty.uncertain import UncertainVector
from ..core.whipple import CriticalSpeeds

__all__ = [
    "LABELS",
    "TABLE2_ORDER",
    "eigen_table",
    "format_value_sigma",
    "matrix_table",
    "parameter_table",
    "part_table",
    "speeds_summary",
]


def parameter_table(ps: ParameterSet, sigmas: PrintedSigmas | None = None) -> str:
    """The parameters as the paper's Table 2: symbol, unit, value, σ.

    With ``sigmas``, its σ is printed; a Monte Carlo σ is marked ``*`` and explained below the table.
    """
    assert set(TABLE2_ORDER) == set(PARAMETER_NAMES)
    title = f"{terminal_safe(ps.bicycle, keep='')}: benchmark parameters (from {terminal_safe(ps.source, keep='')})"
    rows = [title, f"{'parameter':<16}{'value':>12}{'σ':>10}"]
    pv = ps.parameters
    for key in TABLE2_ORDER:
        label, unit = LABELS[key]
        mc = sigmas is not None and key in sigmas.monte_carlo
        v, s = format_value_sigma(pv.value(key), sigmas.sigma[key] if sigmas is not None else pv.sigma(key))
        rows.append(f"{label + ' [' + unit + ']':<16}{v:>12}{s:>10}" + ("*" if mc else ""))
    note = sigmas.note() if sigmas is not None else None
    if note:
        rows.append(f"* {note}")
    if ps.parts is not None:
        rows.append("")
        rows.append(part_table(ps.parts))
    if ps.com:
        rows.append("")
        rows.append(com_summary(ps.com))
    return "\n".join(rows)


#: Names and units of the per-part outputs' quantities (the part letter follows the first symbol).
_PART_QUANTITIES = {"m": ("mass", "kg"), "x": ("x", "m"), "z": ("z", "m"), "I": ("I", "kg m²")}
#: What each extra part is.
PART_TITLES = {"G": "handlebar G", "S": "fork S", "D": "flywheel D"}


def part_table(parts: UncertainVector) -> str:
    """The per-part outputs (fork S, handlebar G measured separately): value and σ per quantity."""
    rows = [f"per-part outputs ({', '.join(PART_TITLES[p] for p in dict.fromkeys(n[1] for n in parts.names))}):"]
    rows.append(f"{'quantity':<16}{'value':>12}{'σ':>10}")
    for name in parts.names:
        _label, unit = _PART_QUANTITIES[name[0]]
        v, s = format_value_sigma(parts.value(name), parts.sigma(name))
        rows.append(f"{name + ' [' + unit + ']':<16}{v:>12}{s:>10}")
    return "\n".join(rows)


def com_summary(coms: Mapping[str, ComEstimate]) -> str:
    """One line per part: both mass-centre solutions' σ and which is more accurate."""
    names = {"B": "rear frame", "H": "fork/handlebar", "S": "fork S", "G": "handlebar G"}
    lines = ["mass centres (x, z) [m], centroid Eq 17-19 vs least squares Eq 20:"]
    for part, est in coms.items():
        c, s = est.centroid, est.least_squares
        centroid = ", ".join(format_uncertain(v, e) for v, e in zip(c.values, c.sigmas, strict=True))
        lstsq = ", ".join(format_uncertain(v, e) for v, e in zip(s.values, s.sigmas, strict=True))
        lines.append(
            f"  {names[part]:<15} centroid ({centroid}); least squares ({lstsq}); "
            f"more accurate: {est.more_accurate.value}; used: {est.used.value}"
        )
    return "\n".join(lines)


def matrix_table(ms: MatrixSet) -> str:
    """M, C1, K0, K2 with σ, one 2 × 2 block each (rows/columns: roll φ, steer δ)."""
    out = [f"canonical matrices (q = [roll, steer]; σ {ms.convention.value}):"]
    for name in ("M", "C1", "K0", "K2"):
        val, sig = getattr(ms.matrices, name), getattr(ms.sigma, name)
        out.append(f"  {name}:")
        for i in range(2):
            cells = []
            for j in range(2):
                v, s = format_value_sigma(float(val[i, j]), float(sig[i, j]))
                cells.append(f"{v:>12} ± {s:<8}")
            out.append("    " + "  ".join(cells))
    return "\n".join(out)


def speeds_summary(cs: CriticalSpeeds) -> str:
    """Weave and capsize speeds, or why one is absent."""
    w = f"{cs.weave:.6f} m/s" if cs.weave is not None else "none (no weave crossing)"
    c = f"{cs.capsize:.6f} m/s" if cs.capsize is not None else "none (no capsize crossing)"
    return f"weave speed:   {w}\ncapsize speed: {c}"


def eigen_cell(z: complex) -> str:
    """One eigenvalue in 25 columns, 1/s: ``-3.1`` real, ``-0.8+4.2j`` complex, at 6 decimals.

    A part that prints as zero has no sign (``0.000000``, never ``-0.000000``), and an
    imaginary part below print resolution leaves a real number (blank where the ``j`` part goes).
    """
    re_text = f"{z.real + 0.0:.6f}"
    re_text = re_text[1:] if re_text == "-0.000000" else re_text
    im_text = f"{abs(z.imag):.6f}"
    if im_text == "0.000000":
        return f"{re_text:>13}{'':>12} "
    return f"{re_text:>13}{('-' if z.imag < 0 else '+') + im_text:>12}j"


def eigen_table(speeds: Sequence[float], eigenvalues: np.ndarray, labels: Sequence[str]) -> str:
    """Eigenvalues per speed, one column per tracked mode."""
    head = f"{'v [m/s]':>9}" + "".join(f"{lab:>26}" for lab in labels)
    rows = ["eigenvalues [1/s]:", head]
    for v, ev in zip(speeds, eigenvalues):
        cells = "".join(eigen_cell(complex(z)) for z in ev)
        rows.append(f"{v:>9.4f}{cells}")
    return "\n".join(rows)
