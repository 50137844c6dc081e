"""Input hygiene (issue 27): repeated YAML keys, special files, rates that disagree, long CSV lines, control codes."""

from __future__ import annotations

import builtins
import io
import os
import tracemalloc
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.io import savemat

from bike_rig.config.paths import config_dir
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.errors import BikeRigError, InputFileError
from bike_rig.core.feedback import load_feedback
from bike_rig.core.io_yaml import dump_measurements_yaml, dump_parameters_yaml, load_yaml_document
from bike_rig.core.loader import load_input, load_measurements
from bike_rig.core.rider import load_rider
from bike_rig.core.rider_yeadon import read_yeadon_configuration, read_yeadon_measurements
from bike_rig.core.safe_yaml import YamlDuplicateKeyError, compose_bounded, read_regular_file
from bike_rig.core.sim.rig import load_rig
from bike_rig.core.textfmt import terminal_safe
from bike_rig.core.trials import MAX_LINE_CHARS, read_trial
from bike_rig.ros.launch import load_graph

BROWSER = config_dir() / "bicycles" / "browser.yaml"


# ---------------------------------------------------------------- a key given twice


def test_a_repeated_key_names_the_key_and_both_lines() -> None:
    text = "a: 1\nframe:\n  mass: [9.86, 0.02]\n  other: 3\n  mass: [99, 0.02]\n"
    with pytest.raises(YamlDuplicateKeyError) as info:
        compose_bounded(text)
    assert (info.value.key, info.value.first_line, info.value.line) == ("frame.mass", 3, 5)
    assert info.value.reason == "key 'frame.mass' given twice (first on line 3)"


@pytest.mark.parametrize(
    ("text", "key", "lines"),
    [
        ("a: 1\na: 2\n", "a", (1, 2)),
        ("x:\n  - {p: 1, q: 2}\n  - {p: 1, p: 2}\n", "x[1].p", (3, 3)),
        ("1: a\n0x1: b\n", "0x1", (1, 2)),  # the same integer written two ways
        ("'k': 1\nk: 2\n", "k", (1, 2)),  # quoted or not, the same string
        ("? k\n: 1\nk: 2\n", "k", (1, 3)),
    ],
)
def test_every_spelling_of_a_repeated_key_is_caught(text: str, key: str, lines: tuple[int, int]) -> None:
    with pytest.raises(YamlDuplicateKeyError) as info:
        compose_bounded(text)
    assert (info.value.key, info.value.first_line, info.value.line) == (key, *lines)


def test_keys_that_differ_and_merge_keys_are_not_repeats() -> None:
    """``<<`` merges a mapping whose keys the mapping may override; '1' and 1 are different keys."""
    text = "base: &b {m: 1, n: 2}\nx:\n  <<: *b\n  m: 3\ny: {'1': a, 1: b}\nz: [*b, *b]\n"
    node, _loader = compose_bounded(text)
    assert node is not None


def test_a_measurement_file_with_frame_mass_twice_is_refused(tmp_path: Path) -> None:
    """The issue's file: frame.mass twice, the second (99 kg) used to win silently."""
    lines = BROWSER.read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("  mass:") and lines[i - 1] == "frame:")
    lines.insert(at + 2, "  mass: [99.0, 0.02]")
    bike = tmp_path / "bike.yaml"
    bike.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputFileError) as info:
        load_input(bike)
    assert str(info.value) == f"{bike}:{at + 3}: key 'frame.mass': given twice (first on line {at + 1})"


def _rig(path: Path) -> object:
    return load_rig(path)


#: Every reader of a YAML file, and a file for it that repeats a key on line 3 (first on line 2).
READERS: dict[str, tuple[Callable[[Path], object], str]] = {
    "parameters": (load_input, "format: bike_rig-parameters/1\nbicycle: B\nbicycle: C\n"),
    "BicycleParameters parameter set": (load_input, "values:\n  IBxx: 1\n  IBxx: 2\n"),
    "rider": (load_rider, "name: r\nmass: 70\nmass: 99\nx: 0\n"),
    "feedback": (load_feedback, "format: bike_rig-feedback/1\nk_phi: 1\nk_phi: 2\n"),
    "rig": (_rig, "format: x\ngyro: {}\ngyro: {}\n"),
    "graph": (load_graph, "format: bike_rig-graph/1\nnodes: []\nnodes: []\n"),
    "Yeadon measurements": (read_yeadon_measurements, "x: 1\nLs1L: 0.1\nLs1L: 0.2\n"),
    "Yeadon configuration": (read_yeadon_configuration, "x: 1\nsomersault: 0\nsomersault: 1\n"),
}


@pytest.mark.parametrize("kind", READERS)
def test_every_yaml_reader_refuses_a_repeated_key(tmp_path: Path, kind: str) -> None:
    reader, text = READERS[kind]
    path = tmp_path / "file.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(BikeRigError) as info:
        reader(path)
    message = str(info.value)
    assert message.startswith(f"{path}:3: key '") and message.endswith("': given twice (first on line 2)"), message


def test_a_name_with_control_characters_is_written_as_yaml_that_reads_back(tmp_path: Path) -> None:
    """The bicycle's name went into the parameter file unquoted: a newline in it made the file another."""
    measurements = load_measurements(BROWSER)
    name = "Br\x1b[2Jowser\nparameters: {}\x00"
    params = replace(compute_parameters(measurements), bicycle=name)
    for text in (dump_parameters_yaml(params), dump_measurements_yaml(replace(measurements, bicycle=name))):
        path = tmp_path / "out.yaml"
        path.write_text(text, encoding="utf-8")
        assert "\x1b" not in text and "\x00" not in text
        assert load_yaml_document(path)[0]["bicycle"] == name


# ---------------------------------------------------------------- special files


def _special(tmp_path: Path, kind: str, suffix: str) -> tuple[Path, str]:
    """A FIFO, a symlink to /dev/zero, a symlink loop, a dangling symlink, a directory or nothing; and its message."""
    path = tmp_path / f"trial{suffix}"
    if kind == "fifo":
        os.mkfifo(path)
        return path, "is a FIFO (named pipe), not a regular file"
    if kind == "device":
        path.symlink_to("/dev/zero")
        return path, "is a character device (through a symlink to /dev/zero), not a regular file"
    if kind == "loop":
        other = tmp_path / f"other{suffix}"
        path.symlink_to(other)
        other.symlink_to(path)
        return path, "is a symlink loop (or a chain of more than 40 symlinks), not a file"
    if kind == "dangling":
        path.symlink_to(tmp_path / "nowhere")
        return path, f"no such file (a broken symlink to {tmp_path / 'nowhere'})"
    if kind == "directory":
        path.mkdir()
        return path, "is a directory, not a regular file"
    return path, "no such file"


@pytest.mark.parametrize("kind", ["fifo", "device", "loop", "dangling", "directory", "missing"])
@pytest.mark.parametrize("suffix", [".csv", ".npy", ".mat", ".yaml"])
def test_special_files_are_named_as_what_they_are_and_never_opened(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str, suffix: str
) -> None:
    """A FIFO is not opened (the read would block for ever), /dev/zero not read (it never ends)."""
    path, reason = _special(tmp_path, kind, suffix)
    reader = load_yaml_document if suffix == ".yaml" else read_trial
    if suffix == ".yaml" and kind in ("dangling", "missing"):  # (YAML readers keep the system's words)
        reason = f"cannot read the file (FileNotFoundError: [Errno 2] No such file or directory: '{path}')"
    opened = _record_opens(monkeypatch, path)
    with pytest.raises(InputFileError) as info:
        reader(path)
    assert str(info.value) == f"{path}: {reason}"
    assert opened == [], f"{path} ({kind}) was opened: {opened}"


def _record_opens(monkeypatch: pytest.MonkeyPatch, path: Path) -> list[str]:
    """The calls of ``os.open`` and ``open`` (``io.open``) on ``path`` from now on, in order (refused: none blocks)."""
    opened: list[str] = []
    os_open, builtin_open = os.open, builtins.open

    def is_path(file: object) -> bool:
        return isinstance(file, (str, bytes, os.PathLike)) and os.path.abspath(os.fsdecode(file)) == str(path)

    def guarded_os_open(file: Any, *args: Any, **kwargs: Any) -> int:
        if is_path(file):
            opened.append("os.open")
            raise PermissionError(13, "opened in a test that forbids it", str(file))
        return os_open(file, *args, **kwargs)

    def guarded_open(file: Any, *args: Any, **kwargs: Any) -> Any:
        if is_path(file):
            opened.append("open")
            raise PermissionError(13, "opened in a test that forbids it", str(file))
        return builtin_open(file, *args, **kwargs)

    monkeypatch.setattr(os, "open", guarded_os_open)
    monkeypatch.setattr(builtins, "open", guarded_open)
    monkeypatch.setattr(io, "open", guarded_open)  # (pathlib's)
    return opened


def test_read_regular_file_caps_the_size(tmp_path: Path) -> None:
    path = tmp_path / "f.yaml"
    path.write_bytes(b"x" * 101)
    with pytest.raises(InputFileError, match="101 bytes: larger than 100 bytes, not a test file"):
        read_regular_file(str(path), path, 100, "a test file")
    assert read_regular_file(str(path), path, 101, "a test file") == b"x" * 101


# ---------------------------------------------------------------- sample rates that disagree


def _swing(rate: float, seconds: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(int(seconds * rate)) / rate
    return t, np.exp(-0.05 * t) * np.sin(2 * np.pi * t / 2.0)


def test_a_mat_whose_sample_rate_and_times_disagree_is_refused(tmp_path: Path) -> None:
    """The issue's file: sampleRate 1000 and a time array in 2 ms steps; it was fitted from the times."""
    t, x = _swing(500.0)
    path = tmp_path / "BrowserFrameTorsionalFirst1.mat"
    savemat(path, {"data": x, "time": t, "sampleRate": 1000.0})
    with pytest.raises(InputFileError) as info:
        read_trial(path)
    assert str(info.value) == (
        f"{path}: key 'sampleRate': sampleRate says 1000 Hz, but the 'time' array steps by 2 ms (500 Hz): "
        "the sample rates disagree (by more than 1 %); give one, or correct the wrong one"
    )
    savemat(path, {"data": x, "time": t, "sampleRate": 500.0})  # agreeing: read, from the times
    assert read_trial(path).timing == {"sample_rate_hz": 500.0}


def test_a_mat_whose_two_rates_disagree_is_refused(tmp_path: Path) -> None:
    t, x = _swing(1000.0)
    path = tmp_path / "two.mat"
    savemat(path, {"data": x, "ActualRate": 1000.0, "sampleRate": 500.0})
    with pytest.raises(InputFileError, match=r"key 'sampleRate': ActualRate says 1000 Hz, but sampleRate says 500 Hz"):
        read_trial(path)
    savemat(path, {"data": x, "ActualRate": 1000.0})
    with pytest.raises(InputFileError, match=r"key 'ActualRate': ActualRate says 1000 Hz, but --rate says 200 Hz"):
        read_trial(path, 200.0)
    assert read_trial(path, 1000.0).sample_rate_hz == 1000.0


@pytest.mark.parametrize("suffix", [".csv", ".npy"])
def test_a_rate_given_for_a_file_with_times_must_agree_with_them(tmp_path: Path, suffix: str) -> None:
    t, x = _swing(500.0)
    path = tmp_path / f"trial{suffix}"
    if suffix == ".csv":
        path.write_text("time,rate\n" + "".join(f"{a:.3f},{b:.6f}\n" for a, b in zip(t, x)), encoding="utf-8")
        label = "time column 'time'"
    else:
        np.save(path, np.column_stack([t, x]))
        label = "time column 0"
    with pytest.raises(InputFileError) as info:
        read_trial(path, 1000.0)
    assert str(info.value) == (
        f"{path}: --rate says 1000 Hz, but {label} steps by 2 ms (500 Hz): "
        "the sample rates disagree (by more than 1 %); give one, or correct the wrong one"
    )
    assert read_trial(path, 500.0).timing == {"sample_rate_hz": 500.0}
    assert read_trial(path, 502.0).times is not None  # within 1 %: the file's times are used


def test_rounded_stamps_and_a_gap_still_agree_with_the_rate(tmp_path: Path) -> None:
    """300 Hz written to 1 ms steps by 3 and 4 ms (the mean agrees); a gap moves the mean, not the median."""
    t, x = _swing(300.0)
    rounded = tmp_path / "rounded.csv"
    rounded.write_text("time,rate\n" + "".join(f"{a:.3f},{b:.6f}\n" for a, b in zip(t, x)), encoding="utf-8")
    assert read_trial(rounded, 300.0).times is not None
    keep = np.ones(t.size, bool)
    keep[1000:1600] = False
    gap = tmp_path / "gap.npy"
    np.save(gap, np.column_stack([t[keep], x[keep]]))
    assert read_trial(gap, 300.0).times is not None


# ---------------------------------------------------------------- CSV read in bounded memory


def test_a_csv_line_longer_than_any_row_is_refused_with_its_length(tmp_path: Path) -> None:
    path = tmp_path / "wide.csv"
    path.write_text("# comment\n" + ",".join(["0.125"] * 400_000) + "\n", encoding="utf-8")
    tracemalloc.start()
    try:
        with pytest.raises(InputFileError) as info:
            read_trial(path, 1000.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # The line is measured in 1 MiB chunks, never split: its 400,000 cells as str objects and floats would take
    # about ten times its 2.4 MB (25 MB measured); reading it whole as str and bytes, twice its size.
    assert peak < 2 * path.stat().st_size, f"refusing the long line took {peak / 1e6:.1f} MB at its peak"
    assert str(info.value) == (
        f"{path}: line 2 is 2.4 MB long: not a CSV of samples (a row of samples is at most {MAX_LINE_CHARS} characters)"
    )


def test_a_csv_is_read_exactly_as_python_reads_its_numbers(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    values = rng.standard_normal((2000, 3)) * 10.0 ** rng.integers(-8, 8, (2000, 3))
    rows = [f"{i / 1000!r} ; {a!r};{b!r}\n" for i, (a, b) in enumerate(values[:, 1:].tolist())]
    body = "".join(row + ("\n# note\n" if i % 500 == 0 else "") for i, row in enumerate(rows))
    text = "# a comment\n\ntime ; rate ; volts\n" + body
    path = tmp_path / "t.csv"
    path.write_text(text, encoding="utf-8")
    trial = read_trial(path)
    assert trial.samples.tolist() == values[:, 1].tolist()  # the column named as a rate, to the last bit
    assert trial.times is not None and trial.times.tolist() == [i / 1000 for i in range(2000)]
    assert trial.samples.flags.writeable


@pytest.mark.parametrize(
    ("text", "line", "reason"),
    [
        ("time,rate\n0,1\n0.001,1\n0.002,x\n", 4, "non-numeric value 'x' in column 2"),
        ("time,rate\n0,1\n0.001,1\n0.002\n", 4, "1 columns where the file has 2"),
        ("time,rate\n0,1\n0.001,\n", 3, "an empty cell in column 2"),
        ("1 2\n\n3 4 5\n", 3, "3 columns where the file has 2"),
    ],
)
def test_a_bad_row_after_the_first_names_its_line(tmp_path: Path, text: str, line: int, reason: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputFileError) as info:
        read_trial(path, 1000.0)
    assert str(info.value) == f"{path}:{line}: {reason}"


def test_a_text_trial_not_utf8_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "latin.csv"
    path.write_bytes(b"time,rate\n0,1\n" + b"0.001,1\n" * 5000 + b"0.002,\xe9\n")
    with pytest.raises(InputFileError, match="not a text file \\(not UTF-8\\)"):
        read_trial(path, 1000.0)


# ---------------------------------------------------------------- control characters


def test_terminal_safe_escapes_c0_del_c1_and_esc_only() -> None:
    text = "Br\x1b[2Jow\x00ser\x07\x7f\x9b\x85\r\nλ σ ±\tend"
    assert terminal_safe(text) == "Br\\x1b[2Jow\\x00ser\\x07\\x7f\\x9b\\x85\\x0d\nλ σ ±\tend"
    assert terminal_safe("a\nb\tc", keep="") == "a\\x0ab\\x09c"
    assert all(ord(c) >= 0x20 and not 0x7F <= ord(c) < 0xA0 for c in terminal_safe(text, keep=""))
