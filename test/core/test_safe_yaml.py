"""YAML files read within bounded time and memory, every refusal one line with its line number."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.core.errors import InputFileError
from bike_rig.core.io_yaml import load_yaml_document
from bike_rig.core.loader import load_input
from bike_rig.core.safe_yaml import LIMITS


def _refused(path: Path, match: str) -> InputFileError:
    with pytest.raises(InputFileError, match=match) as info:
        load_yaml_document(path)
    assert "\n" not in str(info.value)
    return info.value


def test_deep_nesting_is_refused_not_a_recursion_error(tmp_path: Path) -> None:
    """5,000 nested lists were a RecursionError traceback."""
    path = tmp_path / "deep.yaml"
    path.write_text("format: bike_rig-measurements/1\nx: " + "[" * 5000 + "]" * 5000 + "\n")
    err = _refused(path, f"nested deeper than {LIMITS.max_depth} levels")
    assert err.line == 2


def test_deep_block_nesting_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "deep.yaml"
    path.write_text("".join(" " * i + f"k{i}:\n" for i in range(300)))
    _refused(path, "nested deeper than")


def test_the_alias_bomb_is_refused_before_it_expands(tmp_path: Path) -> None:
    """A 339-byte 'billion laughs' took 24 s and 4.4 GB through the line walk before its error.

    (The memory its refusal takes: bench/bench_input_memory.py.)
    """
    text = 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
    for prev, name in zip("abcdefg", "bcdefgh"):
        text += f"{name}: &{name} [" + ",".join([f"*{prev}"] * 9) + "]\n"
    path = tmp_path / "bomb.yaml"
    path.write_text(text + "format: bike_rig-measurements/1\n")
    _refused(path, "expands to more than 100000 values")


def test_a_chain_of_merge_keys_is_refused(tmp_path: Path) -> None:
    """Merging each mapping into the next, 3,000 times, was a RecursionError in the constructor."""
    text = "a0: &a0 {x: 1}\n" + "".join(f"a{i}: &a{i} {{<<: *a{i - 1}}}\n" for i in range(1, 3000))
    path = tmp_path / "merge.yaml"
    path.write_text(text)
    _refused(path, r"deeper than 64 levels \(through its aliases\)")


def test_a_recursive_alias_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "rec.yaml"
    path.write_text("format: bike_rig-measurements/1\na: &a [1, *a]\n")
    err = _refused(path, "an alias refers to a node that contains it")
    assert err.line == 2


def test_shared_aliases_within_limits_are_read(tmp_path: Path) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text("a: &a [1, 2]\nb: *a\nc: {<<: {x: 1}, y: 2}\n")
    data, lines = load_yaml_document(path)
    assert data == {"a": [1, 2], "b": [1, 2], "c": {"x": 1, "y": 2}}
    assert lines[("b",)] == 2


@pytest.mark.parametrize(
    ("text", "match", "line"),
    [
        ("a: !!timestamp 2001-13-45\n", r"cannot read the value \(month must be in 1..12\)", 1),
        ("a: 1\nb: " + "1" * 6000 + "\n", "cannot read the value .*4300 digits", 2),
        ("a: 1\nb: \x01\n", r"unacceptable character #x0001 \(special characters are not allowed\)", 2),
        ("a: [1,\nb: 2\n", r"expected ',' or '\]', but got '<stream end>' \(while parsing a flow sequence\)", 3),
        ("a: !!python/object:os.system x\n", "could not determine a constructor", 1),
        ("a: *nowhere\n", "found undefined alias 'nowhere'", 1),
    ],
)
def test_yaml_errors_are_one_line_with_the_line(tmp_path: Path, text: str, match: str, line: int) -> None:
    """An invalid date or a 6,000-digit integer was a ValueError traceback; a control character two lines."""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    err = _refused(path, match)
    assert err.line == line


def test_an_oversized_file_is_refused_before_reading(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    path.write_bytes(b"a: " + b"x" * LIMITS.max_bytes)
    _refused(path, f"larger than {LIMITS.max_bytes} bytes")


def test_every_yaml_reader_goes_through_the_limits(tmp_path: Path) -> None:
    """Measurement and parameter files (load_input) share the bounded loader."""
    path = tmp_path / "deep.yaml"
    path.write_text("format: bike_rig-parameters/1\nparameters: " + "{a: " * 200 + "1" + "}" * 200 + "\n")
    with pytest.raises(InputFileError, match="nested deeper than"):
        load_input(path)
