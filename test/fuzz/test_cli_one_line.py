"""Each command that reads a file ends a malformed one in one stderr line and exit status 2, no traceback."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.lib import format as npy_format

from bike_rig.config.paths import config_dir

REPO = Path(__file__).resolve().parents[2]
BOMB = 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n' + "".join(
    f"{n}: &{n} [" + ",".join([f"*{p}"] * 9) + "]\n" for p, n in zip("abcdefg", "bcdefgh")
)


def _files(folder: Path) -> dict[str, Path]:
    browser = (config_dir() / "bicycles" / "browser.yaml").read_text()
    made = {
        "deep.yaml": "format: bike_rig-measurements/1\nx: " + "[" * 5000 + "]" * 5000 + "\n",
        "bomb.yaml": BOMB + "format: bike_rig-measurements/1\n",
        "huge.yaml": browser.replace("mass: [9.86, 0.02]", "mass: [1.0e+308, 0.02]"),
        "negative.yaml": browser.replace("mass: [9.86, 0.02]", "mass: [9.86, -0.02]"),
        "control.yaml": "format: bike_rig-rig/1\nname: \x01\n",
        "rider.yaml": "mass: 1" + "0" * 400 + "\nx: 0.3\n",
    }
    out = {}
    for name, text in made.items():
        out[name] = folder / name
        out[name].write_text(text)
    buf = io.BytesIO()
    npy_format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (20_000_000_000,)})
    out["huge.npy"] = folder / "huge.npy"
    out["huge.npy"].write_bytes(buf.getvalue() + b"\0" * 64)
    np.save(folder / "cut.npy", np.zeros((100, 2)))
    out["cut.npy"] = folder / "cut.npy"
    out["cut.npy"].write_bytes(out["cut.npy"].read_bytes()[:60])
    out["segfault.mat"] = REPO / "test" / "fuzz" / "corpus" / "segfault-scipy-1.17.mat"
    return out


CASES = [
    ("params", ["{deep.yaml}"], "nested deeper than 64 levels"),
    ("params", ["{bomb.yaml}"], "expands to more than 100000 values"),
    ("model", ["{huge.yaml}"], "beyond any plausible reading"),
    ("budget", ["{negative.yaml}"], "sigma must be >= 0"),
    ("import-bp", ["{deep.yaml}", "-o", "{out}"], "nested deeper than"),
    ("fit", ["{huge.npy}", "{cut.npy}", "--rate", "100"], "truncated or damaged"),
    ("fit", ["{segfault.mat}"], "not a readable MATLAB .mat file"),
    ("simulate", ["--bicycle", "{bomb.yaml}", "--out", "{out}"], "expands to more than"),
    ("simulate", ["--bicycle", "{browser}", "--rig", "{control.yaml}", "--out", "{out}"], "unacceptable character"),
    ("run", ["--config", "{bomb.yaml}"], "expands to more than"),
    ("model", [str(config_dir() / "bicycles" / "benchmark.yaml"), "--rider", "{rider.yaml}"], "beyond any rider"),
]


@pytest.mark.parametrize(("command", "argv", "reason"), CASES, ids=[f"{c}-{a[0]}" for c, a, _ in CASES])
def test_one_line_and_exit_2(tmp_path: Path, command: str, argv: list[str], reason: str) -> None:
    files = {"{" + k + "}": str(v) for k, v in _files(tmp_path).items()}
    files["{out}"] = str(tmp_path / "out")
    files["{browser}"] = str(config_dir() / "bicycles" / "browser.yaml")
    args = [files.get(a, a) for a in argv]
    done = subprocess.run(
        [sys.executable, "-m", "bike_rig.cli.main", command, *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    lines = done.stderr.splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and lines[0].startswith(f"bike-rig {command}: error: "), done.stderr
    assert reason in lines[0]
