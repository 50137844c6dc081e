"""The printed tables of the paper, parsed from its text at run time.

*Accurate Measurement of Bicycle Parameters* (Moore, Hubbard, Schwab, Kooijman) lives in the shared
folder as ``paper/000_abe15806ef2d8adc.txt`` (text extracted from the PDF). Tests compare our numbers
with what the paper prints, so nothing here is hard-coded: every number is read from that text, and
a row that does not look as expected raises :class:`PaperFormatError` naming the line and its text.

Tables (Appendix A unless said otherwise):

- Table 1 (Section 10): the rigid rider, :func:`rider_table1`.
- Table 2: the 25 benchmark parameters of the eight bicycles with σ, :func:`table2`.
- Table 3: the canonical matrix coefficients with σ, :func:`table3`.
- Table 4: the 25 parameters with the rigid rider added (σ all NA), :func:`table4`.
- Table 5: the canonical matrix coefficients with the rider (σ all NA), :func:`table5`.

Tables 2-5 come back as ``{bicycle column: {key: Printed}}``; the columns are :data:`BICYCLES`
(``B, B*, C, G, P, S, Y, Y*``), the keys :data:`PARAMETER_KEYS` (BicycleParameters names: ``'λ [rad]'``
-> ``lam``, ``'I_{Bxz} [kg m ²]'`` -> ``IBxz``) or :data:`COEFFICIENT_KEYS` (``'M_{12}'`` -> ``M12``,
``'C_{112}'`` -> ``C1_12``, ``'K_{021}'`` -> ``K0_21``, ``'K_{222}'`` -> ``K2_22``; indices 1-based as
printed, 1 = roll, 2 = steer). Units are the paper's: m, rad, kg, kg m².

Quirks of the paper, kept as printed (do not "fix" them here; tests that compare must allow for them):

- Tables 4 and 5 swap IRxx and IFxx relative to Table 2: e.g. Browser (B) has IRxx 0.0904 and IFxx
  0.0884 in Table 2 but IRxx 0.088 and IFxx 0.09 in Table 4 (likewise B*, C, S, Y, Y*; G and P are too
  close to tell at three decimals). Table 5 is presumably computed from the swapped set.
- The σ of Table 3 were computed treating the 25 parameters as independent (correlations between
  them ignored); the paper's text does not say so itself. Use them as the paper's numbers, not as a
  correct propagation.
- The structural zeros C_{111}, K_{211}, K_{221} of Tables 3 and 5 are printed once, as ``0.0 NA`` in
  a cell spanning all eight bicycles; they are returned for every bicycle (value 0.0, σ None, one
  decimal).
- Trailing zeros are dropped in places, so ``value_decimals`` is the number of printed digits, not
  the precision the authors rounded to: Tables 4 and 5 round to three decimals but print ``1.07``,
  ``0.4``, ``0.18`` (Table 2 prints ``1.070``, ``0.400``, ``0.180``); Table 2 prints S zH ``-0.73``
  and Table 3 prints B C1_21 ``-0.45`` beside a three-decimal σ.
- σ is sometimes printed with more decimals than its value (Table 2 B IHxz ``-0.072`` σ ``0.0008``).
- Table 4 prints mF of C and S as ``3.545`` and ``3.334``, more digits than Table 2 (``3.55``,
  ``3.33``); rR and rF are rounded to three decimals (B rR ``0.3410`` -> ``0.341``).
- The header row repeats ``Value σ`` per bicycle in Table 2 but prints it once in Tables 3-5.
- Table 1 prints the rider's inertia as a LaTeX ``bmatrix``; it has no σ.

The shared folder is ``<repo root>/../shared``; the environment variable ``BIKE_RIG_SHARED`` overrides
it. :func:`shared_dir` raises :class:`SharedFolderMissingError` when it is not there.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import MappingProxyType
from typing import Final

from bike_rig.config.paths import config_file
from bike_rig.core.errors import BikeRigError, InputFileError

__all__ = [
    "real_files",
    "BICYCLES",
    "BICYCLE_NAMES",
    "COEFFICIENT_KEYS",
    "PAPER_FILE",
    "PARAMETER_KEYS",
    "SHARED_ENV_VAR",
    "PaperFormatError",
    "Printed",
    "Rider",
    "SharedFolderMissingError",
    "Table",
    "paper_path",
    "rider_table1",
    "shared_dir",
    "table2",
    "table3",
    "table4",
    "table5",
]

SHARED_ENV_VAR: Final = "BIKE_RIG_SHARED"
"""Environment variable that, when set, names the shared folder instead of ``<repo root>/../shared``."""

PAPER_FILE: Final = Path("paper") / "000_abe15806ef2d8adc.txt"
"""The paper's text, relative to the shared folder."""

BICYCLES: Final = ("B", "B*", "C", "G", "P", "S", "Y", "Y*")
"""The paper's bicycle columns, in printed order."""

BICYCLE_NAMES: Final[Mapping[str, str]] = MappingProxyType(
    {
        "B": "Browser",
        "B*": "Browserins",
        "C": "Crescendo",
        "G": "Fisher",
        "S": "Stratos",
        "Y": "Yellow",
    }
)
"""Paper column -> folder under ``shared/data/bicycleparameters``. P (Pista) and Y* (Yellowrev) have no
raw data there."""

PARAMETER_KEYS: Final = (
    "w",
    "c",
    "lam",
    "rR",
    "mR",
    "IRxx",
    "IRyy",
    "xB",
    "zB",
    "mB",
    "IBxx",
    "IBxz",
    "IByy",
    "IBzz",
    "xH",
    "zH",
    "mH",
    "IHxx",
    "IHxz",
    "IHyy",
    "IHzz",
    "rF",
    "mF",
    "IFxx",
    "IFyy",
)
"""The 25 benchmark parameters in the order Tables 2 and 4 print them (BicycleParameters names)."""

COEFFICIENT_KEYS: Final = (
    "M11",
    "M12",
    "M21",
    "M22",
    "C1_11",
    "C1_12",
    "C1_21",
    "C1_22",
    "K0_11",
    "K0_12",
    "K0_21",
    "K0_22",
    "K2_11",
    "K2_12",
    "K2_21",
    "K2_22",
)
"""The canonical matrix coefficients in the order Tables 3 and 5 print them."""

_UNIT_BY_INITIAL: Final[Mapping[str, str]] = MappingProxyType({"l": "rad", "m": "kg", "I": "kgm²"})
_UNITS: Final[Mapping[str, str]] = MappingProxyType({key: _UNIT_BY_INITIAL.get(key[0], "m") for key in PARAMETER_KEYS})
"""Printed unit per parameter, whitespace removed: rad for lam, kg for masses, kg m² for inertias, else m."""

_SYMBOLS: Final[Mapping[str, str]] = MappingProxyType({"λ": "lam"})
_PARAMETER_LABEL: Final = re.compile(r"(?P<symbol>\S+)\s*\[(?P<unit>[^\]]*)\]")
_COEFFICIENT_LABEL: Final = re.compile(r"(?P<matrix>[MCK])_\{(?P<index>\d+)\}")
_NUMBER: Final = re.compile(r"[-+]?\d+(?:\.(?P<fraction>\d+))?")
_BMATRIX: Final = re.compile(r"\$?\s*\\begin\{bmatrix\}(?P<body>.*)\\end\{bmatrix\}\s*\$?")
_NA: Final = "NA"
_SIGMA_HEADER: Final = ("Value", "σ")


class SharedFolderMissingError(BikeRigError, FileNotFoundError):
    """The shared folder, or the paper inside it, is not where the tests look for it."""


class PaperFormatError(InputFileError):
    """A table of the paper's text does not look as this parser expects."""


@dataclass(frozen=True)
class Printed:
    """One printed cell: a value and its σ as they appear in the paper.

    Attributes:
        value: The printed value, in the table's unit.
        sigma: The printed σ, or None where the paper prints NA.
        value_decimals: Digits printed after the decimal point ('0.069' -> 3, '1.07' -> 2, '72' -> 0).
        sigma_decimals: The same for σ, or None where σ is NA.
    """

    value: float
    sigma: float | None
    value_decimals: int
    sigma_decimals: int | None

    def rounding_half_unit(self) -> float:
        """Half a unit of the last printed digit of the value (``0.5 * 10**-value_decimals``).

        Any number within this distance of the printed value rounds to it.
        """
        return 0.5 * 10.0**-self.value_decimals


@dataclass(frozen=True)
class Rider:
    """The rigid rider of Table 1, in the benchmark coordinate system (x forward, z down).

    Attributes:
        mass: m_P [kg].
        x: x_P, mass centre ahead of the rear contact point [m].
        z: z_P, mass centre height, negative above the ground [m].
        inertia: I_P about the rider's mass centre, rows x, y, z [kg m²].
    """

    mass: float
    x: float
    z: float
    inertia: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


Table = dict[str, dict[str, Printed]]
"""Bicycle column -> key -> printed cell."""


def shared_dir() -> Path:
    """The shared folder: ``$BIKE_RIG_SHARED`` if set, else ``<repo root>/../shared``.

    Raises:
        SharedFolderMissingError: The folder does not exist.
    """
    override = os.environ.get(SHARED_ENV_VAR)
    if override:
        folder = Path(override).expanduser().resolve()
        origin = f"{SHARED_ENV_VAR}={override!r}"
    else:
        folder = (Path(__file__).resolve().parents[2] / ".." / "shared").resolve()
        origin = f"the default <repo root>/../shared (set {SHARED_ENV_VAR} to point elsewhere)"
    if not folder.is_dir():
        msg = f"shared folder {folder} not found; looked there because of {origin}"
        raise SharedFolderMissingError(msg)
    return folder


def paper_path() -> Path:
    """The paper's text file inside :func:`shared_dir`.

    Raises:
        SharedFolderMissingError: The shared folder or the paper's text is missing.
    """
    path = shared_dir() / PAPER_FILE
    if not path.is_file():
        msg = f"the paper's text {path} is missing from the shared folder"
        raise SharedFolderMissingError(msg)
    return path


def table2() -> Table:
    """Table 2: the 25 parameters of the eight bicycles, with σ."""
    return _copy(_tables(paper_path())[2])


def table3() -> Table:
    """Table 3: the canonical matrix coefficients of the eight bicycles, with σ."""
    return _copy(_tables(paper_path())[3])


def table4() -> Table:
    """Table 4: the 25 parameters with the rigid rider (σ all None; IRxx/IFxx swapped, see module doc)."""
    return _copy(_tables(paper_path())[4])


def table5() -> Table:
    """Table 5: the canonical matrix coefficients with the rigid rider (σ all None)."""
    return _copy(_tables(paper_path())[5])


def rider_table1() -> Rider:
    """Table 1: the rigid rider's mass, mass centre and inertia."""
    return _rider(paper_path())


def _copy(table: Mapping[str, Mapping[str, Printed]]) -> Table:
    return {bicycle: dict(cells) for bicycle, cells in table.items()}


@cache
def _lines(path: Path) -> tuple[str, ...]:
    return tuple(path.read_text(encoding="utf-8").splitlines())


@cache
def _tables(path: Path) -> dict[int, Table]:
    return {
        2: _bicycle_table(path, 2, PARAMETER_KEYS, _parameter_key, spanning_zeros=False),
        3: _bicycle_table(path, 3, COEFFICIENT_KEYS, _coefficient_key, spanning_zeros=True),
        4: _bicycle_table(path, 4, PARAMETER_KEYS, _parameter_key, spanning_zeros=False),
        5: _bicycle_table(path, 5, COEFFICIENT_KEYS, _coefficient_key, spanning_zeros=True),
    }


def _table_rows(path: Path, number: int) -> list[tuple[int, str]]:
    """Return (1-based line number, text) of each row of table ``number``, header rows included.

    The rows run from the first non-blank line after the caption to the next blank line.
    """
    lines = _lines(path)
    caption = re.compile(rf"\s*Table {number}:")
    starts = [index for index, line in enumerate(lines) if caption.match(line)]
    if len(starts) != 1:
        raise PaperFormatError(str(path), f"expected one caption 'Table {number}:', found {len(starts)}")
    index = starts[0] + 1
    while index < len(lines) and not lines[index].strip():
        index += 1
    rows: list[tuple[int, str]] = []
    while index < len(lines) and lines[index].strip():
        rows.append((index + 1, lines[index]))
        index += 1
    if not rows:
        raise PaperFormatError(str(path), f"Table {number} has no rows", line=starts[0] + 1)
    return rows


def _fail(path: Path, number: int, line: int, text: str, reason: str) -> PaperFormatError:
    return PaperFormatError(str(path), f"Table {number}: {reason}; row text {text!r}", line=line)


def _bicycle_table(
    path: Path,
    number: int,
    keys: tuple[str, ...],
    key_of: Callable[[str], str],
    *,
    spanning_zeros: bool,
) -> Table:
    """Parse a table whose columns are the eight bicycles, each a ``Value σ`` pair.

    Cells are separated by tabs; the label is everything before the first tab and the cells are the
    whitespace-separated tokens after it, so stray spaces or doubled tabs do not matter but a missing
    or extra cell does. With ``spanning_zeros``, a row printing only ``0 NA`` is a structural zero
    spanning all bicycles.
    """
    rows = _table_rows(path, number)
    _check_bicycle_headers(path, number, rows)
    table: Table = {bicycle: {} for bicycle in BICYCLES}
    for line, text in rows[2:]:
        label, tab, rest = text.partition("\t")
        if not tab:
            raise _fail(path, number, line, text, "no tab between the row label and its cells")
        try:
            key = key_of(label.strip())
            cells = _bicycle_cells(rest.split(), spanning_zeros=spanning_zeros)
        except ValueError as error:
            raise _fail(path, number, line, text, str(error)) from None
        if key in table[BICYCLES[0]]:
            raise _fail(path, number, line, text, f"{key} is printed twice")
        for bicycle, cell in zip(BICYCLES, cells, strict=True):
            table[bicycle][key] = cell

    printed = tuple(table[BICYCLES[0]])
    if printed != keys:
        missing = [key for key in keys if key not in printed]
        reason = f"Table {number}: expected the rows {keys} in that order, found {printed} (missing {missing})"
        raise PaperFormatError(str(path), reason, line=rows[0][0])
    return table


def _check_bicycle_headers(path: Path, number: int, rows: list[tuple[int, str]]) -> None:
    """Check the two header rows: 'Parameter' and the bicycles, then 'Value σ' once or per bicycle."""
    if len(rows) < 2:
        raise _fail(path, number, *rows[0], "expected two header rows before the data")
    (header_line, header), (sigma_line, sigma_header) = rows[:2]
    if header.split() != ["Parameter", *BICYCLES]:
        raise _fail(path, number, header_line, header, f"header is not 'Parameter' and the bicycles {BICYCLES}")
    pairs = len(sigma_header.split()) // 2
    if pairs not in (1, len(BICYCLES)) or sigma_header.split() != list(_SIGMA_HEADER * pairs):
        raise _fail(path, number, sigma_line, sigma_header, "second header row is not 'Value σ' repeated")


def _bicycle_cells(tokens: list[str], *, spanning_zeros: bool) -> list[Printed]:
    """One row's cells per bicycle from its ``Value σ`` tokens; raises ValueError on a wrong count."""
    if spanning_zeros and len(tokens) == 2 and tokens[1] == _NA and _printed(*tokens).value == 0.0:
        return [_printed(*tokens)] * len(BICYCLES)
    if len(tokens) != 2 * len(BICYCLES):
        msg = f"expected {2 * len(BICYCLES)} cells (Value σ per bicycle), found {len(tokens)}"
        raise ValueError(msg)
    return [_printed(value, sigma) for value, sigma in zip(tokens[::2], tokens[1::2], strict=True)]


def _parameter_key(label: str) -> str:
    """``'I_{Bxz} [kg m ²]'`` -> ``'IBxz'``, checking the unit."""
    match = _PARAMETER_LABEL.fullmatch(label)
    if match is None:
        msg = f"label {label!r} is not 'symbol [unit]'"
        raise ValueError(msg)
    symbol = match["symbol"]
    key = _SYMBOLS.get(symbol, symbol.replace("_", "").replace("{", "").replace("}", ""))
    if key not in _UNITS:
        msg = f"label {label!r} is not one of the 25 benchmark parameters"
        raise ValueError(msg)
    unit = "".join(match["unit"].split()).replace("^2", "²")
    if unit != _UNITS[key]:
        msg = f"label {label!r}: unit {match['unit']!r} is not {_UNITS[key]!r}"
        raise ValueError(msg)
    return key


def _coefficient_key(label: str) -> str:
    """``'M_{12}'`` -> ``'M12'``, ``'C_{112}'`` -> ``'C1_12'``, ``'K_{021}'`` -> ``'K0_21'``."""
    match = _COEFFICIENT_LABEL.fullmatch(label)
    if match is None:
        msg = f"label {label!r} is not a coefficient like 'M_{{11}}' or 'K_{{021}}'"
        raise ValueError(msg)
    matrix, index = match["matrix"], match["index"]
    key = matrix + index if matrix == "M" else f"{matrix}{index[:-2]}_{index[-2:]}"
    if key not in COEFFICIENT_KEYS:
        msg = f"label {label!r} is not one of the canonical matrix coefficients"
        raise ValueError(msg)
    return key


def _number(token: str) -> tuple[float, int]:
    """A printed number and its count of decimals; raises ValueError on anything else."""
    normalized = token.replace("\u2212", "-")
    match = _NUMBER.fullmatch(normalized)
    if match is None:
        msg = f"cell {token!r} is not a number"
        raise ValueError(msg)
    fraction = match["fraction"]
    return float(normalized), len(fraction) if fraction else 0


def _printed(value_token: str, sigma_token: str) -> Printed:
    value, value_decimals = _number(value_token)
    if sigma_token == _NA:
        return Printed(value, None, value_decimals, None)
    sigma, sigma_decimals = _number(sigma_token)
    return Printed(value, sigma, value_decimals, sigma_decimals)


@cache
def _rider(path: Path) -> Rider:
    rows = _table_rows(path, 1)
    header_line, header = rows[0]
    if header.split() != ["Parameter", "Value"]:
        raise _fail(path, 1, header_line, header, "header is not 'Parameter Value'")
    cells: dict[str, tuple[int, str, str]] = {}
    for line, text in rows[1:]:
        label, tab, value = text.partition("\t")
        if not tab or not value.strip():
            raise _fail(path, 1, line, text, "expected a label and a value separated by a tab")
        cells["".join(label.split())] = (line, text, value.strip())
    expected = ("m_P[kg]", "x_P[m]", "z_P[m]", "I_P[kgm²]")
    if tuple(cells) != expected:
        raise PaperFormatError(str(path), f"Table 1: expected the rows {expected}, found {tuple(cells)}")

    def scalar(label: str) -> float:
        line, text, value = cells[label]
        try:
            return _number(value)[0]
        except ValueError as error:
            raise _fail(path, 1, line, text, str(error)) from None

    line, text, matrix = cells["I_P[kgm²]"]
    match = _BMATRIX.fullmatch(matrix)
    if match is None:
        raise _fail(path, 1, line, text, "I_P is not a LaTeX bmatrix")
    try:
        entries = [[_number(entry.strip())[0] for entry in row.split("&")] for row in match["body"].split(r"\\")]
    except ValueError as error:
        raise _fail(path, 1, line, text, str(error)) from None
    if [len(row) for row in entries] != [3, 3, 3]:
        raise _fail(path, 1, line, text, "I_P is not 3x3")
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = entries
    inertia = ((xx, xy, xz), (yx, yy, yz), (zx, zy, zz))
    return Rider(mass=scalar("m_P[kg]"), x=scalar("x_P[m]"), z=scalar("z_P[m]"), inertia=inertia)


def real_files() -> Iterator[Path]:
    """Every shipped bicycle and every paper bicycle's raw and benchmark file (and Jason on the Browser)."""
    yield from sorted(config_file("bicycles").glob("*.yaml"))
    data = shared_dir() / "data" / "bicycleparameters"
    yield from sorted(data.glob("*/RawData/*Measured.txt"))
    yield from sorted(data.glob("*/Parameters/*Benchmark.txt"))
    yield from sorted(data.glob("riders/*/Parameters/*Benchmark.txt"))
