"""Plain-text tables for the terminal: values with σ rounded the way the paper prints them."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..core.benchmark import PARAMETER_NAMES, ComEstimate, ParameterSet
from ..core.model import MatrixSet
from ..core.whipple import CriticalSpeeds

__all__ = ["format_value_sigma", "parameter_table", "matrix_table", "speeds_summary", "eigen_table"]

#: Display label and unit of each parameter (paper Table 2 order).
LABELS: dict[str, tuple[str, str]] = {
    "w": ("w", "m"), "c": ("c", "m"), "lam": ("λ", "rad"), "g": ("g", "m/s²"),
    "rR": ("r_R", "m"), "mR": ("m_R", "kg"), "IRxx": ("I_Rxx", "kg m²"), "IRyy": ("I_Ryy", "kg m²"),
    "xB": ("x_B", "m"), "zB": ("z_B", "m"), "mB": ("m_B", "kg"), "IBxx": ("I_Bxx", "kg m²"),
    "IBxz": ("I_Bxz", "kg m²"), "IByy": ("I_Byy", "kg m²"), "IBzz": ("I_Bzz", "kg m²"),
    "xH": ("x_H", "m"), "zH": ("z_H", "m"), "mH": ("m_H", "kg"), "IHxx": ("I_Hxx", "kg m²"),
    "IHxz": ("I_Hxz", "kg m²"), "IHyy": ("I_Hyy", "kg m²"), "IHzz": ("I_Hzz", "kg m²"),
    "rF": ("r_F", "m"), "mF": ("m_F", "kg"), "IFxx": ("I_Fxx", "kg m²"), "IFyy": ("I_Fyy", "kg m²"),
}  # fmt: skip
TABLE2_ORDER = tuple(LABELS)


def format_value_sigma(value: float, sigma: float) -> tuple[str, str]:
    """Value and σ as the paper prints them: σ to one significant digit, the value to match.

    With σ = 0 (exact or unknown) the value gets 6 significant digits.
    """
    if not sigma > 0 or not math.isfinite(sigma):
        return f"{value:.6g}", "0" if sigma == 0 else "nan"
    decimals = max(0, -math.floor(math.log10(sigma)))
    if round(sigma, decimals) >= 10 ** (1 - decimals):  # σ rounded up to the next decade
        decimals = max(0, decimals - 1)
    return f"{value:.{decimals}f}", f"{sigma:.{decimals}f}"


def parameter_table(ps: ParameterSet) -> str:
    """The parameters as the paper's Table 2: symbol, unit, value, σ."""
    assert set(TABLE2_ORDER) == set(PARAMETER_NAMES)
    rows = [f"{ps.bicycle}: benchmark parameters (from {ps.source})", f"{'parameter':<16}{'value':>12}{'σ':>10}"]
    pv = ps.parameters
    for key in TABLE2_ORDER:
        label, unit = LABELS[key]
        v, s = format_value_sigma(pv.value(key), pv.sigma(key))
        rows.append(f"{label + ' [' + unit + ']':<16}{v:>12}{s:>10}")
    if ps.com:
        rows.append("")
        rows.append(com_summary(ps.com))
    return "\n".join(rows)


def com_summary(coms: Mapping[str, ComEstimate]) -> str:
    """One line per part: both mass-centre solutions' σ and which is more accurate."""
    names = {"B": "rear frame", "H": "fork/handlebar"}
    lines = ["mass centres (x, z) [m], centroid Eq 17-19 vs least squares Eq 20:"]
    for part, est in coms.items():
        c, s = est.centroid, est.least_squares
        lines.append(
            f"  {names[part]:<15} centroid ({c.values[0]:.4f}, {c.values[1]:.4f}) σ ({c.sigmas[0]:.4f}, "
            f"{c.sigmas[1]:.4f}); least squares ({s.values[0]:.4f}, {s.values[1]:.4f}) σ ({s.sigmas[0]:.4f}, "
            f"{s.sigmas[1]:.4f}); more accurate: {est.more_accurate.value}; used: {est.used.value}"
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


def eigen_table(speeds: Sequence[float], eigenvalues: np.ndarray, labels: Sequence[str]) -> str:
    """Eigenvalues per speed, one column per tracked mode."""
    head = f"{'v [m/s]':>9}" + "".join(f"{lab:>26}" for lab in labels)
    rows = ["eigenvalues [1/s]:", head]
    for v, ev in zip(speeds, eigenvalues):
        cells = "".join(f"{z.real:>13.6f}{z.imag:>+12.6f}j" for z in ev)
        rows.append(f"{v:>9.4f}{cells}")
    return "\n".join(rows)
