"""Tests of the paper-table parser against the paper's own text."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from test.support.paper import (
    BICYCLE_NAMES,
    BICYCLES,
    COEFFICIENT_KEYS,
    PAPER_FILE,
    PARAMETER_KEYS,
    SHARED_ENV_VAR,
    PaperFormatError,
    Printed,
    SharedFolderMissingError,
    Table,
    paper_path,
    rider_table1,
    shared_dir,
    table2,
    table3,
    table4,
    table5,
)


def _raw_row(label: str, occurrence: int = 0) -> list[str]:
    """The whitespace-separated cells of the ``occurrence``-th line of the paper starting with ``label``."""
    lines = [line for line in paper_path().read_text(encoding="utf-8").splitlines() if line.startswith(label + "\t")]
    return lines[occurrence].split("\t", 1)[1].split()


def _formatted_row(table: Table, key: str) -> list[str]:
    """The cells of row ``key``, each formatted with its printed decimals."""
    tokens: list[str] = []
    for bicycle in BICYCLES:
        cell = table[bicycle][key]
        sigma = "NA" if cell.sigma is None else f"{cell.sigma:.{cell.sigma_decimals}f}"
        tokens += [f"{cell.value:.{cell.value_decimals}f}", sigma]
    return tokens


def test_shared_dir_holds_the_paper() -> None:
    assert paper_path() == shared_dir() / PAPER_FILE
    assert paper_path().is_file()


@pytest.mark.parametrize("table", [table2, table4])
def test_parameter_tables_have_eight_bicycles_of_25_parameters(table: Callable[[], Table]) -> None:
    parsed = table()
    assert tuple(parsed) == BICYCLES
    for cells in parsed.values():
        assert tuple(cells) == PARAMETER_KEYS
        assert len(cells) == 25


@pytest.mark.parametrize("table", [table3, table5])
def test_coefficient_tables_have_eight_bicycles_of_16_coefficients(table: Callable[[], Table]) -> None:
    parsed = table()
    assert tuple(parsed) == BICYCLES
    for cells in parsed.values():
        assert tuple(cells) == COEFFICIENT_KEYS
        assert len(cells) == 16


def test_table2_spot_checks() -> None:
    t2 = table2()
    assert t2["B"]["c"] == Printed(0.069, 0.002, 3, 3)
    assert t2["B"]["c"].rounding_half_unit() == pytest.approx(0.0005)
    assert t2["B"]["lam"] == Printed(0.400, 0.003, 3, 3)
    assert t2["Y*"]["c"].value == 0.180
    assert t2["P"]["xB"] == Printed(0.38, 0.02, 2, 2)
    assert t2["S"]["IBxz"] == Printed(-0.0383, 0.0004, 4, 4)
    assert t2["B"]["IHxz"] == Printed(-0.072, 0.0008, 3, 4)
    assert t2["B*"]["mB"].value == 14.71
    assert all(cell.sigma is not None for cells in t2.values() for cell in cells.values())


def test_table3_spot_checks() -> None:
    t3 = table3()
    assert t3["Y*"]["M22"] == Printed(0.301, 0.006, 3, 3)
    assert t3["B"]["C1_21"] == Printed(-0.45, 0.004, 2, 3)
    assert t3["G"]["K0_11"] == Printed(-5.2, 0.03, 1, 2)
    assert t3["C"]["K2_22"] == Printed(1.05, 0.03, 2, 2)


def test_table5_spot_checks() -> None:
    t5 = table5()
    assert t5["B"]["K2_12"] == Printed(74.125, None, 3, None)
    assert t5["Y*"]["K2_22"].value == 4.495
    assert t5["B"]["M11"].value == 102.78
    assert t5["C"]["K0_22"].value == -0.91


def test_na_is_none() -> None:
    for table in (table4(), table5()):
        for cells in table.values():
            for cell in cells.values():
                assert cell.sigma is None
                assert cell.sigma_decimals is None


@pytest.mark.parametrize("table", [table3, table5])
def test_structural_zeros_span_all_bicycles(table: Callable[[], Table]) -> None:
    for cells in table().values():
        for key in ("C1_11", "K2_11", "K2_21"):
            assert cells[key] == Printed(0.0, None, 1, None)


def test_printed_cells_round_trip_to_the_text() -> None:
    # Formatting each cell with its printed decimals gives back the paper's characters.
    assert _formatted_row(table2(), "c") == _raw_row("c [m]")
    assert _formatted_row(table4(), "c") == _raw_row("c [m]", 1)
    assert _formatted_row(table3(), "K0_21") == _raw_row("K_{021}")
    assert _formatted_row(table5(), "K2_22") == _raw_row("K_{222}", 1)


def test_symmetric_coefficients_are_printed_equal() -> None:
    for table in (table3(), table5()):
        for cells in table.values():
            assert cells["M12"] == cells["M21"]
            assert cells["K0_12"] == cells["K0_21"]


def test_rider_table1() -> None:
    rider = rider_table1()
    assert rider.mass == 72
    assert rider.x == 0.2909
    assert rider.z == -1.1091
    assert rider.inertia[0][0] == 7.9985
    assert rider.inertia[0][2] == rider.inertia[2][0] == -1.9272
    assert rider.inertia[1][1] == 8.0689
    assert rider.inertia[2][2] == 2.3624
    assert rider.inertia[0][1] == rider.inertia[1][0] == rider.inertia[1][2] == rider.inertia[2][1] == 0.0


def test_table4_adds_the_rider_mass_to_the_frame() -> None:
    t2, t4, rider = table2(), table4(), rider_table1()
    for bicycle in BICYCLES:
        assert t4[bicycle]["mB"].value == pytest.approx(t2[bicycle]["mB"].value + rider.mass)


def test_tables_2_and_4_swap_irxx_and_ifxx() -> None:
    # Table 4 rounds to three decimals (trailing zeros dropped), so compare at half of 0.001.
    half = 0.0005 + 1e-12
    t2, t4 = table2(), table4()
    b2, b4 = t2["B"], t4["B"]
    assert (b2["IRxx"].value, b2["IFxx"].value) == (0.0904, 0.0884)
    assert (b4["IRxx"].value, b4["IFxx"].value) == (0.088, 0.09)
    assert abs(b4["IRxx"].value - b2["IFxx"].value) <= half
    assert abs(b4["IFxx"].value - b2["IRxx"].value) <= half
    assert abs(b4["IRxx"].value - b2["IRxx"].value) > half
    assert abs(b4["IFxx"].value - b2["IFxx"].value) > half
    for bicycle in BICYCLES:  # swapped for every bicycle (G and P are too close to tell)
        assert abs(t4[bicycle]["IRxx"].value - t2[bicycle]["IFxx"].value) <= half
        assert abs(t4[bicycle]["IFxx"].value - t2[bicycle]["IRxx"].value) <= half


def test_returned_tables_are_fresh_copies() -> None:
    first = table2()
    first["B"].clear()
    assert len(table2()["B"]) == 25


def test_bicycle_names_have_data_folders() -> None:
    assert set(BICYCLE_NAMES) == set(BICYCLES) - {"P", "Y*"}
    for name in BICYCLE_NAMES.values():
        assert (shared_dir() / "data" / "bicycleparameters" / name).is_dir()


def test_missing_shared_folder_is_a_clear_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv(SHARED_ENV_VAR, str(tmp_path / "nowhere"))
    with pytest.raises(SharedFolderMissingError, match=SHARED_ENV_VAR):
        shared_dir()
    monkeypatch.setenv(SHARED_ENV_VAR, str(tmp_path))
    assert shared_dir() == tmp_path.resolve()
    with pytest.raises(FileNotFoundError, match="paper"):
        table2()


def _edited_paper(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, old: str, new: str) -> None:
    text = paper_path().read_text(encoding="utf-8")
    assert old in text
    (tmp_path / PAPER_FILE).parent.mkdir(parents=True)
    (tmp_path / PAPER_FILE).write_text(text.replace(old, new, 1), encoding="utf-8")
    monkeypatch.setenv(SHARED_ENV_VAR, str(tmp_path))


def test_a_row_missing_a_cell_fails_loudly(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    _edited_paper(monkeypatch, tmp_path, "c [m]\t0.069\t0.002\t", "c [m]\t0.069\t")
    with pytest.raises(PaperFormatError, match=r"expected 16 cells.*c \[m\]\\t0\.069") as raised:
        table2()
    assert raised.value.line is not None


def test_odd_spacing_inside_a_row_is_tolerated(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    _edited_paper(monkeypatch, tmp_path, "c [m]\t0.069\t0.002\t", "c  [m] \t 0.069 \t\t0.002  \t")
    assert table2()["B"]["c"] == Printed(0.069, 0.002, 3, 3)


def test_an_unknown_label_fails_loudly(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    _edited_paper(monkeypatch, tmp_path, "M_{22}\t0.220", "M_{23}\t0.220")
    with pytest.raises(PaperFormatError, match=r"M_\{23\}"):
        table3()
