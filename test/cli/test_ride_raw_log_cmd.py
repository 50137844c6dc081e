"""``bike-rig ride simulate --raw-log``: a whole raw log, then ``ride fit --segments find`` on it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_dir

BROWSER = str(config_dir() / "bicycles" / "browser.yaml")


def test_a_simulated_raw_log_is_segmented_push_by_push(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "log.csv"
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--speed", "5", "--duration", "179"]
    assert main([*argv, "--raw-log", "3", "--seed", "3", "-o", str(out)]) == 0
    told = capsys.readouterr().out
    decays = [(float(a), float(b)) for a, b in re.findall(r"free decay ([\d.]+)–([\d.]+) s", told)]
    assert len(decays) == 3 and out.read_text().splitlines()[0] == "time,roll_rate,wheel_speed"
    assert main(["ride", "fit", str(out), "--segments", "find", "--json"]) == 0
    segments = json.loads(capsys.readouterr().out)
    assert len(segments) == 3
    for seg, (start, stop) in zip(segments, decays, strict=True):
        assert abs(seg["start"] - start) < 0.3 and abs(seg["stop"] - stop) < 1.0
        assert seg["speed"] == pytest.approx(5.0, abs=0.05) and "wheel speed" in seg["start_reason"]
        assert not any(f.startswith("unconfirmed_kick") for f in seg["flags"])


def test_a_raw_log_without_wheel_speed_gives_no_clean_eigenvalue(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Roll rate alone: the rider's motions look like pushes, so no segment found in it is clean."""
    out = tmp_path / "log.csv"
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--speed", "5", "--duration", "179"]
    assert main([*argv, "--raw-log", "3", "--seed", "3", "-o", str(out)]) == 0
    capsys.readouterr()
    rows = [line.split(",") for line in out.read_text().splitlines()]
    roll = tmp_path / "roll.csv"
    roll.write_text("\n".join(",".join(r[:2]) for r in rows) + "\n", encoding="utf-8")
    assert main(["ride", "fit", str(roll), "--segments", "find", "--speed", "5", "--json"]) == 0
    segments = json.loads(capsys.readouterr().out)
    assert len(segments) >= 3
    for seg in segments:
        assert any(f.startswith("unconfirmed_kick") and "no wheel speed" in f for f in seg["flags"])


def test_a_raw_log_needs_a_csv_and_pushes(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    argv = ["ride", "simulate", BROWSER, "--speed", "5", "--raw-log", "-1", "-o", str(tmp_path / "x.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--raw-log needs N >= 0" in err and len(err.strip().splitlines()) == 1


def test_a_log_without_pushes_says_why_it_has_no_segment(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "riding.csv"
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--speed", "5", "--duration", "90", "--raw-log", "0"]
    assert main([*argv, "--seed", "4", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["ride", "fit", str(out), "--segments", "find"]) == 0
    got = capsys.readouterr()
    assert got.out == "" and len(got.err.strip().splitlines()) == 1
    assert "no segment" in got.err and "none within 0.3 s of a wheel-speed transient" in got.err


def test_a_raw_log_follows_the_feedback_it_is_given(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """``--feedback`` sets the raw log's assist; without it the simulator's own assist (said so)."""
    own = "k_phidot: {speeds: [2.0, 3.3333333333333335, 5.0], values: [-50.0, -25.0, -20.0]}\nk_deltadot: 1.0\n"
    other = "k_phidot: -50.0\nk_deltadot: 1.0\n"
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--speed", "5", "--duration", "40", "--seed", "4"]
    logs = {}
    for name, gains in (("none", None), ("own", own), ("other", other)):
        extra = []
        if gains is not None:
            fb = tmp_path / f"{name}.yaml"
            fb.write_text(f"format: bike_rig-feedback/1\nname: {name} gains\n{gains}", encoding="utf-8")
            extra = ["--feedback", str(fb)]
        out = tmp_path / f"{name}.csv"
        assert main([*argv, *extra, "--raw-log", "1", "-o", str(out)]) == 0
        told = capsys.readouterr().out
        assert ("the simulator's own assist" in told) == (gains is None), told
        assert gains is None or f"assist {name} gains" in told, told
        logs[name] = out.read_text()
    assert logs["own"] == logs["none"]  # the same gains: the same log, draw for draw
    assert logs["other"] != logs["none"]
