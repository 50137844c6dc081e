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
    "format_uncertain",
    "format_value_sigma",
    "sigma_digits",
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
    "w": ("w", "m"),
    "c": ("c", "m"),
    "lam": ("λ", "rad"),
    "g": ("g", "m/s²"),
    "rR": ("r_R", "m"),
    "mR": ("m_R", "kg"),
    "IRxx": ("I_Rxx", "kg m²"),
    "IRyy": ("I_Ryy", "kg m²"),
    "xB": ("x_B", "m"),
    "zB": ("z_B", "m"),
    "mB": ("m_B", "kg"),
    "IBxx": ("I_Bxx", "kg m²"),
    "IBxz": ("I_Bxz", "kg m²"),
    "IByy": ("I_Byy", "kg m²"),
    "IBzz": ("I_Bzz", "kg m²"),
    "xH": ("x_H", "m"),
    "zH": ("z_H", "m"),
    "mH": ("m_H", "kg"),
    "IHxx": ("I_Hxx", "kg m²"),
    "IHxz": ("I_Hxz", "kg m²"),
    "IHyy": ("I_Hyy", "kg m²"),
    "IHzz": ("I_Hzz", "kg m²"),
    "rF": ("r_F", "m"),
    "mF": ("m_F", "kg"),
    "IFxx": ("I_Fxx", "kg m²"),
    "IFyy": ("I_Fyy", "kg m²"),
}
#: The parameters in the order of the paper's Table 2.
TABLE2_ORDER = tuple(LABELS)


def sigma_digits(sigma: float) -> int:
    """Significant digits of σ by the Particle Data Group's rule: 1 or 2.

    The σ's first three significant digits 100–354 keep two digits, 355–949 one, and 950–999
    are rounded up to the next decade and keep two (``0.0972`` → ``0.10``). Two digits where
    the first is small (1, 2, 3: rounding to one digit would change σ by up to 17 %), one
    where it is large.
    """
    if not math.isfinite(sigma) or sigma <= 0.0:
        return 2
    lead = _leading_digits(sigma)
    return 2 if lead < 355 or lead >= 950 else 1


def _leading_digits(sigma: float) -> int:
    """σ's first three significant digits, 100–999 (σ > 0, finite)."""
    return min(max(int(sigma / 10.0 ** (math.floor(math.log10(sigma)) - 2) + 1e-9), 100), 999)


def format_value_sigma(value: float, sigma: float | None, digits: int | None = 1) -> tuple[str, str]:
    """Value and σ for print: σ to ``digits`` significant digits, the value to σ's last digit.

    Args:
        value: The value (any unit).
        sigma: Its standard uncertainty, same unit; None, 0, NaN or inf when unknown.
        digits: Significant digits of σ; ``None`` for the Particle Data Group's rule
            (:func:`sigma_digits`, what every uncertain number outside the paper-style
            parameter table uses); ``1`` as the paper prints its Table 2.

    Returns:
        ``(value, sigma)`` texts; without a usable σ the value gets 6 significant digits and σ
        is ``"0"`` (exactly zero) or ``"–"``. A value that rounds to zero prints without a sign.
    """
    if not math.isfinite(value):
        return str(value), "–"
    if sigma is None or not math.isfinite(sigma) or sigma <= 0.0:
        return f"{value + 0.0:.6g}", "0" if sigma == 0.0 else "–"
    if digits is None:
        digits = sigma_digits(sigma)
        if _leading_digits(sigma) >= 950:  # 950–999 round up to 1000: two digits of the next decade
            sigma = 10.0 ** (math.floor(math.log10(sigma)) + 1)
    decimals = digits - 1 - math.floor(math.log10(sigma))
    if round(sigma, decimals) >= 10.0 ** (digits - decimals):  # σ rounded up to the next decade
        decimals -= 1
    if decimals > 0:
        v, s = f"{value:.{decimals}f}", f"{sigma:.{decimals}f}"
    else:  # σ ≥ 10**(digits-1): round both to units, tens, hundreds...
        scale = 10.0 ** (-decimals)
        v, s = f"{round(value / scale) * scale:.0f}", f"{round(sigma / scale) * scale:.0f}"
    return _unsigned_zero(v), s


def _unsigned_zero(text: str) -> str:
    """``-0.00`` → ``0.00``: a value that rounds to zero has no sign."""
    return text[1:] if text.startswith("-") and not any(c in "123456789" for c in text) else text


def format_uncertain(value: float, sigma: float | None, unit: str = "") -> str:
    """``value ± σ unit`` by the one rule (:func:`format_value_sigma` with ``digits=None``)."""
    v, s = format_value_sigma(value, sigma, digits=None)
    text = v if s == "–" else f"{v} ± {s}"
    return f"{text} {unit}" if unit else text


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
    """A weave or capsize speed with its σ for people, the same everywhere: ``4.20 ± 0.05 m/s``.

    σ to 1–2 significant digits by the one rule (:func:`sigma_digits`), the speed to σ's
    last digit (:func:`format_value_sigma`).

    Args:
        speed: The speed with σ, m/s; None (or a speed that is not finite) when the bicycle
            has no such crossing.
        mode: The speed's name (``weave``, ``capsize``) for the text of an absent one.
        compact: Without spaces or unit (``4.20±0.05``), for narrow places such as the
            console's title.

    Returns:
        ``4.20 ± 0.05 m/s`` (σ 0.045); ``4.292383 ± 0 m/s (the parameters carry no σ)`` for σ 0;
        ``4.292383 m/s (σ undefined: not a simple root)`` for a σ that is not finite;
        ``none (no weave crossing)``, or ``none`` without ``mode``, for no speed. Compact:
        ``4.20±0.05``, ``4.29238±0``, ``4.29238`` and ``none``.
    """
    if speed is None or not math.isfinite(speed.speed):
        return f"none (no {mode} crossing)" if mode and not compact else "none"
    if compact:
        value, sigma = format_value_sigma(speed.speed, speed.sigma, digits=None)
        return value if sigma == "–" else f"{value}±{sigma}"
    if not math.isfinite(speed.sigma):
        return f"{speed.speed:.6f} m/s (σ undefined: not a simple root)"
    if speed.sigma == 0.0:
        return f"{speed.speed:.6f} ± 0 m/s (the parameters carry no σ)"
    value, sigma = format_value_sigma(speed.speed, speed.sigma, digits=None)
    return f"{value} ± {sigma} m/s"
