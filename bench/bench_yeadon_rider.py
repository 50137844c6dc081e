"""A Yeadon rider seated on every shared bicycle: bike_rig against BicycleParameters 1.5.2.

Jason (the shared Yeadon measurements) in his Browser configuration on each bicycle whose raw
file has the rider-geometry keys. For each: the time to seat him (bike_rig without the rider's
σ; BicycleParameters' ``configure_rider``), the largest relative difference of the rider's seven
numbers where both seat him, and how far BicycleParameters leaves his hands from the grips
(measured on its own posed yeadon human, against the grips of ``LhbR``, ``LhbF``, ``whb``): where
it cannot reach it says nothing and returns a rider with detached hands; bike_rig refuses, naming
the geometry and the lean that would reach (its issues #6, #9, #19).

``make bench`` puts BicycleParameters on PYTHONPATH (never a test dependency).
"""

from __future__ import annotations

import contextlib
import io
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.rider_pose import LIMBS, RiderPoseError, limb_end_point
from bike_rig.core.rider_yeadon import (
    RIDER_GEOMETRY_KEYS,
    YeadonRider,
    pose_targets,
    read_yeadon_configuration,
    read_yeadon_measurements,
    rider_geometry,
    seat_rider,
)

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "bicycleparameters"
JASON = SHARED / "riders" / "Jason" / "RawData"


def _bp_seat(
    bike: str, work: Path, bp_rider: object, bp_io: object, bp_main: object
) -> tuple[np.ndarray, object, float]:
    """BicycleParameters' rider (7 numbers), its posed human, and the seconds it took."""
    rider_dir = work / "Jason"
    (rider_dir / "RawData").mkdir(parents=True, exist_ok=True)
    shutil.copy(JASON / "JasonYeadonMeas.txt", rider_dir / "RawData" / "JasonYeadonMeas.txt")
    shutil.copy(JASON / "JasonBrowserYeadonCFG.txt", rider_dir / "RawData" / f"Jason{bike}YeadonCFG.txt")
    measured = bp_io.load_parameter_text_file(str(SHARED / bike / "RawData" / f"{bike}Measured.txt"))  # type: ignore[attr-defined]
    par, _ = bp_main.calculate_benchmark_from_measured(measured)  # type: ignore[attr-defined]
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        rider_par, human, _ = bp_rider.configure_rider(str(rider_dir), bike, par, measured, False)  # type: ignore[attr-defined]
    seconds = time.perf_counter() - t0
    values = np.array([float(rider_par[k]) for k in ("mB", "xB", "zB", "IBxx", "IByy", "IBzz", "IBxz")])
    return values, human, seconds


def _hand_miss(human: object, bike: str, ps: object, rider: YeadonRider) -> float:
    """Largest distance of a posed hand from its grip, m (BicycleParameters' human, our grip definition)."""
    _, targets = pose_targets(rider_geometry(rider, ps), ps.values())  # type: ignore[attr-defined]
    return max(float(np.linalg.norm(limb_end_point(human, limb) - targets[limb.name])) for limb in LIMBS if limb.arm)


def main() -> int:
    try:
        from bicycleparameters import io as bp_io
        from bicycleparameters import main as bp_main
        from bicycleparameters import rider as bp_rider
    except ImportError:
        print("bicycleparameters not importable: run via `make bench`; comparison skipped")
        bp_rider = None
    rider = YeadonRider(
        "Jason",
        read_yeadon_measurements(JASON / "JasonYeadonMeas.txt"),
        read_yeadon_configuration(JASON / "JasonBrowserYeadonCFG.txt"),
        measurement_sigma=0.0,
        mass_sigma=0.0,
        pose_sigma=False,
    )
    print(f"{'bicycle':<12}{'ours ms':>9}{'BP ms':>8}  {'max rel diff':>12}  {'BP hands off grips':>18}  bike_rig")
    with tempfile.TemporaryDirectory() as tmp:
        for raw in sorted(SHARED.glob("*/RawData/*Measured.txt")):
            m = read_bp_measured(raw)
            if not all(k in m.extras for k in RIDER_GEOMETRY_KEYS) or "w" not in m.readings:
                continue
            bike = raw.parent.parent.name
            ps = compute_parameters(m)
            t0 = time.perf_counter()
            try:
                ours = seat_rider(rider, ps)
                mine = np.array([ours.mass, ours.x, ours.z, ours.Ixx, ours.Iyy, ours.Izz, ours.Ixz])
                verdict = "seated, hands on the grips"
            except RiderPoseError as exc:
                parts = str(exc).split("; ")
                lean = next((p for p in parts if "lean of somersault" in p), "")
                mine, verdict = None, f"refused: {parts[0].split(': ')[1]}" + (f"; {lean}" if lean else "")
            t_ours = 1e3 * (time.perf_counter() - t0)
            line = f"{bike:<12}{t_ours:>9.0f}"
            if bp_rider is not None:
                theirs, human, t_bp = _bp_seat(bike, Path(tmp) / bike, bp_rider, bp_io, bp_main)
                diff = "" if mine is None else f"{np.max(np.abs(mine - theirs) / np.abs(theirs)):.1e}"
                line += f"{1e3 * t_bp:>8.0f}  {diff:>12}  {_hand_miss(human, bike, ps, rider):>16.3f} m"
            print(f"{line}  {verdict}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
