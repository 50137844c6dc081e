"""Linearised Whipple bicycle model (Meijaard, Papadopoulos, Ruina, Schwab 2007).

The model is ``M q̈ + v C1 q̇ + (g K0 + v² K2) q = f`` with ``q = [φ, δ]`` (roll, steer; rad)
and ``f = [T_φ, T_δ]`` (N m). The package provides, one job per module:

* :mod:`.matrices`: :func:`canonical_matrices` (``M, C1, K0, K2`` from the 26 benchmark
  parameters, paper Appendix A, as pure broadcasting arithmetic that also accepts complex values
  for complex-step derivatives); :func:`state_space` (the first-order form ``ẋ = A x + B f``,
  ``x = [φ, δ, φ̇, δ̇]``); :func:`characteristic_polynomial` / :func:`characteristic_coefficients`
  (``det(M s² + v C1 s + g K0 + v² K2)`` as a bivariate polynomial in ``s`` and ``v``);
* :mod:`.quartic`: :func:`quartic_roots`, closed-form (Ferrari) roots of many real quartics at
  once;
* :mod:`.modes`: :func:`eigenvalues`, the four eigenvalues (1/s) over many speeds at once, by
  closed-form quartic roots, tracked across speeds and labelled weave / capsize / caster
  (:class:`EigenvalueSweep`, :data:`MODE_LABELS`);
* :mod:`.stability`: :func:`critical_speeds` / :func:`stable_speed_range`, the weave and capsize
  speeds (m/s) from the Routh–Hurwitz structure of the quartic, in closed form and then polished;
* :mod:`.closed_loop`: the model under steer-torque state feedback (``A − B K``): its
  characteristic polynomial, state space, critical speeds and stable speed ranges.

Units are SI throughout: lengths in m, masses in kg, inertias in kg m², angles in rad, ``g`` in
m/s², speeds in m/s, eigenvalues in 1/s.
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
