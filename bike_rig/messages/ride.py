"""Converters of the ride topics: the speed (``std_msgs/Float64``, m/s) and ``StateSpaceModel``.

Layouts as the ``StateSpace`` service: A row-major 4 × 4, B row-major 4 × 2, each with the σ of
every entry in the same layout; eigenvalues and their σ in ``mode_labels`` order.
"""

from __future__ import annotations

import math

from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..pipeline.model import StateSpaceAt, StateSpaceWithSigma
from .fields import Message, MessageError, check_length, fill_fields, floats, record_fields, set_floats, strings

__all__ = ["fill_ride_speed", "fill_state_space_model", "ride_speed_from_msg", "state_space_model_from_msg"]

#: Fields of :class:`StateSpaceWithSigma` written here, not copied: the matrices' σ are reshaped.
_EXPLICIT = ("a_sigma", "b_sigma")


def fill_ride_speed(msg: Message, speed: float) -> Message:
    """Write a riding speed (m/s) into a ``std_msgs/Float64``."""
    msg.data = float(speed)
    return msg


def ride_speed_from_msg(msg: Message, topic: str = "") -> float:
    """The riding speed (m/s) of a ``std_msgs/Float64``.

    Raises:
        MessageError: the speed is not a finite number ≥ 0 m/s.
    """
    v = float(msg.data)
    if not (math.isfinite(v) and v >= 0.0):
        where = f"{topic}: " if topic else ""
        raise MessageError(f"{where}ride speed must be a finite number >= 0 m/s, got {v}")
    return v


def fill_state_space_model(msg: Message, model: StateSpaceWithSigma) -> Message:
    """Write the state space with σ into a ``StateSpaceModel`` (the header is left to the caller)."""
    state = model.state
    fill_fields(msg, model, skip=_EXPLICIT)
    msg.speed = float(state.speed)
    msg.sigma_convention = model.convention.value
    set_floats(msg, "a", state.a)
    set_floats(msg, "a_sigma", model.a_sigma)
    set_floats(msg, "b", state.b)
    set_floats(msg, "b_sigma", model.b_sigma)
    set_floats(msg, "eigenvalues_real", state.eigenvalues.real)
    set_floats(msg, "eigenvalues_real_sigma", model.eigenvalues_sigma_real)
    set_floats(msg, "eigenvalues_imag", state.eigenvalues.imag)
    set_floats(msg, "eigenvalues_imag_sigma", model.eigenvalues_sigma_imag)
    msg.mode_labels = list(state.labels)
    return msg


def state_space_model_from_msg(msg: Message) -> StateSpaceWithSigma:
    """A ``StateSpaceModel`` as :class:`~bike_rig.pipeline.model.StateSpaceWithSigma`.

    Raises:
        MessageError: wrong array lengths or an unknown σ convention.
    """
    fields = {
        "a": 16,
        "a_sigma": 16,
        "b": 8,
        "b_sigma": 8,
        "eigenvalues_real": 4,
        "eigenvalues_real_sigma": 4,
        "eigenvalues_imag": 4,
        "eigenvalues_imag_sigma": 4,
    }
    values = {}
    for name, n in fields.items():
        values[name] = floats(getattr(msg, name))
        check_length(f"StateSpaceModel.{name}", values[name].size, n)
    labels = strings(msg.mode_labels)
    check_length("StateSpaceModel.mode_labels", len(labels), 4)
    try:
        convention = SigmaConvention(str(msg.sigma_convention))
    except ValueError:
        raise MessageError(f"StateSpaceModel.sigma_convention: unknown {msg.sigma_convention!r}") from None
    eig = values["eigenvalues_real"] + 1j * values["eigenvalues_imag"]
    state = StateSpaceAt(float(msg.speed), values["a"].reshape(4, 4), values["b"].reshape(4, 2), eig, labels)
    return StateSpaceWithSigma(
        **record_fields(StateSpaceWithSigma, msg, skip=_EXPLICIT),
        state=state,
        a_sigma=values["a_sigma"].reshape(4, 4),
        b_sigma=values["b_sigma"].reshape(4, 2),
        eigenvalues_sigma_real=values["eigenvalues_real_sigma"],
        eigenvalues_sigma_imag=values["eigenvalues_imag_sigma"],
        convention=convention,
    )
