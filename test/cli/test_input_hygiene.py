"""Input hygiene on the command line: one error line, no hang, no raw control codes, a hostile file in capped memory."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from bike_rig.config.paths import config_dir
from bike_rig.core.textfmt import CONTROL_CHARACTERS
from bike_rig.core.trials import read_trial
from test.support.cli import run
from test.support.signals import gyro_trial

ROOT = Path(__file__).resolve().parents[2]
BROWSER = config_dir() / "bicycles" / "browser.yaml"
RAW_CONTROLS = {chr(c) for c in CONTROL_CHARACTERS} - {"\n", "\t"}


def bike_rig(*argv: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    """``bike-rig ARGV`` in a real interpreter (a hang fails the test by its timeout)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "bike_rig.cli.main", *argv]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout, check=False)


def test_a_measurement_file_repeating_a_key_is_one_error_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    mass = "frame:\n  mass: [9.86, 0.02]"
    text = BROWSER.read_text(encoding="utf-8").replace(mass, mass + "\n  mass: [99.0, 0.02]")
    bike = tmp_path / "bike.yaml"
    bike.write_text(text, encoding="utf-8")
    first = text.splitlines().index("  mass: [9.86, 0.02]", text.splitlines().index("frame:")) + 1
    code, out, err = run(capsys, "params", str(bike))
    assert (code, out) == (2, "")
    assert err == f"bike-rig params: error: {bike}:{first + 1}: key 'frame.mass': given twice (first on line {first})\n"


# ---------------------------------------------------------------- special files


def _specials(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.csv"
    zero.symlink_to("/dev/zero")
    loop = tmp_path / "loop.csv"
    loop.symlink_to(tmp_path / "loop2.csv")
    (tmp_path / "loop2.csv").symlink_to(loop)
    return {
        "fifo": (fifo, "is a FIFO (named pipe), not a regular file"),
        "device": (zero, "is a character device (through a symlink to /dev/zero), not a regular file"),
        "loop": (loop, "is a symlink loop (or a chain of more than 40 symlinks), not a file"),
    }


@pytest.mark.parametrize("kind", ["fifo", "device", "loop"])
def test_fit_names_a_special_file_and_does_not_hang(tmp_path: Path, kind: str) -> None:
    """These were "no such file"; a FIFO opened for reading would wait for a writer for ever."""
    path, reason = _specials(tmp_path)[kind]
    proc = bike_rig("fit", str(path), "--rate", "1000")
    assert (proc.returncode, proc.stdout) == (2, "")
    assert proc.stderr == f"bike-rig fit: error: {path}: {reason}\n"


def test_a_rider_file_that_is_a_fifo_is_refused_not_waited_for(tmp_path: Path) -> None:
    fifo = tmp_path / "rider.yaml"
    os.mkfifo(fifo)
    proc = bike_rig("model", str(BROWSER), "--rider", str(fifo))
    assert (proc.returncode, proc.stdout) == (2, "")
    assert proc.stderr == f"bike-rig model: error: {fifo}: is a FIFO (named pipe), not a regular file\n"


# ---------------------------------------------------------------- control characters


def test_a_bicycle_name_with_escape_sequences_is_printed_escaped(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    name = 'bicycle: "Br\\e[2J\\e]0;pwned\\aow\\0ser\\x9b"'
    text = BROWSER.read_text(encoding="utf-8").replace("bicycle: Browser", name)
    bike = tmp_path / "bike.yaml"
    bike.write_text(text, encoding="utf-8")
    code, out, err = run(capsys, "params", str(bike))
    assert code == 0 and err == ""
    assert out.startswith("Br\\x1b[2J\\x1b]0;pwned\\x07ow\\x00ser\\x9b: benchmark parameters")
    assert not RAW_CONTROLS & set(out)
    code, out, _ = run(capsys, "params", str(bike), "--json")
    assert code == 0 and not RAW_CONTROLS & set(out)
    assert json.loads(out)["bicycle"] == "Br\x1b[2J\x1b]0;pwned\x07ow\x00ser\x9b"


def test_fit_prints_trial_and_file_names_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A .mat's fields name the trial; a file name may hold ESC too."""
    trial = gyro_trial(1, period=1.6)
    mat = tmp_path / "a.mat"
    fields = {"bicycle": "B\x1b[31m", "part": "Frame", "pendulum": "Torsional", "angleOrder": "First", "trial": "1"}
    savemat(mat, {"data": trial.samples, "sampleRate": 1000.0, **fields})
    csv = tmp_path / "b\x1b[2J\r.csv"
    rows = zip(trial.times.tolist(), trial.samples.tolist())
    csv.write_text("time,rate\x1b,v\n" + "".join(f"{t!r},{x!r},0\n" for t, x in rows))
    code, out, err = run(capsys, "fit", str(mat), str(csv))
    assert code == 0, err
    assert "B\\x1b[31mFrameTorsionalFirst1" in out and "b\\x1b[2J\\x0d " in out  # (the table's name column)
    assert "b\\x1b[2J\\x0d.csv" in err and "signal: column 'rate\\x1b' of time, rate\\x1b, v" in err  # (a note)
    assert not RAW_CONTROLS & set(out + err)


# ---------------------------------------------------------------- sample rates


def test_fit_refuses_a_mat_whose_rate_and_times_disagree(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """The issue's file was fitted from its times, T = 4.000 s "ok", its sampleRate (1000) ignored."""
    trial = gyro_trial(1, period=2.0)
    path = tmp_path / "disagree.mat"
    savemat(path, {"data": trial.samples, "time": trial.times * 2.0, "sampleRate": 1000.0})
    code, out, err = run(capsys, "fit", str(path))
    assert (code, out) == (2, "")
    assert err == (
        f"bike-rig fit: error: {path}: key 'sampleRate': sampleRate says 1000 Hz, but the 'time' array steps by "
        "2 ms (500 Hz): the sample rates disagree (by more than 1 %); give one, or correct the wrong one\n"
    )


# ---------------------------------------------------------------- a 60 MB one-line CSV

#: The address space the fit runs in (the issue: 1.5 GB taken, a MemoryError traceback under 1.2 GB).
ADDRESS_SPACE = 1200 << 20
#: Runs ``python ARGS`` with its address space capped at ``ADDRESS_SPACE``.
_CAPPED = (
    "import os, resource, sys; resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit})); "
    "os.execv(sys.executable, [sys.executable, *sys.argv[1:]])"
)


def test_a_60_mb_one_line_csv_is_refused_in_capped_memory(tmp_path: Path) -> None:
    """Before: 1.5 GB (15 M cells as Python strings and floats) and a MemoryError traceback under 1.2 GB.

    (Its peak resident set and time: bench/bench_input_memory.py.)
    """
    path = tmp_path / "one-line.csv"
    path.write_text("0.1," * 14_999_999 + "0.1\n")
    assert path.stat().st_size == 59_999_999 + 1
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-c", _CAPPED.format(limit=ADDRESS_SPACE), "-m", "bike_rig.cli.main", "fit", str(path)]
    done = subprocess.run([*cmd, "--rate", "1000"], capture_output=True, text=True, env=env, timeout=120, check=False)
    assert done.returncode == 2, done.stderr
    assert done.stderr == (
        f"bike-rig fit: error: {path}: line 1 is 60 MB long: not a CSV of samples "
        "(a row of samples is at most 65536 characters)\n"
    )


def test_a_large_csv_is_read_whole(tmp_path: Path) -> None:
    """1.5 M rows of time,rate (31 MB): every row read (the memory it takes: bench/bench_input_memory.py)."""
    t = np.arange(1_500_000) / 1000.0
    x = np.exp(-0.01 * t) * np.sin(2 * np.pi * t / 1.6)
    path = tmp_path / "long.csv"
    with path.open("w") as f:
        f.write("time,rate\n")
        np.savetxt(f, np.column_stack([t, x]), fmt="%.6f", delimiter=",")
    trial = read_trial(path)
    assert trial.samples.size == t.size
    assert np.max(np.abs(trial.samples - x)) <= 5.0000001e-7  # (written with 6 decimals)
