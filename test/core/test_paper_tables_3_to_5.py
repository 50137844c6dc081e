"""Paper Tables 3–5 from the raw measurements.

The canonical matrices, and the parameters and matrices with the rigid rider of Table 1.

Documented facts, measured here:

* Table 3 σ follow the paper's convention: the 25 parameters treated as independent. With that
  convention every printed σ is reproduced within one printed unit. Our default keeps the
  correlations between parameters; it gives smaller σ for M22 and K0_22 of several bicycles
  (listed in ``CORRELATED_SMALLER``), where correlated errors partly cancel.
* Table 3 values: B* M11 and C1_12 inherit the B* frame discrepancy of Table 2.
* Tables 4–5: the paper exchanged IRxx and IFxx. Table 4 prints them swapped, and Table 5 was
  computed with them swapped: with the swap 12 more Table 5 cells match the print than
  without it (e.g. B M22 0.2487 with the swap vs 0.2467 without, printed 0.249).
* Tables 4–5 print no σ; cells are compared within the printed rounding or our propagated σ.
  The B* frame and the C fork differ as in Table 2.
"""

from __future__ import annotations

import pytest

from bike_rig.config.paths import config_dir
from bike_rig.core.benchmark import ParameterSet, compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from bike_rig.core.uncertainty.uncertain import UncertainVector
from test.support.paper import BICYCLE_NAMES, rider_table1, table3, table4, table5

COLUMNS = sorted(BICYCLE_NAMES)

#: Table 3 values outside the printed rounding and σ: (column, entry) -> z-range vs printed σ.
TABLE3_KNOWN: dict[tuple[str, str], tuple[float, float]] = {
    ("B*", "M11"): (2.9, 3.1),
    ("B*", "C1_12"): (1.4, 1.6),
}
#: Entries whose correlated σ is smaller than the printed (independent) σ by more than one unit.
CORRELATED_SMALLER = {
    ("B", "K0_22"),
    ("B*", "K0_22"),
    ("C", "M22"),
    ("G", "M22"),
    ("G", "K0_22"),
    ("S", "K0_22"),
    ("Y", "K0_22"),
}
#: Tables 4–5 cells outside rounding and our σ: (table, column, entry) -> z-range vs our σ.
RIDER_KNOWN: dict[tuple[int, str, str], tuple[float, float]] = {
    (4, "B*", "IBxx"): (4.8, 5.1),
    (4, "B*", "IBxz"): (3.9, 4.2),
    (4, "B*", "IBzz"): (1.6, 1.9),
    (5, "B*", "M11"): (3.1, 3.3),
    (4, "C", "IHxx"): (1.6, 1.8),
    (4, "C", "IHxz"): (1.5, 1.7),
}


def _params(col: str) -> ParameterSet:
    return compute_parameters(load_measurements(config_dir() / "bicycles" / f"{BICYCLE_NAMES[col].lower()}.yaml"))


def _swap_wheel_xx(ps: ParameterSet) -> ParameterSet:
    pv = ps.parameters
    values = pv.values.copy()
    i, j = pv.index("IRxx"), pv.index("IFxx")
    values[[i, j]] = values[[j, i]]
    cov = pv.covariance.copy()
    cov[[i, j], :] = cov[[j, i], :]
    cov[:, [i, j]] = cov[:, [j, i]]
    return ParameterSet(ps.bicycle, UncertainVector(pv.names, values, cov), ps.source)


def test_paper_rider_is_table1() -> None:
    t1 = rider_table1()
    r = PAPER_RIDER
    assert (r.mass, r.x, r.z) == (t1.mass, t1.x, t1.z)
    assert (r.Ixx, r.Iyy, r.Izz, r.Ixz) == (t1.inertia[0][0], t1.inertia[1][1], t1.inertia[2][2], t1.inertia[0][2])
    assert t1.inertia[0][1] == t1.inertia[1][2] == 0.0


@pytest.mark.parametrize("col", COLUMNS)
def test_table3(col: str) -> None:
    ps = _params(col)
    paper = canonical_with_sigma(ps, SigmaConvention.PAPER).coefficients
    corr = canonical_with_sigma(ps, SigmaConvention.CORRELATED).coefficients
    assert list(paper.values) == list(corr.values)
    for key, cell in table3()[col].items():
        value = paper.value(key)
        if cell.sigma is None:  # structural zeros printed once as '0.0 NA'
            assert value == 0.0 and paper.sigma(key) == 0.0 and corr.sigma(key) == 0.0, key
            continue
        assert cell.sigma_decimals is not None
        diff = abs(value - cell.value)
        if (col, key) in TABLE3_KNOWN:
            lo, hi = TABLE3_KNOWN[(col, key)]
            assert lo <= diff / cell.sigma <= hi, (col, key, value, cell)
        else:
            assert diff <= cell.rounding_half_unit() * (1 + 1e-9) or diff <= cell.sigma, (col, key, value, cell)
        unit = 10.0**-cell.sigma_decimals
        assert abs(paper.sigma(key) - cell.sigma) <= unit, (col, key, paper.sigma(key), cell.sigma)
        corr_units = (corr.sigma(key) - cell.sigma) / unit
        if (col, key) in CORRELATED_SMALLER:
            assert corr_units < -1.0 and corr.sigma(key) < paper.sigma(key), (col, key)
        else:
            assert abs(corr_units) <= 1.0, (col, key, corr.sigma(key), cell.sigma)


@pytest.mark.parametrize("col", COLUMNS)
def test_tables_4_and_5_with_the_rider(col: str) -> None:
    with_rider = add_rider(_params(col), PAPER_RIDER)
    pv = with_rider.parameters
    for key, cell in table4()[col].items():
        ours = {"IRxx": "IFxx", "IFxx": "IRxx"}.get(key, key)  # Table 4 prints them swapped
        _check(4, col, key, pv.value(ours), pv.sigma(ours), cell.value, cell.rounding_half_unit())
    swapped = canonical_with_sigma(_swap_wheel_xx(with_rider)).coefficients
    for key, cell in table5()[col].items():
        _check(5, col, key, swapped.value(key), swapped.sigma(key), cell.value, cell.rounding_half_unit())


def test_table5_was_computed_with_the_wheel_inertias_swapped() -> None:
    def misses(swap: bool) -> int:
        count = 0
        for col in COLUMNS:
            ps = add_rider(_params(col), PAPER_RIDER)
            co = canonical_with_sigma(_swap_wheel_xx(ps) if swap else ps).coefficients
            for key, cell in table5()[col].items():
                count += abs(co.value(key) - cell.value) > cell.rounding_half_unit() * (1 + 1e-9)
        return count

    assert misses(swap=False) - misses(swap=True) >= 10


def _check(table: int, col: str, key: str, value: float, sigma: float, printed: float, half_unit: float) -> None:
    diff = abs(value - printed)
    if (table, col, key) in RIDER_KNOWN:
        lo, hi = RIDER_KNOWN[(table, col, key)]
        assert lo <= diff / sigma <= hi, (table, col, key, value, printed)
    else:
        assert diff <= half_unit * (1 + 1e-9) or diff <= sigma, (table, col, key, value, sigma, printed)
