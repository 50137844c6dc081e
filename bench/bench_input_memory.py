"""Memory that hostile or large input files take on their way in (the tests check the refusals).

Prints, each against its target:

* ``bike-rig fit`` of a 60 MB CSV of one line (refused: a row of samples is at most 65536
  characters) under a 1.2 GB address space: its peak resident set, against that of a process
  that only imports the command line (target: the file is never held whole, < 150 MB);
* :func:`bike_rig.core.trials.read_trial` of a 31 MB CSV of 1.5 M rows ``time,rate``: how much
  its peak resident set grew, as a multiple of the file's size (target < 2: only the two
  columns are kept, 8 bytes a number);
* a YAML "billion laughs" of about 340 bytes refused by the reader: tracemalloc's peak (target < 20 MB).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from bike_rig.core.errors import InputFileError
from bike_rig.core.io_yaml import load_yaml_document

REPO = Path(__file__).resolve().parents[1]
#: The address space the refusal runs in, bytes.
ADDRESS_SPACE = 1200 << 20
ONE_LINE_PEAK_TARGET = 150e6
GROWTH_TARGET = 2.0
ALIAS_BOMB_PEAK_TARGET = 20e6

_MEASURE = """
import json, resource, subprocess, sys, time
def cap():
    resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
started = time.monotonic()
proc = subprocess.run(sys.argv[1:], capture_output=True, text=True, preexec_fn=cap, timeout=120)
peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
seconds = time.monotonic() - started
print(json.dumps({{"code": proc.returncode, "stderr": proc.stderr, "peak": peak, "seconds": seconds}}))
"""


def measured(cmd: list[str]) -> tuple[int, str, float, float]:
    """``cmd`` run under the address-space cap: its status, stderr, peak RSS [bytes] and wall time [s]."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    wrapper = [sys.executable, "-c", _MEASURE.format(limit=ADDRESS_SPACE), *cmd]
    got = json.loads(subprocess.run(wrapper, capture_output=True, text=True, env=env, check=True).stdout)
    return int(got["code"]), str(got["stderr"]), float(got["peak"]), float(got["seconds"])


def one_line_csv(directory: Path) -> bool:
    path = directory / "one-line.csv"
    path.write_text("0.1," * 14_999_999 + "0.1\n")
    fit = [sys.executable, "-m", "bike_rig.cli.main", "fit", str(path), "--rate", "1000"]
    code, stderr, peak, seconds = measured(fit)
    floor = measured([sys.executable, "-c", "import bike_rig.cli.main, bike_rig.core.trials"])[2]
    refused = code == 2 and "line 1 is 60 MB long" in stderr
    ok = refused and peak < ONE_LINE_PEAK_TARGET
    print(
        f"fit of a 60 MB one-line CSV: {'refused' if refused else 'NOT REFUSED'} in {seconds:.2f} s, "
        f"peak RSS {peak / 1e6:.0f} MB ({peak / floor:.1f} x the imports' {floor / 1e6:.0f} MB; "
        f"target < {ONE_LINE_PEAK_TARGET / 1e6:.0f} MB): {'OK' if ok else 'MISSED'}"
    )
    return ok


def large_csv(directory: Path) -> bool:
    t = np.arange(1_500_000) / 1000.0
    x = np.exp(-0.01 * t) * np.sin(2 * np.pi * t / 1.6)
    path = directory / "long.csv"
    with path.open("w") as f:
        f.write("time,rate\n")
        np.savetxt(f, np.column_stack([t, x]), fmt="%.6f", delimiter=",")
    size = path.stat().st_size
    code = (  # VmHWM: this process's peak RSS (ru_maxrss would start at the parent's, inherited through exec)
        "import re, sys, time; from bike_rig.core.trials import read_trial\n"
        "def peak(): return int(re.search(r'VmHWM:\\s+(\\d+)', open('/proc/self/status').read())[1]) * 1024\n"
        "before = peak(); t0 = time.perf_counter(); trial = read_trial(sys.argv[1])\n"
        "print(trial.samples.size, peak() - before, time.perf_counter() - t0)"
    )
    env = dict(os.environ, PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, env=env, check=True)
    rows, grown, seconds = out.stdout.split()
    ratio = int(grown) / size
    ok = int(rows) == t.size and ratio < GROWTH_TARGET
    print(
        f"read_trial of a {size / 1e6:.0f} MB CSV ({int(rows):,} rows) in {float(seconds):.2f} s: peak RSS grew by "
        f"{int(grown) / 1e6:.0f} MB, {ratio:.2f} x the file (target < {GROWTH_TARGET:g}): {'OK' if ok else 'MISSED'}"
    )
    return ok


def alias_bomb(directory: Path) -> bool:
    text = 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
    for prev, name in zip("abcdefg", "bcdefgh", strict=True):
        text += f"{name}: &{name} [" + ",".join([f"*{prev}"] * 9) + "]\n"
    path = directory / "bomb.yaml"
    path.write_text(text + "format: bike_rig-measurements/1\n")
    refused = False
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        load_yaml_document(path)
    except InputFileError as exc:
        refused = "expands to more than 100000 values" in str(exc)
    finally:
        seconds = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    ok = refused and peak < ALIAS_BOMB_PEAK_TARGET
    print(
        f"YAML alias bomb ({len(text)} bytes): {'refused' if refused else 'NOT REFUSED'} in {seconds:.3f} s, "
        f"tracemalloc peak {peak / 1e6:.1f} MB (target < {ALIAS_BOMB_PEAK_TARGET / 1e6:.0f} MB): "
        f"{'OK' if ok else 'MISSED'}"
    )
    return ok


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        results = [one_line_csv(directory), large_csv(directory), alias_bomb(directory)]
    print(f"input memory: {'OK' if all(results) else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
