"""A FIFO, a symlink to /dev/zero or a symlink loop given as a file is named as what it is, never read or waited for."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bike_rig.config.paths import config_dir
from test.support.cli import run

BENCHMARK = config_dir() / "bicycles" / "benchmark.yaml"
REASONS = {
    "fifo": "is a FIFO (named pipe), not a regular file",
    "zero": "is a character device (through a symlink to /dev/zero), not a regular file",
    "loop": "is a symlink loop (or a chain of more than 40 symlinks), not a file",
}


def special(folder: Path, kind: str, name: str) -> Path:
    path = folder / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "zero":
        path.symlink_to("/dev/zero")
    else:
        path.symlink_to(folder / f"other-{name}")
        (folder / f"other-{name}").symlink_to(path)
    return path


@pytest.mark.parametrize("kind", list(REASONS))
def test_measurement_and_ride_files_name_the_special_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, kind: str
) -> None:
    cases = {
        "params": ["params"],
        "ride-fit": ["ride", "fit"],
        "ride-validate": ["ride", "validate", str(BENCHMARK)],
    }
    for label, argv in cases.items():
        folder = tmp_path / label
        folder.mkdir()
        path = special(folder, kind, "in.csv")
        code, out, err = run(capsys, *argv, str(path))
        assert (code, out) == (2, ""), label
        assert err.endswith(f": error: {path}: {REASONS[kind]}\n") and err.count("\n") == 1, (label, err)


@pytest.mark.parametrize("kind", list(REASONS))
def test_a_bag_holding_a_special_file_names_it(capsys: pytest.CaptureFixture[str], tmp_path: Path, kind: str) -> None:
    single = special(tmp_path, kind, "x.mcap")
    code, out, err = run(capsys, "bag", "info", str(single))
    assert (code, out) == (2, "") and err == f"bike-rig bag: error: {single}: {REASONS[kind]}\n"
    for name in ("metadata.yaml", "bag_0.mcap"):
        bag = tmp_path / f"{kind}-{name}"
        bag.mkdir()
        special(bag, kind, name)
        code, out, err = run(capsys, "bag", "info", str(bag))
        assert (code, out) == (2, "") and err == f"bike-rig bag: error: {bag}: {name} {REASONS[kind]}\n"
