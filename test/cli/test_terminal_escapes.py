"""Names and paths that hold control characters are printed escaped by every command's text output."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.cli import run_cmd
from bike_rig.config.paths import config_dir
from bike_rig.core.textfmt import CONTROL_CHARACTERS
from test.support.cli import run

BROWSER = config_dir() / "bicycles" / "browser.yaml"
BENCHMARK = config_dir() / "bicycles" / "benchmark.yaml"
RAW_CONTROLS = {chr(c) for c in CONTROL_CHARACTERS} - {"\n", "\t"}
EVIL = "Br\x1b[2J\x1b]0;pwned\x07ow\x00ser\x9b"
SHOWN = "Br\\x1b[2J\\x1b]0;pwned\\x07ow\\x00ser\\x9b"


@pytest.fixture
def evil_bike(tmp_path: Path) -> Path:
    name = 'bicycle: "Br\\e[2J\\e]0;pwned\\aow\\0ser\\x9b"'
    bike = tmp_path / "bike.yaml"
    bike.write_text(BROWSER.read_text(encoding="utf-8").replace("bicycle: Browser", name), encoding="utf-8")
    return bike


def test_report_and_import_bp_print_the_name_escaped(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, evil_bike: Path
) -> None:
    code, out, err = run(capsys, "report", str(evil_bike), "-o", str(tmp_path / "r"))
    assert code == 0 and f": {SHOWN} (measurements)" in err and not RAW_CONTROLS & set(out + err)
    code, out, err = run(capsys, "import-bp", str(evil_bike), "-o", str(tmp_path / "x.yaml"))
    assert code == 0 and f": {SHOWN} measurements" in err and not RAW_CONTROLS & set(out + err)


def test_ride_simulate_prints_its_output_path_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_path = tmp_path / "r\x1b[2J.csv"
    code, out, err = run(
        capsys, "ride", "simulate", str(BENCHMARK), "--speed", "5", "--duration", "3", "-o", str(out_path)
    )
    assert code == 0, err
    assert "r\\x1b[2J.csv" in out and not RAW_CONTROLS & set(out + err)


def test_session_errors_print_the_file_name_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    missing = tmp_path / f"{EVIL.replace(chr(0), '')}.yaml"  # (no argument of a real process holds NUL)
    code, out, err = run(capsys, "session", "--plain", "--bicycle", str(missing), "--output", str(tmp_path / "s"))
    assert code == 2 and err.startswith("bike-rig session: error: ") and err.count("\n") == 1
    assert SHOWN.replace("\\x00", "") in err and not RAW_CONTROLS & set(out + err)


def test_run_says_and_prints_lines_escaped(capsys: pytest.CaptureFixture[str]) -> None:
    run_cmd._say(f"bicycle {EVIL}")
    run_cmd._out(f"TtB1#1 {EVIL} - ok")
    out, err = capsys.readouterr()
    assert out == f"TtB1#1 {SHOWN} - ok\n" and err == f"bike-rig run: bicycle {SHOWN}\n"
