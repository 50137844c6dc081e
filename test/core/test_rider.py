"""The one place a rider choice becomes a rider: names, rider files and their errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.core.errors import BikeRigError
from bike_rig.core.rider import PAPER_RIDER, Rider, RiderError, load_rider, resolve_rider, rider_key


def _write(path: Path, rider: Rider, name: bool = True) -> Path:
    """A rider file with ``rider``'s values (and its name)."""
    r = rider
    path.write_text(
        (f"name: {r.name}\n" if name else "")
        + f"mass: {r.mass!r}\nx: {r.x!r}\nz: {r.z!r}\nIxx: {r.Ixx!r}\nIyy: {r.Iyy!r}\nIzz: {r.Izz!r}\nIxz: {r.Ixz!r}\n"
    )
    return path


@pytest.mark.parametrize("spec", [None, "", "none"])
def test_no_rider(spec: str | None) -> None:
    """None, "" and "none" all mean no rider, recorded as ""."""
    assert resolve_rider(spec) is None
    assert resolve_rider(spec, files=False) is None
    assert rider_key(spec) == ""


def test_paper_rider() -> None:
    """The name paper is Table 1's rider, recorded as "paper"."""
    assert resolve_rider("paper") is PAPER_RIDER
    assert resolve_rider("paper", files=False) is PAPER_RIDER
    assert rider_key("paper") == "paper"


def test_rider_file(tmp_path: Path) -> None:
    """A rider file gives its values and name; its record name is its path."""
    path = _write(tmp_path / "tall.yaml", PAPER_RIDER)
    assert resolve_rider(str(path)) == PAPER_RIDER
    assert resolve_rider(path) == load_rider(path) == PAPER_RIDER
    assert rider_key(str(path)) == str(path)
    unnamed = _write(tmp_path / "short.yaml", PAPER_RIDER, name=False)
    assert resolve_rider(str(unnamed)).name == "short"  # type: ignore[union-attr]


def test_unknown_name_without_files() -> None:
    """Where only names are known, anything else is an unknown rider."""
    with pytest.raises(RiderError, match=r"^unknown rider 'tall': expected '', 'none' or 'paper'$"):
        resolve_rider("tall", files=False)
    with pytest.raises(RiderError, match="unknown rider 'tall'"):
        rider_key("tall", files=False)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "mass: 70\nx: 0.3\nz: -1.1\nIxx: 7\nIyy: 8\nIzz: two\nIxz: -1.9\n",
            r"rider\.yaml:6: key 'Izz': needs a number \('two' given\)$",
        ),
        ("mass: 70\nx: 0.3\n", r"rider\.yaml: key 'z': needs a number \(None given\)$"),
        ("mass: true\nx: 0.3\n", r"rider\.yaml:1: key 'mass': needs a number \(True given\)$"),
        (
            "mass: 0\nx: 0.3\nz: -1.1\nIxx: 7\nIyy: 8\nIzz: 2\nIxz: -1.9\n",
            r"rider\.yaml:1: key 'mass': rider mass must be positive$",
        ),
        ("- 1\n- 2\n", r"rider\.yaml: a rider file is a mapping of mass, x, z, Ixx, Iyy, Izz, Ixz$"),
        ("mass: [1\n", r"rider\.yaml:\d+: invalid YAML"),
    ],
)
def test_bad_rider_files(tmp_path: Path, text: str, message: str) -> None:
    """A bad rider file names the file, key and line, as any input file error does."""
    path = tmp_path / "rider.yaml"
    path.write_text(text)
    with pytest.raises(RiderError, match=message) as info:
        resolve_rider(str(path))
    assert isinstance(info.value, BikeRigError)
    assert info.value.path == str(path)


def test_missing_rider_file(tmp_path: Path) -> None:
    """A path that is not a readable file."""
    path = tmp_path / "absent.yaml"
    with pytest.raises(RiderError, match=r"absent\.yaml: cannot read the file \(FileNotFoundError"):
        resolve_rider(str(path))


def test_integers_beyond_any_float_are_refused_in_one_line(tmp_path: Path) -> None:
    """400 digits was an OverflowError; 4,000 hex digits a ValueError writing the message (found by fuzzing)."""
    for number in ("1" + "0" * 400, "0x" + "f" * 4000):
        path = tmp_path / "rider.yaml"
        path.write_text(f"mass: {number}\nx: 0.3\n")
        with pytest.raises(RiderError, match=r"rider\.yaml:1: key 'mass': .* is beyond any rider"):
            load_rider(path)
