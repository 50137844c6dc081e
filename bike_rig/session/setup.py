"""Put a session together: the plan from the rig, the state, and the controller's checks.

:func:`build_controller` is what ``bike-rig session`` (and the tests) use: the plan of
:func:`~bike_rig.session.plan.plan_from_rig`, an empty :class:`OperatorSession`, and a
:class:`SessionController` whose reading check is :func:`check_typed_reading` (the entry's
own checks, then the plausibility warnings of :mod:`bike_rig.session.readings`) and whose
ranking is :func:`rank_items` (:mod:`bike_rig.session.nextbest`).
"""

from __future__ import annotations

import math
import time

from ..core.sim.rig import RigConfig
from ..pipeline.readings import ReadingEntry, ReadingEntryError, check_entry
from .controller import GraphLink, SessionController
from .plan import plan_from_rig
from .state import OperatorSession

__all__ = ["build_controller", "check_typed_reading"]


def _number(text: str, what: str, key: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"reading {key}: {what} '{text}' is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"reading {key}: {what} '{text}' must be a finite number")
    return value


def check_typed_reading(
    key: str, value_text: str, sigma_text: str, session: OperatorSession
) -> tuple[ReadingEntry, list[str]]:
    """The entry the operator typed, and its plausibility warnings.

    Raises:
        ValueError: The entry cannot be taken (not a number, unknown key, σ < 0, impossible
            value); the message names the key, the value and why.
    """
    value = _number(value_text, "value", key)
    sigma = _number(sigma_text, "sigma", key)
    corrected = key in session.readings
    entry = ReadingEntry(key, value, sigma, time.time_ns(), "correction" if corrected else "")
    try:
        check_entry(entry)
    except ReadingEntryError as exc:
        raise ValueError(str(exc)) from None
    return entry, []


def build_controller(rig: RigConfig, bicycle: str, link: GraphLink, source: str = "sim") -> SessionController:
    """A controller of a new session of ``bicycle`` on ``rig`` through ``link``."""
    session = OperatorSession(plan_from_rig(rig), bicycle=bicycle, source=f"{source} gyro")
    return SessionController(session, link, check_reading=check_typed_reading)
