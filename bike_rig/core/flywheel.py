"""An extra rigid part on the front wheel, a flywheel D (BicycleParameters' part ``D``).

The front wheel is measured alone (``mF``, ``TcF1``, ``TtF1``) and with the flywheel fixed in
it (``mD``: the wheel with the flywheel, ``TcD1``, ``TtD1``), each as Eq 28–29. D's mass centre
is on the axle, so its mass and moments about the wheel centre are the differences. It turns
with the wheel: for the model it adds to m_F, I_Fxx and I_Fyy (BicycleParameters reports D but
leaves it out of its model). Analytic arithmetic (complex-step safe, broadcasting).
"""

from __future__ import annotations

from typing import Any

__all__ = ["flywheel_inertia", "flywheel_mass", "wheel_with_flywheel"]


def flywheel_mass(m_FD: Any, mF: Any) -> Any:
    """Mass of the flywheel from the wheel weighed with and without it.

    Args:
        m_FD: Front wheel with the flywheel (key ``mD``), kg.
        mF: Front wheel alone, kg.

    Returns:
        m_D = m_FD − m_F, kg.
    """
    return m_FD - mF


def flywheel_inertia(I_FD: Any, I_F: Any) -> Any:
    """A moment of inertia of the flywheel about the wheel centre, from the wheel with and without it.

    Both moments are about the same axis through the wheel centre, where both mass centres lie
    (Eq 28 for I_yy, Eq 29 for I_xx, each from the matching periods).

    Args:
        I_FD: Moment of the wheel with the flywheel, kg m².
        I_F: Moment of the wheel alone, kg m².

    Returns:
        I_D = I_FD − I_F, kg m².
    """
    return I_FD - I_F


def wheel_with_flywheel(part_F: Any, part_D: Any) -> Any:
    """A front-wheel mass or moment with the flywheel that turns with it (the model's front wheel).

    Returns:
        m_F + m_D, or I_F + I_D, in their unit.
    """
    return part_F + part_D
