"""Linear versus Monte Carlo σ of the benchmark parameters, with line conditioning.

For each bicycle in the shared BicycleParameters data: the smallest angle between the
hanging lines of each part, and the ratio σ_MC / σ_linear of every parameter whose ratio
departs from 1 by more than the threshold (seeded draws through the raw readings).

Usage: python bench/bench_com_mc.py [samples] [threshold]
"""

from __future__ import annotations

import glob
import math
import sys

import numpy as np

from bike_rig.core import com
from bike_rig.core.benchmark import compute_parameters, hung_parts, monte_carlo_parameters
from bike_rig.core.loader import load_measurements


def main() -> None:
    samples = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    threshold = float(sys.argv[2]) if len(sys.argv) > 2 else 0.02
    for d in sorted(glob.glob("/work/shared/data/bicycleparameters/*/")):
        files = glob.glob(d + "RawData/*Measured*")
        if not files:
            continue
        name = d.rstrip("/").split("/")[-1]
        m = load_measurements(files[0])
        angles = []
        for part in hung_parts(m.readings):
            slopes = [math.tan(math.radians(m.value(f"alpha{part}{i}"))) for i in m.orientations(part)]
            angles.append(f"{part} {math.degrees(com.line_conditioning(slopes).min_angle):.1f}°")
        lin = compute_parameters(m).parameters
        mc = monte_carlo_parameters(m, samples, seed=1)
        off = []
        for i, p in enumerate(lin.names):
            s = float(np.sqrt(lin.covariance[i, i]))
            if s > 0:
                r = float(np.std(mc[p], ddof=1)) / s
                if abs(r - 1.0) > threshold:
                    off.append(f"{p} {r:.3f}")
        print(f"{name:11s} min angle {', '.join(angles):28s} MC/lin off by >{threshold:.1%}: {', '.join(off) or '-'}")


if __name__ == "__main__":
    main()
