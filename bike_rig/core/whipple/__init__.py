"""Linearised Whipple bicycle model (Meijaard, Papadopoulos, Ruina, Schwab 2007).

``M q̈ + v C1 q̇ + (g K0 + v² K2) q = f`` with ``q = [φ, δ]`` (roll, steer; rad) and
``f = [T_φ, T_δ]`` (N m). Modules: :mod:`.matrices` (``M, C1, K0, K2`` from the 26 benchmark
parameters, paper Appendix A, complex-step safe; state space; characteristic polynomial),
:mod:`.quartic` (closed-form roots of many quartics), :mod:`.modes` (eigenvalues over speeds,
tracked and labelled weave / capsize / caster), :mod:`.stability` (weave and capsize speeds by
Routh–Hurwitz), :mod:`.closed_loop` (under steer-torque state feedback ``A − B K``). SI
throughout: m, kg, kg m², rad, g in m/s², speeds m/s, eigenvalues 1/s.
"""

from __future__ import annotations

from .matrices import (
    PARAMETER_KEYS,
    CharacteristicPolynomial,
    WhippleMatrices,
    canonical_matrices,
    characteristic_coefficients,
    characteristic_polynomial,
    state_space,
)
from .modes import MODE_LABELS, EigenvalueSweep, eigenvalues
from .quartic import quartic_roots
from .stability import (
    CriticalSpeeds,
    Crossing,
    critical_speeds,
    hurwitz_determinant,
    hurwitz_quadratic,
    pair_crossing_rate,
    stable_speed_range,
)

__all__ = [
    "MODE_LABELS",
    "PARAMETER_KEYS",
    "CharacteristicPolynomial",
    "CriticalSpeeds",
    "Crossing",
    "EigenvalueSweep",
    "WhippleMatrices",
    "canonical_matrices",
    "characteristic_coefficients",
    "characteristic_polynomial",
    "critical_speeds",
    "eigenvalues",
    "hurwitz_determinant",
    "hurwitz_quadratic",
    "pair_crossing_rate",
    "quartic_roots",
    "stable_speed_range",
    "state_space",
]
