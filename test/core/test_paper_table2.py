"""Paper Table 2 from the raw measurements: within the printed rounding or the paper's σ.

Known discrepancies, measured and kept as expectations (never hidden by a looser bound):

* B* (Browserins) frame: the raw frame data do not give the printed frame inertias; the paper
  used other data. Printed IBxx 0.866 vs 1.045 from the raw file (36σ), IBxz -0.181 vs -0.113
  (17σ), IBzz 1.867 vs 1.850 (2.1σ). BicycleParameters' ``BrowserinsBenchmark.txt`` agrees with
  ours (see ``test_against_bicycleparameters.py``).
* B (Browser) frame: IBxx 0.5296 vs printed 0.527 (1.3σ), IBxz -0.1163 vs -0.114 (2.3σ).
* C (Crescendo) fork: IHxx 0.3840 vs 0.387 (1.5σ), IHxz -0.0778 vs -0.076 (1.8σ).

Each listed cell must stay outside the paper's σ by the stated z-range, and every other cell must
match the print within its rounding or within σ.
"""

from __future__ import annotations

import pytest

from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.io_bp import read_bp_measured
from test.support.paper import BICYCLE_NAMES, shared_dir, table2

#: (paper column, parameter) -> (min, max) of |ours - printed| / printed σ.
KNOWN_DISCREPANCIES: dict[tuple[str, str], tuple[float, float]] = {
    ("B*", "IBxx"): (35.0, 37.0),
    ("B*", "IBxz"): (16.5, 17.5),
    ("B*", "IBzz"): (2.0, 2.2),
    ("B", "IBxx"): (1.2, 1.4),
    ("B", "IBxz"): (2.2, 2.4),
    ("C", "IHxx"): (1.4, 1.6),
    ("C", "IHxz"): (1.7, 1.9),
}


def _ours(col: str) -> dict[str, tuple[float, float]]:
    bike = BICYCLE_NAMES[col]
    path = shared_dir() / "data" / "bicycleparameters" / bike / "RawData" / f"{bike}Measured.txt"
    pv = compute_parameters(read_bp_measured(path)).parameters
    return {n: (pv.value(n), pv.sigma(n)) for n in pv.names}


@pytest.mark.parametrize("col", sorted(BICYCLE_NAMES))
def test_table2_column(col: str) -> None:
    ours = _ours(col)
    printed = table2()[col]
    assert len(printed) == 25
    for key, cell in printed.items():
        value, _sigma = ours[key]
        diff = abs(value - cell.value)
        assert cell.sigma is not None
        if (col, key) in KNOWN_DISCREPANCIES:
            lo, hi = KNOWN_DISCREPANCIES[(col, key)]
            assert lo <= diff / cell.sigma <= hi, (col, key, value, cell.value)
        else:
            assert diff <= cell.rounding_half_unit() * (1 + 1e-9) or diff <= cell.sigma, (col, key, value, cell)


#: σ that differ from the print by more than one printed unit (the frame data again):
#: (column, parameter) -> (min, max) of (ours - printed) in units of the printed last digit.
KNOWN_SIGMA_DISCREPANCIES: dict[tuple[str, str], tuple[float, float]] = {
    ("B", "IByy"): (1.0, 1.05),  # ours 0.00401, printed 0.003
    ("B*", "IByy"): (1.7, 1.9),  # ours 0.00678, printed 0.005
}


@pytest.mark.parametrize("col", sorted(BICYCLE_NAMES))
def test_table2_sigmas(col: str) -> None:
    """Our σ agree with the printed σ (one significant digit) within one printed unit.

    The printed σ are neither consistently rounded nor truncated versions of ours (e.g. ours
    0.00152 prints as 0.001, ours 0.00401 prints as 0.003), so one unit is the honest bound.
    """
    ours = _ours(col)
    for key, cell in table2()[col].items():
        assert cell.sigma is not None and cell.sigma_decimals is not None
        units = (ours[key][1] - cell.sigma) / 10.0**-cell.sigma_decimals
        if (col, key) in KNOWN_SIGMA_DISCREPANCIES:
            lo, hi = KNOWN_SIGMA_DISCREPANCIES[(col, key)]
            assert lo <= units <= hi, (col, key, ours[key][1], cell.sigma)
        else:
            assert abs(units) <= 1.0, (col, key, ours[key][1], cell.sigma)
