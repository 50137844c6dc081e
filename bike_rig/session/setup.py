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
from collections.abc import Mapping
from functools import partial

from ..core.measurements import Measurements
from ..core.sim.rig import RigConfig
from ..pipeline.assemble import merged_readings
from ..pipeline.readings import ReadingEntry, apply_entries
from .controller import GraphLink, SessionController
from .nextbest import PeriodTrials, next_best, nominal_reading_sigmas
from .plan import ItemState, plan_from_rig
from .readings import ReadingInputError, parse_reading, plausibility
from .state import OperatorSession

__all__ = [
    "build_controller",
    "check_typed_reading",
    "connection",
    "rank_items",
    "session_measurements",
    "take_readings_file",
]


def check_typed_reading(
    key: str, value_text: str, sigma_text: str, session: OperatorSession
) -> tuple[ReadingEntry, list[str]]:
    """The entry the operator typed (:func:`~bike_rig.session.readings.parse_reading`), and its plausibility warnings.

    Raises:
        ValueError: The entry cannot be taken (not a number, unknown key or not in the plan,
            σ missing or negative, impossible value); the message names the key and why.
    """
    allowed = [i.key for i in session.plan.readings]
    note = "correction" if key in session.readings else ""
    try:
        entry = parse_reading(
            key, value_text, sigma_text, allowed=allowed, where="console", stamp_ns=time.time_ns(), note=note
        )
    except ReadingInputError as exc:
        raise ValueError(str(exc)) from None
    others = {k: e for k in session.readings if k != key and (e := session.reading(k)) is not None}
    return entry, plausibility(entry.key, entry.value, entry.sigma, others)


def session_measurements(session: OperatorSession) -> Measurements:
    """The session's readings now: the newest entry of each key, and each period key's combined period."""
    entries = [e for es in session.readings.values() for e in es]
    static = apply_entries(Measurements(session.bicycle, {}, path=""), entries)
    periods = {} if session.parameters is None else {p.key: (p.value, p.sigma) for p in session.parameters.periods}
    return merged_readings(static, periods, "period estimates")


def rank_items(session: OperatorSession, nominal: dict[str, float]) -> list[tuple[str, str]]:
    """The plan's items ranked by the σ reduction of the speeds (:func:`~bike_rig.session.nextbest.next_best`).

    Returns:
        ``(item id, one line)`` best first; a period key's item is the first of its trial
        items to do or redo, else its first (one more trial of it).
    """
    items = [i.key for i in session.plan.items]
    trials: dict[str, list[float]] = {}
    for view in session.trials.values():
        if view.fit is not None and view.fit.usable:
            trials.setdefault(view.key, []).append(view.fit.period_sigma)
    try:
        ranked = next_best(
            session_measurements(session),
            list(dict.fromkeys(items)),
            nominal,
            {k: PeriodTrials(tuple(v)) for k, v in trials.items()},
        )
    except Exception as exc:
        return [("", f"no ranking: {exc}")]
    out = []
    for sug in ranked:
        ids = [i for i in session.plan.items if i.key == sug.key]
        open_ = [i for i in ids if session.state(i) in (ItemState.TODO, ItemState.REDO)]
        item = (open_ or ids)[0].item_id if ids else sug.key
        if not math.isnan(sug.score) or sug.missing:
            out.append((item, f"{item}: {sug.describe()}"))
    return out


def build_controller(rig: RigConfig, bicycle: str, link: GraphLink, source: str = "sim") -> SessionController:
    """A controller of a new session of ``bicycle`` on ``rig`` through ``link``."""
    plan = plan_from_rig(rig)
    session = OperatorSession(plan, bicycle=bicycle, source=f"{source} gyro")
    nominal = nominal_reading_sigmas(rig.sigma, [i.key for i in plan.readings])
    return SessionController(
        session, link, check_reading=check_typed_reading, rank=partial(rank_items, nominal=nominal)
    )


def take_readings_file(ctl: SessionController, readings: Measurements) -> int:
    """Mark the plan's static readings that a measurement file gives (``session --readings``) as entered.

    The parameter node reads the same file itself, so nothing is sent to the graph: the plan,
    the progress and the next item just stop asking for them. Returns how many were taken.
    """
    wanted = {i.key for i in ctl.session.plan.readings}
    taken = 0
    for key, r in readings.readings.items():
        if key in wanted and key not in ctl.session.readings:
            ctl.session.on_reading(ReadingEntry(key, r.value, r.sigma, note=f"from {readings.path}"))
            taken += 1
    return taken


def connection(source: str, driver: Mapping[str, object], domain_id: int | None) -> tuple[str, dict[str, object]]:
    """What a session is connected to, in one line, and the same for ``--json``.

    Args:
        source: The driver's source (``sim``, ``can``, ``daq``, ``bag``).
        driver: The driver's parameters (its parameter file's values with the overrides on top).
        domain_id: The graph's ROS domain (None: unknown, the environment's).

    Returns:
        E.g. ``can gyro on socketcan:can0 id 0x100 · ROS domain 7 · live view: bike-rig view --domain-id 7``.
    """
    data: dict[str, object] = {"source": source, "domain_id": domain_id}
    where = f"{source} gyro"
    if source == "can":
        from ..sources.can_bus import choose_bus
        from ..sources.errors import SourceConfigError

        interface, channel = str(driver.get("can_interface", "")), str(driver.get("can_channel", ""))
        try:  # (the bus the driver opens: the parameters', python-can's configured one, or the virtual one)
            bitrate = int(str(driver.get("can_bitrate", 0)), 0)
            chosen = choose_bus(interface, channel, bitrate)
            interface, channel = chosen.interface, chosen.channel
        except (SourceConfigError, ValueError):
            pass  # (the driver says what is wrong with them)
        can_id = int(str(driver.get("can_id", 0)), 0)
        data.update(interface=interface, channel=channel, can_id=can_id)
        where += f" on {interface}:{channel} id 0x{can_id:x}"
    elif source == "daq":
        data["channel"] = str(driver.get("daq_channel", ""))
        where += f" on {data['channel']}"
    elif source == "sim":
        where = "simulated gyro"
    domain = "ROS domain ?" if domain_id is None else f"ROS domain {domain_id}"
    view = "bike-rig view" if domain_id is None else f"bike-rig view --domain-id {domain_id}"
    data["view"] = view
    return f"{where} · {domain} · live view: {view}", data
