"""How numbers with σ and parameter names are written for people, and text made safe for a terminal.

The same for terminal tables, figures and the HTML report alike.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Protocol

__all__ = [
    "CONTROL_CHARACTERS",
    "LABELS",
    "TABLE2_ORDER",
    "SpeedLike",
    "format_speed",
    "format_value_sigma",
    "terminal_safe",
]

#: Code points a terminal acts on instead of showing: C0 (ESC among them), DEL and C1.
CONTROL_CHARACTERS = (*range(0x00, 0x20), 0x7F, *range(0x80, 0xA0))


@lru_cache(maxsize=4)
def _escapes(keep: str) -> dict[int, str]:
    return {c: f"\\x{c:02x}" for c in CONTROL_CHARACTERS if chr(c) not in keep}


def terminal_safe(text: str, keep: str = "\n\t") -> str:
    r"""``text`` with every control character written as ``\xNN``, so a terminal shows it and obeys none.

    C0 (NUL, ESC and the rest), DEL and C1 (U+0080–U+009F, among them CSI U+009B) are escaped:
    a name from a file holding ``ESC [ 2 J`` prints as ``\x1b[2J`` instead of clearing the
    screen. Everything else, ``λ`` and ``σ`` included, is left as it is.

    Args:
        text: Text that may hold what a user or a file wrote.
        keep: Control characters left as they are: newline and tab for a whole output, ``""``
            for a value that must stay on one line (a name in a table).
    """
    return text.translate(_escapes(keep))


#: Display label and unit of each benchmark parameter (paper Table 2 order).
LABELS: dict[str, tuple[str, str]] = {
    "w": ("w", "m"), "c": ("c", "m"), "lam": ("λ", "rad"), "g": ("g", "m/s²"),
    "rR": ("r_R", "m"), "mR": ("m_R", "kg"), "IRxx": ("I_Rxx", "kg m²"), "IRyy": ("I_Ryy", "kg m²"),
    "xB": ("x_B", "m"), "zB": ("z_B", "m"), "mB": ("m_B", "kg"), "IBxx": ("I_Bxx", "kg m²"),
    "IBxz": ("I_Bxz", "kg m²"), "IByy": ("I_Byy", "kg m²"), "IBzz": ("I_Bzz", "kg m²"),
    "xH": ("x_H", "m"), "zH": ("z_H", "m"), "mH": ("m_H", "kg"), "IHxx": ("I_Hxx", "kg m²"),
    "IHxz": ("I_Hxz", "kg m²"), "IHyy": ("I_Hyy", "kg m²"), "IHzz": ("I_Hzz", "kg m²"),
    "rF": ("r_F", "m"), "mF": ("m_F", "kg"), "IFxx": ("I_Fxx", "kg m²"), "IFyy": ("I_Fyy", "kg m²"),
}  # fmt: skip
#: The parameters in the order of the paper's Table 2.
TABLE2_ORDER = tuple(LABELS)


def format_value_sigma(value: float, sigma: float | None, digits: int = 1) -> tuple[str, str]:
    """Value and σ for print.

    σ to ``digits`` significant digits, the value to the same place (``digits=1`` is how the
    paper prints its tables).

    Args:
        value: The value (any unit).
        sigma: Its standard uncertainty, same unit; None, 0, NaN or inf when unknown.
        digits: Significant digits of σ.

    Returns:
        ``(value, sigma)`` texts; without a usable σ the value gets 6 significant digits and σ
        is ``"0"`` (exactly zero) or ``"–"``.
    """
    if not math.isfinite(value):
        return str(value), "–"
    if sigma is None or not math.isfinite(sigma) or sigma <= 0.0:
        return f"{value:.6g}", "0" if sigma == 0.0 else "–"
    decimals = digits - 1 - math.floor(math.log10(sigma))
    if round(sigma, decimals) >= 10.0 ** (digits - decimals):  # σ rounded up to the next decade
        decimals -= 1
    if decimals > 0:
        return f"{value:.{decimals}f}", f"{sigma:.{decimals}f}"
    # σ ≥ 10**(digits-1): round both to units, tens, hundreds...
    scale = 10.0 ** (-decimals)
    return f"{round(value / scale) * scale:.0f}", f"{round(sigma / scale) * scale:.0f}"


class SpeedLike(Protocol):
    """A critical speed with its σ, m/s (:class:`~bike_rig.core.uncertainty.speed_sigma.SpeedWithSigma`)."""

    @property
    def speed(self) -> float:
        """The speed, m/s."""
        ...

    @property
    def sigma(self) -> float:
        """Its standard uncertainty, m/s (NaN when the root is not simple)."""
        ...


def format_speed(speed: SpeedLike | None, mode: str = "", *, compact: bool = False) -> str:
    """A weave or capsize speed with its σ for people, the same everywhere: ``4.195 ± 0.045 m/s``.

    σ to two significant digits and the speed to the same place (:func:`format_value_sigma`).

    Args:
        speed: The speed with σ, m/s; None (or a speed that is not finite) when the bicycle
            has no such crossing.
        mode: The speed's name (``weave``, ``capsize``) for the text of an absent one.
        compact: Without spaces or unit (``4.195±0.045``), for narrow places such as the
            console's title.

    Returns:
        ``4.195 ± 0.045 m/s``; ``4.292383 ± 0 m/s (the parameters carry no σ)`` for σ 0;
        ``4.292383 m/s (σ undefined: not a simple root)`` for a σ that is not finite;
        ``none (no weave crossing)``, or ``none`` without ``mode``, for no speed. Compact:
        ``4.195±0.045``, ``4.29238±0``, ``4.29238`` and ``none``.
    """
    if speed is None or not math.isfinite(speed.speed):
        return f"none (no {mode} crossing)" if mode and not compact else "none"
    if compact:
        value, sigma = format_value_sigma(speed.speed, speed.sigma, digits=2)
        return value if sigma == "–" else f"{value}±{sigma}"
    if not math.isfinite(speed.sigma):
        return f"{speed.speed:.6f} m/s (σ undefined: not a simple root)"
    if speed.sigma == 0.0:
        return f"{speed.speed:.6f} ± 0 m/s (the parameters carry no σ)"
    value, sigma = format_value_sigma(speed.speed, speed.sigma, digits=2)
    return f"{value} ± {sigma} m/s"
