"""Eigenvalues of the Whipple model over 100,000 speeds, and the critical speeds.

Times, in one process and on the same speeds (0..10 m/s, benchmark bicycle of Meijaard et al.
2007):

* ours: :func:`bike_rig.core.whipple.eigenvalues` (closed-form quartic roots + mode tracking),
  without and with eigenvectors; :func:`~bike_rig.core.whipple.critical_speeds`;
* numpy: ``np.linalg.eig`` batched on the same state-space matrices ``A`` (``eigvals`` too);
* BicycleParameters 1.5.2, as its users do it: ``bicycle.benchmark_par_to_canonical``, then
  ``ab_matrix`` + ``np.linalg.eig`` per speed (``Bicycle.eig``) and ``bicycle.sort_modes``
  (timed separately: the sum is the comparable figure, since ours includes tracking).
  ``make bench`` puts it on PYTHONPATH; elsewhere set ``BIKE_RIG_BENCH_DEPS`` to a folder that
  holds it (``pip install --target DIR bicycleparameters==1.5.2``). Skipped if not importable.

Targets (our issue): 100k speeds with tracking <= 35 ms; critical speeds <= 5 ms.
Prints medians and ratios; the only checks are sanity checks of agreement.
"""

from __future__ import annotations

import importlib
import itertools
import os
import sys
from typing import Any

import numpy as np
from timing import median_ms  # bench/timing.py

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet
from bike_rig.core.loader import load_input
from bike_rig.core.whipple import (
    canonical_matrices,
    critical_speeds,
    eigenvalues,
    state_space,
)

N_SPEEDS = 100_000
#: The Meijaard et al. (2007) benchmark bicycle, as shipped in config/bicycles/benchmark.yaml.
_SHIPPED = load_input(config_file("bicycles/benchmark.yaml"))
assert isinstance(_SHIPPED, ParameterSet)
BENCHMARK: dict[str, float] = _SHIPPED.values()
G = BENCHMARK["g"]


def worst_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest root distance under the best matching of each row's 4 roots."""
    perms = np.array(list(itertools.permutations(range(4))))
    dist = np.abs(b[:, perms] - a[:, None, :])
    best = np.argmin(dist.sum(axis=-1), axis=1)
    return float(dist[np.arange(a.shape[0]), best].max())


def import_bicycleparameters() -> Any:
    """The ``bicycleparameters.bicycle`` module, or None."""
    extra = os.environ.get("BIKE_RIG_BENCH_DEPS")
    if extra:
        sys.path.insert(0, extra)
    try:
        return importlib.import_module("bicycleparameters.bicycle")
    except ImportError:
        return None


def bp_eig(bicycle: Any, speeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """BicycleParameters' ``Bicycle.eig`` route: canonical matrices, ab_matrix + eig per speed."""
    m, c1, k0, k2 = bicycle.benchmark_par_to_canonical(BENCHMARK)
    evals = np.zeros((speeds.size, 4), dtype=complex)
    evecs = np.zeros((speeds.size, 4, 4), dtype=complex)
    for i, v in enumerate(speeds):
        a, _ = bicycle.ab_matrix(m, c1, k0, k2, v, G)
        evals[i], evecs[i] = np.linalg.eig(a)
    return evals, evecs


def bp_route(bicycle: Any, speeds: np.ndarray) -> tuple[Any, ...]:
    """BicycleParameters users' full route: :func:`bp_eig`, then ``bicycle.sort_modes``."""
    return tuple(bicycle.sort_modes(*bp_eig(bicycle, speeds)))


def main() -> int:
    speeds = np.linspace(0.0, 10.0, N_SPEEDS)
    mats = canonical_matrices(BENCHMARK)
    print(f"Whipple eigenvalues, benchmark bicycle, {N_SPEEDS} speeds 0..10 m/s")

    ours = median_ms(lambda: eigenvalues(mats, G, speeds), 31)
    ours_vec = median_ms(lambda: eigenvalues(mats, G, speeds, vectors=True), 15)
    crit = median_ms(lambda: critical_speeds(mats, G), 201)
    a_time = median_ms(lambda: state_space(mats, speeds, G), 11)
    a, _ = state_space(mats, speeds, G)
    eig_time = median_ms(lambda: np.linalg.eig(a), 5)
    eigvals_time = median_ms(lambda: np.linalg.eigvals(a), 5)

    print(f"  ours, tracked + labelled          {ours:9.2f} ms   (target <= 35 ms)")
    print(f"  ours, with eigenvectors           {ours_vec:9.2f} ms")
    print(f"  critical speeds (weave, capsize)  {crit:9.3f} ms   (target <= 5 ms)")
    print(f"  state_space A for all speeds      {a_time:9.2f} ms")
    print(f"  np.linalg.eig batched on A        {eig_time:9.2f} ms   ({eig_time / ours_vec:.1f}x ours+vectors)")
    print(f"  np.linalg.eigvals batched on A    {eigvals_time:9.2f} ms   ({eigvals_time / ours:.1f}x ours)")

    # Sanity: same eigenvalues as numpy (1 in 50 speeds), critical speeds of the paper.
    sweep = eigenvalues(mats, G, speeds, vectors=True)
    sub = slice(None, None, 50)
    diff = worst_distance(sweep.eigenvalues[sub], np.linalg.eigvals(a[sub]))
    cs = critical_speeds(mats, G)
    assert sweep.eigenvectors is not None
    resid = np.abs(a @ sweep.eigenvectors - sweep.eigenvectors * sweep.eigenvalues[:, None, :]).max()
    print(f"  max |ours - eigvals| = {diff:.1e} 1/s, max |A x - s x| = {resid:.1e}")
    print(f"  weave {cs.weave:.12f} m/s, capsize {cs.capsize:.12f} m/s")
    print("  (paper: weave 4.29238253634111, capsize 6.02426201538837)")
    ok = diff < 1e-6 and cs.weave is not None and abs(cs.weave - 4.29238253634111) < 1e-9

    bicycle = import_bicycleparameters()
    if bicycle is None:
        print(
            "  bicycleparameters not importable (run via `make bench` or set BIKE_RIG_BENCH_DEPS): comparison skipped"
        )
        return 0 if ok else 1
    bp_eig_only = median_ms(lambda: bp_eig(bicycle, speeds), 3)
    evals, evecs = bp_eig(bicycle, speeds)
    bp_sort = median_ms(lambda: bicycle.sort_modes(evals, evecs), 3)
    bp = bp_eig_only + bp_sort
    m_bp = bicycle.benchmark_par_to_canonical(BENCHMARK)
    mat_diff = max(
        float(np.abs(np.asarray(x) - y).max()) for x, y in zip(m_bp, (mats.M, mats.C1, mats.K0, mats.K2), strict=True)
    )
    weave, capsize, caster = bp_route(bicycle, speeds[::1000])
    bp_ev = np.column_stack([weave["evals"], capsize["evals"], caster["evals"]])
    bp_diff = worst_distance(eigenvalues(mats, G, speeds[::1000]).eigenvalues, bp_ev)
    ratios = f"{bp / ours_vec:.0f}x ours+vectors, {bp / ours:.0f}x ours"
    print(f"  BicycleParameters 1.5.2 eig per speed  {bp_eig_only:9.1f} ms")
    print(f"  BicycleParameters 1.5.2 sort_modes     {bp_sort:9.1f} ms")
    print(f"  BicycleParameters 1.5.2 eig+sort_modes {bp:9.1f} ms   ({ratios})")
    print(f"  BP vs ours: max matrix diff {mat_diff:.1e}, max eigenvalue diff {bp_diff:.1e} 1/s")
    return 0 if ok and bp_diff < 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
