"""What a measurement session measures: every part, as each pendulum, at each orientation.

The paper (sections 8–9) hangs each part as a compound pendulum and as a torsional pendulum
and repeats every period measurement three times. Each planned measurement is one period
reading of the measurement file, under its flat key (``TcR1``, ``TtB2``, ``TtP1``...; see
:mod:`bike_rig.core.measurements`), and its trials are named after it:
``frame_torsional_o2_t3``, ``calibration_rod_torsional_t1``.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PART_LETTERS", "PlannedMeasurement", "measurement_plan"]

#: Measurement-file section -> the part letter of its flat keys.
PART_LETTERS: dict[str, str] = {
    "rear_wheel": "R",
    "front_wheel": "F",
    "frame": "B",
    "fork": "H",
    "fork_only": "S",
    "handlebar": "G",
    "calibration_rod": "P",
}


@dataclass(frozen=True)
class PlannedMeasurement:
    """One period to measure.

    Attributes:
        part: The measurement-file section (``rear_wheel``, ``front_wheel``, ``frame``,
            ``fork``, ``fork_only``, ``handlebar`` or ``calibration_rod``).
        pendulum: ``compound`` or ``torsional``.
        orientation: The 1-based hanging orientation of the frame or fork (torsional), else None.
    """

    part: str
    pendulum: str
    orientation: int | None = None

    @property
    def key(self) -> str:
        """The flat key of the period reading, e.g. ``TtB2`` (see the measurements module)."""
        kind = "Tc" if self.pendulum == "compound" else "Tt"
        return f"{kind}{PART_LETTERS[self.part]}{self.orientation or 1}"

    @property
    def stem(self) -> str:
        """The trials' common name, e.g. ``frame_torsional_o2``."""
        suffix = f"_o{self.orientation}" if self.orientation is not None else ""
        return f"{self.part}_{self.pendulum}{suffix}"

    def trial_name(self, trial: int) -> str:
        """The name of trial ``trial`` (1-based), e.g. ``frame_torsional_o2_t3``."""
        return f"{self.stem}_t{trial}"


def measurement_plan(
    frame_orientations: int, fork_orientations: int, split_fork: bool = False
) -> tuple[PlannedMeasurement, ...]:
    """Every period of a session, in the order the paper describes them (sections 9.1–9.4).

    Args:
        frame_orientations: Number of hanging orientations of the rear frame.
        fork_orientations: Number of hanging orientations of the fork/handlebar (of the fork
            alone and of the handlebar each, when split).
        split_fork: The fork S (``fork_only``) and handlebar G (``handlebar``) are hung
            separately (Moore's refined method) instead of the fork/handlebar H together.

    Returns:
        Wheels (compound, torsional), frame (compound, torsional at each orientation), fork
        (likewise; or the fork alone, then the handlebar) and the calibration rod (torsional).
    """
    plan = [
        PlannedMeasurement("rear_wheel", "compound"),
        PlannedMeasurement("rear_wheel", "torsional"),
        PlannedMeasurement("front_wheel", "compound"),
        PlannedMeasurement("front_wheel", "torsional"),
        PlannedMeasurement("frame", "compound"),
    ]
    plan += [PlannedMeasurement("frame", "torsional", i + 1) for i in range(frame_orientations)]
    for part in ("fork_only", "handlebar") if split_fork else ("fork",):
        plan.append(PlannedMeasurement(part, "compound"))
        plan += [PlannedMeasurement(part, "torsional", i + 1) for i in range(fork_orientations)]
    plan.append(PlannedMeasurement("calibration_rod", "torsional"))
    return tuple(plan)
