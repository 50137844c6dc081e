"""Ride segment σ against their scatter on simulated rides: seven conditions, one table.

Prints numbers, asserts nothing. For each condition (the Browser with the paper's rider, the
balance assist's gains as shipped, with the roll-rate gain doubled, or none; the rider's
steering torque σ; the motor's limit) ``--groups`` records of three segments of 1.2–2.5 cycles
at each of two speeds are simulated and fitted (:func:`bike_rig.core.ride.calibration.measure_calibration`):
clean segments, pooled χ²/dof of Re λ and Im λ about each speed's weighted mean (≈ 1 when the
σ are right) and the RMS of the errors against the simulated weave in σ (≈ 1).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

import numpy as np

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import Feedback, resolve_feedback
from bike_rig.core.ride.calibration import measure_calibration
from bike_rig.core.ride.ridesim import RideConditions
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

#: A condition: its name, the gains at a speed (None: no assist), the two speeds [m/s], the ride.
Condition = tuple[str, Callable[[float], np.ndarray | None], tuple[float, ...], RideConditions]


def conditions(fb: Feedback) -> list[Condition]:
    """The seven conditions of the table (module docstring) for the shipped assist ``fb``."""

    def doubled(v: float) -> np.ndarray:
        return fb.gains(v) * np.array([1.0, 1.0, 2.0, 1.0])

    def none(v: float) -> None:
        return None

    return [
        ("×2 roll-rate gain, rider 0.05 N m, motor 5 N m", doubled, (2.5, 4.2), RideConditions(rider_torque=0.05)),
        ("×2 roll-rate gain, rider 0.2 N m, motor 5 N m", doubled, (2.5, 4.2), RideConditions(rider_torque=0.2)),
        (
            "×2 roll-rate gain, rider 0.2 N m, motor 2 N m",
            doubled,
            (2.5, 4.2),
            RideConditions(rider_torque=0.2, saturation=2.0),
        ),
        ("shipped gains, rider 0.2 N m, motor 5 N m", fb.gains, (3.0, 4.5), RideConditions(rider_torque=0.2)),
        ("shipped gains, rider 0.5 N m, motor 5 N m", fb.gains, (3.0, 4.5), RideConditions(rider_torque=0.5)),
        (
            "shipped gains, rider 0.2 N m, no motor limit",
            fb.gains,
            (3.0, 4.5),
            RideConditions(rider_torque=0.2, saturation=math.inf),
        ),
        ("no assist, rider 0.2 N m", none, (4.5, 5.5), RideConditions(rider_torque=0.2)),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--groups", type=int, default=30, help="records per condition (default 30)")
    args = parser.parse_args()
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None
    cases = conditions(fb)
    print(f"{'condition':48s} {'clean':>9s} {'dof':>4s}  χ²/dof Re/Im  error RMS Re/Im [σ]")
    for i, (name, gains, speeds, ride) in enumerate(cases):
        c = measure_calibration(browser.matrices, browser.g, gains, speeds, ride, args.groups, seed=10 + i)
        print(
            f"{name:48s} {c.clean:>4d}/{c.segments:<4d} {c.dof:>4d}  {c.chi2_real:5.2f}/{c.chi2_imag:<5.2f}     "
            f"{c.z_real:5.2f}/{c.z_imag:<5.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
