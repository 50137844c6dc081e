"""Zero surface-plate readings and a stray frame distance: bike_rig against BicycleParameters 1.5.2.

For every ``<Name>Measured.txt`` in ``test/core/data/zero_readings`` (BicycleParameters'
``GyroMeasured.txt`` and ``Balanceassistv1Measured.txt``, and two Rigid-derived files of the
tests) this recomputes the parameters live with BicycleParameters
(``io.load_parameter_text_file``, then ``main.calculate_benchmark_from_measured``), checks them
against the stored ``<Name>Benchmark.txt`` that ``test/core/test_refined_zero_readings.py`` reads,
prints bike_rig's largest relative difference, and, where the two σ differ by more than 0.1 %,
both beside a Monte Carlo propagation of the raw readings' σ through the same formulas
(independent normal readings, as both libraries assume). ``--write`` rewrites the stored files.

``make bench`` puts BicycleParameters on PYTHONPATH (never a test dependency).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import sys
import warnings
from pathlib import Path

import numpy as np

from bike_rig.core.benchmark import PARAMETER_NAMES, PART_GROUPS, benchmark_formulas, compute_parameters
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from bike_rig.core.measurements import Measurements
from bike_rig.core.uncertainty.uncertain import monte_carlo

DATA = Path(__file__).resolve().parents[1] / "test" / "core" / "data" / "zero_readings"
SAMPLES = 100_000
SEED = 11

HEADER = """\
# {name}: the benchmark parameters BicycleParameters 1.5.2 computes from {name}Measured.txt:
#   mp = bicycleparameters.io.load_parameter_text_file("{name}Measured.txt")
#   par, _ = bicycleparameters.main.calculate_benchmark_from_measured(mp)
# written as value+/-sigma (par[k].nominal_value, par[k].std_dev; full float precision) by
# `python bench/bench_zero_readings.py --write`; `make bench` recomputes and compares them.
# Derived from BicycleParameters data and software: BSD-2-Clause, (c) 2011-2025 BicycleParameters Authors.
"""


def bp_parameters(path: Path) -> dict[str, tuple[float, float]]:
    """BicycleParameters' parameters (and per-part outputs) of one raw file: ``{key: (value, σ)}``."""
    from bicycleparameters import io as bp_io
    from bicycleparameters import main as bp_main

    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")  # uncertainties warns about its σ = 0 readings
        par, _ = bp_main.calculate_benchmark_from_measured(bp_io.load_parameter_text_file(str(path)))
    keys = list(PARAMETER_NAMES) + [k for group in PART_GROUPS if all(n in par for n in group) for k in group]
    return {k: (float(getattr(par[k], "nominal_value", par[k])), float(getattr(par[k], "std_dev", 0.0))) for k in keys}


def benchmark_text(name: str, values: dict[str, tuple[float, float]]) -> str:
    """The stored file: the header, then ``key = value+/-sigma`` per line."""
    body = "".join(f"{k} = {v!r}+/-{s!r}\n" for k, (v, s) in values.items())
    return HEADER.format(name=name) + body


def monte_carlo_sigma(m: Measurements, names: list[str]) -> dict[str, float]:
    """σ of ``names`` over SAMPLES independent normal draws of the readings (SEED)."""
    values = {k: r.value for k, r in m.readings.items()}
    perturbed = [k for k, r in m.readings.items() if r.sigma > 0]
    cov = np.diag([m.readings[k].sigma ** 2 for k in perturbed])
    draws = monte_carlo(benchmark_formulas, values, cov, perturbed, SAMPLES, SEED, names)
    return {k: float(np.std(draws[k])) for k in names}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="rewrite the stored <Name>Benchmark.txt files")
    args = parser.parse_args(argv)
    try:
        import bicycleparameters  # noqa: F401
    except ImportError:
        print("bicycleparameters not importable: run via `make bench`; comparison skipped")
        return 0
    logging.getLogger("bike_rig").setLevel(logging.ERROR)  # the stray aB4's note
    status = 0
    for raw in sorted(DATA.glob("*Measured.txt")):
        name = raw.name[: -len("Measured.txt")]
        live = bp_parameters(raw)
        stored_path = DATA / f"{name}Benchmark.txt"
        if args.write:
            stored_path.write_text(benchmark_text(name, live))
        stored = read_bp_parameters(stored_path)
        vectors = [stored.parameters] + ([stored.parts] if stored.parts is not None else [])
        # BicycleParameters' σ move in the last bit from run to run (uncertainties sums its
        # variables in an order that depends on their memory addresses)
        stale = max(
            max(abs(vec.value(k) - live[k][0]) / abs(live[k][0]), abs(vec.sigma(k) - live[k][1]) / (live[k][1] or 1.0))
            for vec in vectors
            for k in vec.names
        )
        m = read_bp_measured(raw)
        ours = compute_parameters(m)
        mine = [ours.parameters] + ([ours.parts] if ours.parts is not None else [])
        worst = max(abs(vec.value(k) - live[k][0]) / abs(live[k][0]) for vec in mine for k in vec.names)
        print(
            f"{name}: stored values and σ against BicycleParameters now: max rel diff {stale:.1e}; "
            f"bike_rig's {sum(len(v.names) for v in mine)} values: max rel diff {worst:.1e}"
        )
        if stale > 1e-12 or worst > 1e-9:
            status = 1
        sigmas = {k: vec.sigma(k) for vec in mine for k in vec.names}
        differ = [k for k, s in sigmas.items() if live[k][1] > 0 and abs(s / live[k][1] - 1) > 1e-3]
        mc = monte_carlo_sigma(m, differ) if differ else {}
        for k in differ:
            s_ours, s_bp, s_mc = sigmas[k], live[k][1], mc[k]
            print(
                f"  σ {k:<5} bike_rig {s_ours:.4g} ({s_ours / s_mc - 1:+.1%}), BicycleParameters {s_bp:.4g} "
                f"({s_bp / s_mc - 1:+.1%}), Monte Carlo {s_mc:.4g} ({SAMPLES} draws)"
            )
    return status


if __name__ == "__main__":
    sys.exit(main())
