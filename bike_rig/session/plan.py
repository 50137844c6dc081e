"""The plan of a measurement session: every trial and every static reading, in rig order.

Made from the rig description (:class:`~bike_rig.core.sim.rig.RigConfig`: orientations, trials
per period, durations) and what the parameters need
(:data:`~bike_rig.core.measurements.REQUIRED_KEYS` and the orientation readings), in the order a
person works: gravity and geometry, then part by part its readings and trials (wheels, frame,
fork, rod). Item ids: a reading's flat key (``mR``, ``alphaB2``), a trial's key and repeat
(``TtB2#3``).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from ..core.sim.plan import PlannedMeasurement, measurement_plan
from ..core.sim.rig import RigConfig

__all__ = ["ItemState", "PlanItem", "ReadingItem", "SessionPlan", "TrialItem", "plan_from_rig"]


class ItemState(Enum):
    """Where an item of the plan stands."""

    TODO = "to do"
    RECORDING = "recording"
    OK = "ok"
    REDO = "REDO"
    DONE = "done"


_PART_TEXT: dict[str, str] = {
    "rear_wheel": "the rear wheel",
    "front_wheel": "the front wheel",
    "frame": "the frame",
    "fork": "the fork and handlebar",
    "calibration_rod": "the calibration rod",
}

#: (key, what, unit, how) of the readings taken before any part is hung.
_GENERAL: tuple[tuple[str, str, str, str], ...] = (
    ("g", "local acceleration of gravity", "m/s^2", "the local value (e.g. from a gravity map)"),
    ("w", "wheelbase", "m", "tape-measure the distance between the wheel contact points"),
    ("gamma", "head-tube angle from the horizontal", "deg", "digital level on the head tube, bicycle upright"),
    ("f", "fork offset", "m", "perpendicular distance from the front axle to the steer axis"),
)
_WHEEL: tuple[tuple[str, str, str, str], ...] = (
    ("n{p}", "rotations rolled (exact count)", "1", "roll the bicycle a whole number of wheel rotations"),
    ("d{p}", "distance rolled over those rotations", "m", "tape-measure the distance rolled"),
    ("m{p}", "mass", "kg", "weigh the wheel"),
    ("l{p}", "compound-pendulum arm (rim contact to centre)", "m", "measure from the knife edge to the axle"),
)


@dataclass(frozen=True)
class ReadingItem:
    """One static reading to take.

    Attributes:
        key: Its flat key (``mR``, ``alphaB2``); degrees only where the unit says ``deg``.
        what: What is measured.
        unit: The unit the value is entered in.
        how: How to take it, in a few words.
        part: The plan section it belongs to (``general`` or a part name).
    """

    key: str
    what: str
    unit: str
    how: str
    part: str

    @property
    def item_id(self) -> str:
        """The item's id in the plan: the key."""
        return self.key

    @property
    def instruction(self) -> str:
        """A plain instruction for the operator."""
        return f"Reading {self.key}: {self.what} [{self.unit}] — {self.how}."


@dataclass(frozen=True)
class TrialItem:
    """One pendulum trial to record.

    Attributes:
        measurement: The period it measures (part, pendulum, orientation).
        repeat: 1-based trial number of that measurement.
        duration_s: The rig's trial duration, s.
        angle_deg: The hanging angle of the head or steer tube for a torsional orientation of
            the frame or fork (the rig description's), degree; None otherwise.
        amplitude_deg: The initial swing to give, roughly, degree.
    """

    measurement: PlannedMeasurement
    repeat: int
    duration_s: float
    angle_deg: float | None
    amplitude_deg: float

    @property
    def key(self) -> str:
        """The period's flat key, e.g. ``TtB2``."""
        return self.measurement.key

    @property
    def item_id(self) -> str:
        """The item's id in the plan, e.g. ``TtB2#3``."""
        return f"{self.key}#{self.repeat}"

    @property
    def part(self) -> str:
        """The part hung (a measurement-file section name)."""
        return self.measurement.part

    @property
    def instruction(self) -> str:
        """A plain instruction: what to hang, how, in which orientation, roughly which angle."""
        m, part = self.measurement, _PART_TEXT[self.measurement.part]
        swing = f"swing it by about {self.amplitude_deg:.1g}° and release"
        if m.pendulum == "compound":
            if m.part.endswith("wheel"):
                how = f"Hang {part} by its rim on the knife edge (compound pendulum)"
            elif m.part == "frame":
                how = f"Hang {part} from the rear axle on the knife edge (compound pendulum)"
            else:
                how = f"Hang {part} from the front axle on the knife edge (compound pendulum)"
        elif m.orientation is not None:
            tube = "head tube" if m.part == "frame" else "steer tube"
            angle = "" if self.angle_deg is None else f", {tube} at about {self.angle_deg:.0f}° from the horizontal"
            how = f"Clamp {part} to the torsion rod in orientation {m.orientation}{angle} (torsional pendulum)"
            swing = f"twist it by about {self.amplitude_deg:.1g}° and release"
        elif m.part == "calibration_rod":
            how = f"Clamp {part} to the torsion rod, horizontal (torsional pendulum)"
            swing = f"twist it by about {self.amplitude_deg:.1g}° and release"
        else:
            how = f"Clamp {part} to the torsion rod by its axle, axle vertical (torsional pendulum)"
            swing = f"twist it by about {self.amplitude_deg:.1g}° and release"
        return f"Trial {self.key} #{self.repeat}: {how}; {swing}; record {self.duration_s:g} s."


PlanItem = ReadingItem | TrialItem


@dataclass(frozen=True)
class SessionPlan:
    """Every item of a session, in the order to take them.

    Attributes:
        items: Readings and trials, in rig order.
        frame_orientations: Number of hanging orientations of the frame.
        fork_orientations: Number of hanging orientations of the fork.
        per_measurement: Trials per period.
    """

    items: tuple[PlanItem, ...]
    frame_orientations: int
    fork_orientations: int
    per_measurement: int

    @property
    def trials(self) -> tuple[TrialItem, ...]:
        """The trial items, in order."""
        return tuple(i for i in self.items if isinstance(i, TrialItem))

    @property
    def readings(self) -> tuple[ReadingItem, ...]:
        """The reading items, in order."""
        return tuple(i for i in self.items if isinstance(i, ReadingItem))

    def item(self, item_id: str) -> PlanItem:
        """The item with this id.

        Raises:
            KeyError: No such item (the message lists what ids look like).
        """
        for i in self.items:
            if i.item_id == item_id:
                return i
        raise KeyError(f"no plan item {item_id!r} (readings are keys such as mR, trials KEY#REPEAT such as TtB2#1)")

    def measurements(self) -> tuple[PlannedMeasurement, ...]:
        """The planned periods, in plan order."""
        return measurement_plan(self.frame_orientations, self.fork_orientations)


def _part_readings(part: str, orientations: int) -> list[ReadingItem]:
    if part in ("rear_wheel", "front_wheel"):
        p = "R" if part == "rear_wheel" else "F"
        return [
            ReadingItem(k.format(p=p), f"{_PART_TEXT[part]}: {what}", unit, how, part) for k, what, unit, how in _WHEEL
        ]
    if part == "calibration_rod":
        return [
            ReadingItem("mP", "calibration rod mass", "kg", "weigh the rod", part),
            ReadingItem("lP", "calibration rod length", "m", "measure the rod's length", part),
            ReadingItem("dP", "calibration rod diameter", "m", "calliper the rod's diameter", part),
        ]
    p = "B" if part == "frame" else "H"
    axle = "rear axle" if part == "frame" else "front axle"
    out = [ReadingItem(f"m{p}", f"{_PART_TEXT[part]}: mass", "kg", "weigh it", part)]
    for i in range(1, orientations + 1):
        out.append(
            ReadingItem(
                f"alpha{p}{i}",
                f"orientation {i}: hanging angle",
                "deg",
                "digital level on the tube while it hangs",
                part,
            )
        )
        out.append(
            ReadingItem(
                f"a{p}{i}",
                f"orientation {i}: string-line distance to the {axle}",
                "m",
                "perpendicular distance from the plumb line to the axle",
                part,
            )
        )
    return out


def plan_from_rig(rig: RigConfig, per_measurement: int | None = None, duration_s: float | None = None) -> SessionPlan:
    """The plan of a session on ``rig``.

    Args:
        rig: The rig description.
        per_measurement: Trials per period (default: the rig's).
        duration_s: Trial duration, s (default: the rig's first duration).
    """
    n = per_measurement if per_measurement is not None else rig.trials.per_measurement
    duration = duration_s if duration_s is not None else rig.trials.durations[0]
    amplitude = 0.5 * (rig.trials.amplitude_deg[0] + rig.trials.amplitude_deg[1])
    angles = {"frame": rig.frame_orientations_deg, "fork": rig.fork_orientations_deg}
    nori = {"frame": len(rig.frame_orientations_deg), "fork": len(rig.fork_orientations_deg)}
    items: list[PlanItem] = [ReadingItem(k, what, unit, how, "general") for k, what, unit, how in _GENERAL]
    measurements = measurement_plan(nori["frame"], nori["fork"])
    for part in ("rear_wheel", "front_wheel", "frame", "fork", "calibration_rod"):
        items += _part_readings(part, nori.get(part, 0))
        for m in (m for m in measurements if m.part == part):
            angle = angles[part][m.orientation - 1] if m.orientation is not None and part in angles else None
            items += [TrialItem(m, r, duration, angle, amplitude) for r in range(1, n + 1)]
    return SessionPlan(tuple(items), nori["frame"], nori["fork"], n)
