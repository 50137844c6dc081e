"""Raw measurements → 25 parameters + canonical matrices with correlated σ, per bicycle.

Times bike_rig and BicycleParameters 1.5.2 (``make bench`` puts it on PYTHONPATH; it is never
a test dependency) on the same raw files in the same process and prints the ratio. Target
(issue 2): ours ≤ 2 ms per bicycle; BicycleParameters ≈ 5 ms.

Both sides start from a parsed raw file (parsing is timed separately for ours).
"""

from __future__ import annotations

import sys
from pathlib import Path

from timing import median_ms  # bench/timing.py

from bike_rig.core.benchmark import PARAMETER_NAMES, compute_parameters
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.measurements import Measurements
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "bicycleparameters"
BIKES = ("Browser", "Browserins", "Crescendo", "Fisher", "Stratos", "Yellow")


def main() -> int:
    try:
        from bicycleparameters import bicycle as bp_bicycle
        from bicycleparameters import io as bp_io
        from bicycleparameters import main as bp_main
    except ImportError:
        bp_main = None
        print("bicycleparameters not importable: run via `make bench`; comparison skipped")
    print(f"{'bicycle':<12}{'parse':>9}{'ours':>9}{'BP 1.5.2':>10}{'ratio':>8}  max rel diff")
    worst_ours = 0.0
    for bike in BIKES:
        raw = SHARED / bike / "RawData" / f"{bike}Measured.txt"
        parse = median_ms(lambda raw=raw: read_bp_measured(raw), 50)
        m = read_bp_measured(raw)

        def ours(m: Measurements = m) -> object:
            ps = compute_parameters(m)
            return canonical_with_sigma(ps)

        t_ours = median_ms(ours)
        worst_ours = max(worst_ours, t_ours)
        line = f"{bike:<12}{parse:>8.2f} {t_ours:>8.3f}"
        if bp_main is not None:
            mp = bp_io.load_parameter_text_file(str(raw))

            def theirs(mp: dict[str, object] = mp) -> object:
                par, _extras = bp_main.calculate_benchmark_from_measured(mp)
                return bp_bicycle.benchmark_par_to_canonical(par)

            t_bp = median_ms(theirs, 50)
            par, _ = bp_main.calculate_benchmark_from_measured(mp)
            ps = compute_parameters(m).parameters
            diff = max(abs(ps.value(k) - float(par[k].nominal_value)) / abs(ps.value(k)) for k in PARAMETER_NAMES)
            line += f"{t_bp:>10.3f}{t_bp / t_ours:>7.1f}x  {diff:.1e}"
        print(line)
    print(f"worst per-bicycle time: {worst_ours:.3f} ms (target <= 2 ms): {'OK' if worst_ours <= 2 else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
