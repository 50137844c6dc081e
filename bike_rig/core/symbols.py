"""The benchmark parameters' names (Meijaard et al. 2007 symbols, BicycleParameters spelling)."""

from __future__ import annotations

__all__ = ["PARAMETER_NAMES"]

#: The 25 benchmark parameters plus g, in BicycleParameters' (alphabetical) order.
PARAMETER_NAMES: tuple[str, ...] = (
    "IBxx",
    "IBxz",
    "IByy",
    "IBzz",
    "IFxx",
    "IFyy",
    "IHxx",
    "IHxz",
    "IHyy",
    "IHzz",
    "IRxx",
    "IRyy",
    "c",
    "g",
    "lam",
    "mB",
    "mF",
    "mH",
    "mR",
    "rF",
    "rR",
    "w",
    "xB",
    "xH",
    "zB",
    "zH",
)
