"""``bike-rig plot``: every kind writes its files under the documented names and prints them.

User mistakes end in one line and exit status 2 before anything is drawn.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import main
from bike_rig.cli.plot_cmd import figure_stem, unique_names
from bike_rig.config.paths import config_file
from bike_rig.core.sim import write_session
from bike_rig.offline.subjects import load_subject
from test.support.simulated import short_session

BROWSER = str(config_file("bicycles/browser.yaml"))
YELLOW = str(config_file("bicycles/yellow.yaml"))
BENCHMARK = str(config_file("bicycles/benchmark.yaml"))
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
#: The only period of the small session still given as trial files.
KEPT = "rear_wheel_compound"


@pytest.fixture(scope="module")
def small_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated Browser session whose rear-wheel compound period keeps its 3 trial files.

    Every other period is the mean of its trials, as a number (3 fit figures, not 39).
    """
    root = tmp_path_factory.mktemp("plot_cmd")
    path = write_session(short_session(), root / "session")
    full = load_subject(path)
    period = {Path(t.source).name: t.fit.period for t in full.trials}
    text = path.read_text()

    def as_number(match: re.Match[str]) -> str:
        files = [Path(f.strip()).name for f in match.group(1).split(",")]
        if files[0].startswith(KEPT):
            return match.group(0)
        return f"[{float(np.mean([period[f] for f in files]))!r}, 0.0002]"

    small = root / "session" / "small.yaml"
    small.write_text(re.sub(r"\{trials: \[([^\]]*)\]\}", as_number, text))
    return small


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, list[str], str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


def test_side_writes_png_and_svg_and_prints_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "new" / "figures"  # created, parents too
    code, lines, err = run(capsys, "plot", "side", BROWSER, YELLOW, "-o", str(out), "--format", "png,svg")
    assert code == 0, err
    assert lines == [str(out / "side.png"), str(out / "side.svg")]
    assert (out / "side.png").read_bytes()[:8] == PNG_MAGIC
    svg = (out / "side.svg").read_text()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg


def test_trials_and_fits_of_a_session(small_session: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, err = run(capsys, "plot", "trials", str(small_session), "-o", str(tmp_path))
    assert code == 0, err
    assert lines == [str(tmp_path / "trials_browser.png")]
    code, lines, err = run(capsys, "plot", "fits", str(small_session), "-o", str(tmp_path))
    assert code == 0, err
    assert lines == [str(tmp_path / f"fit_browser_rear-wheel-compound-t{k}.png") for k in (1, 2, 3)]
    assert all(Path(p).read_bytes()[:8] == PNG_MAGIC for p in lines)


def test_model_kinds_per_rider(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, err = run(
        capsys, "plot", "eigen", BROWSER, "-o", str(tmp_path), "--rider", "both", "--speeds", "0", "8", "41"
    )
    assert code == 0, err
    assert lines == [str(tmp_path / "eigen.png"), str(tmp_path / "eigen_rider.png")]
    code, lines, err = run(
        capsys,
        "plot",
        "bode",
        BROWSER,
        YELLOW,
        "-o",
        str(tmp_path),
        "--rider",
        "paper",
        "--input",
        "roll-torque",
        "--output",
        "steer_angle",
        "--speed",
        "4",
    )
    assert code == 0, err
    assert lines == [str(tmp_path / "bode_rider.png")]


def test_all_skips_trial_figures_of_inputs_without_trials(
    small_session: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines, err = run(capsys, "plot", "all", str(small_session), BENCHMARK, "-o", str(tmp_path))
    assert code == 0, err
    names = [Path(p).name for p in lines]
    assert names[:5] == ["eigen.png", "locus.png", "modes.png", "bode.png", "side.png"]
    assert names[5:] == ["trials_browser.png"] + [f"fit_browser_rear-wheel-compound-t{k}.png" for k in (1, 2, 3)]
    assert f"{BENCHMARK}: no trials to plot: it is a parameter file" in err
    assert all(Path(p).is_file() for p in lines)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["plot", "wheels", BROWSER], "unknown figure kind 'wheels'"),
        (["plot", "side", BROWSER, "--format", "png,jpg"], "--format: unknown format 'jpg'"),
        (["plot", "trials", BENCHMARK], f"{BENCHMARK}: no trials to plot: it is a parameter file"),
        (["plot", "fits", BROWSER], f"{BROWSER}: no trials to plot: its periods are numbers, not trial files"),
        (["plot", "bode", BROWSER, "--input", "pedal torque"], "--input: unknown 'pedal torque'"),
        (["plot", "eigen", BROWSER, "--speeds", "5", "1", "3"], "--speeds START STOP N needs"),
        (["plot", "eigen", BROWSER, "--speeds", "0", "1e6", "5"], "STOP <= 100 m/s"),
        (["plot", "bode", BROWSER, "--speed", "1e300"], "--speed must be a finite number from 0 to 100 m/s"),
        (["plot", "side", "missing.yaml"], "missing.yaml: no such file or directory"),
    ],
)
def test_user_mistakes(argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code, lines, err = run(capsys, *argv, "-o", str(out))
    assert code == 2
    assert lines == []
    assert err.count("\n") == 1 and err.startswith("bike-rig plot: error: ") and message in err
    assert not any(out.glob("*"))  # nothing drawn


def test_unwritable_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a directory")
    code, _, err = run(capsys, "plot", "side", BROWSER, "-o", str(blocker))
    assert code == 2 and f"{blocker}: exists and is not a directory" in err
    code, _, err = run(capsys, "plot", "side", BROWSER, "-o", str(blocker / "sub"))
    assert code == 2 and f"{blocker / 'sub'}: cannot create the directory" in err


def test_file_names() -> None:
    assert unique_names(["Browser", "Browser", "Yellow Rev", "Browser"]) == [
        "browser",
        "browser-2",
        "yellow-rev",
        "browser-3",
    ]
    out = Path("d")
    assert figure_stem(out, "eigen", rider="paper") == out / "eigen_rider"
    assert figure_stem(out, "trials", "browser") == out / "trials_browser"
    assert figure_stem(out, "fits", "browser", trial="Frame T1") == out / "fit_browser_frame-t1"


def test_real_process(tmp_path: Path) -> None:
    """Through a real interpreter: the files, one path per line; a mistake is one line, exit 2."""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]), MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "bike_rig.cli.main", "plot"]
    proc = subprocess.run(
        [*cmd, "side", BROWSER, "-o", str(tmp_path)], capture_output=True, text=True, env=env, timeout=120, check=False
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == [str(tmp_path / "side.png")] and proc.stderr == ""
    proc = subprocess.run(
        [*cmd, "trials", BENCHMARK, "-o", str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        f"bike-rig plot: error: {BENCHMARK}: no trials to plot: it is a parameter file, which holds no trials"
    ]
