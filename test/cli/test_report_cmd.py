"""``bike-rig report``: writes DIR/index.html; user mistakes end in one line and exit status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from test.support.cli import run

BENCHMARK = config_file("bicycles/benchmark.yaml")


def test_report_writes_the_page(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "report"
    code, stdout, err = run(capsys, "report", str(BENCHMARK), "-o", str(out), "-j", "1")
    assert code == 0, err
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "<title>Benchmark: bicycle parameter report</title>" in page
    assert page.count("<img ") == 9
    assert stdout == ""
    lines = err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"wrote {out / 'index.html'}: Benchmark (parameters), 9 figures, 0 trials, in ")


def _one_line_error(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    code, stdout, err = run(capsys, "report", *argv)
    assert code == 2
    assert stdout == ""
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("bike-rig report: error: ")
    assert "Traceback" not in err
    return err


def test_report_bad_inputs(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = str(tmp_path / "out")
    err = _one_line_error(capsys, str(tmp_path / "missing.yaml"), "-o", out)
    assert "missing.yaml: no such file or directory" in err
    err = _one_line_error(capsys, str(config_file("rig.yaml")), "-o", out)
    assert "rig.yaml: unknown kind of YAML file" in err
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        config_file("bicycles/browser.yaml").read_text().replace("mass: [9.86, 0.02]", "mass: [-9.86, 0.02]")
    )
    err = _one_line_error(capsys, str(bad), "-o", out)
    assert "bad.yaml:" in err and "frame.mass" in err
    empty_bag = tmp_path / "bag"
    empty_bag.mkdir()
    err = _one_line_error(capsys, str(empty_bag), "-o", out)
    assert str(empty_bag) in err
    assert not Path(out).exists()  # nothing written for a bad input


def test_report_bad_output(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    target = tmp_path / "a-file"
    target.write_text("x")
    err = _one_line_error(capsys, str(BENCHMARK), "-o", str(target))
    assert f"{target}: exists and is not a directory" in err


def test_report_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["report", str(BENCHMARK)], ["report", str(BENCHMARK), "-o", "x", "-j", "0"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    assert "usage: bike-rig report" in capsys.readouterr().err
