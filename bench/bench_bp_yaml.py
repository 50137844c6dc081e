"""``bike-rig params --format bp-yaml`` against BicycleParameters 1.5.2's own reader.

For every shared bicycle, with no rider and with the paper's rider: the export is written as
the command writes it, loaded by ``Meijaard2007ParameterSet._from_yaml`` as it stands, and
compared with bike_rig's values (the largest relative difference must be 0) and its ``rider``
flag. Prints one line per file and exits 1 when one does not load or differs.

``make bench`` puts BicycleParameters on PYTHONPATH (never a test dependency).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from bike_rig.cli.main import main as cli

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "bicycleparameters"


def main() -> int:
    try:
        from bicycleparameters.parameter_sets import Meijaard2007ParameterSet
    except ImportError:
        print("bicycleparameters is not installed (make bench-deps): skipped")
        return 0
    from bike_rig.core.benchmark import compute_parameters
    from bike_rig.core.io_bp import read_bp_measured
    from bike_rig.core.rider import add_rider, resolve_rider

    raws = sorted(SHARED.glob("*/RawData/*Measured.txt"))
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for raw in raws:
            for rider in ("none", "paper"):
                out = Path(tmp) / f"{raw.stem}-{rider}.yml"
                if cli(["params", str(raw), "--rider", rider, "--format", "bp-yaml", "-o", str(out)]) != 0:
                    print(f"{raw.parent.parent.name:12s} rider={rider:5s}: bike-rig params failed")
                    bad += 1
                    continue
                try:
                    loaded = Meijaard2007ParameterSet._from_yaml(str(out))
                except Exception as exc:  # its reader's own errors, whatever they are
                    print(f"{raw.parent.parent.name:12s} rider={rider:5s}: does not load ({exc})")
                    bad += 1
                    continue
                ps = compute_parameters(read_bp_measured(raw))
                chosen = resolve_rider(rider)
                if chosen is not None:
                    ps = add_rider(ps, chosen)
                ours = ps.values()
                worst = max(abs(float(loaded.parameters[k]) - v) / max(abs(v), 1e-300) for k, v in ours.items())
                ok = worst == 0.0 and loaded.includes_rider is (rider != "none")
                bad += not ok
                print(
                    f"{raw.parent.parent.name:12s} rider={rider:5s}: loads, largest relative difference "
                    f"{worst:.1e}, includes_rider={loaded.includes_rider}  {'OK' if ok else 'DIFFERS'}"
                )
    print(f"{len(raws) * 2 - bad} of {len(raws) * 2} exports load in Meijaard2007ParameterSet exactly")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
