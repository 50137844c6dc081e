"""``bike-rig simulate``: writes the session directory; a bad rig file ends in one line."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
import yaml

from bike_rig.cli import simulate_cmd
from bike_rig.cli.main import main
from bike_rig.config.paths import config_dir, config_file
from bike_rig.core.errors import BikeRigError, InputFileError
from bike_rig.core.sim.errors import RigFileError

BROWSER = str(config_dir() / "bicycles" / "browser.yaml")
BENCHMARK = str(config_dir() / "bicycles" / "benchmark.yaml")


def _parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="bike-rig")
    simulate_cmd.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(["simulate", *argv])


def test_simulate_writes_the_session_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path / "s"), "--seed", "7")
    assert args.func is simulate_cmd.run
    assert args.func(args) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"wrote {tmp_path / 's' / 'session.yaml'}: Browser, 39 trials of 30 s at 1000 Hz")
    assert err.rstrip().endswith("seed 7") and err.count("\n") == 1
    assert len(list((tmp_path / "s" / "trials").glob("*.npy"))) == 39
    truth = yaml.safe_load((tmp_path / "s" / "truth.yaml").read_text(encoding="utf-8"))
    assert truth["seed"] == 7 and truth["bicycle"] == "Browser"
    assert truth["rig"] == str(config_file("rig.yaml"))
    # the same seed writes the same files, byte for byte
    again = _parse("--bicycle", BROWSER, "--out", str(tmp_path / "again"), "--seed", "7")
    assert again.func(again) == 0
    for f in sorted((tmp_path / "s").rglob("*")):
        if f.is_file():
            assert f.read_bytes() == (tmp_path / "again" / f.relative_to(tmp_path / "s")).read_bytes(), f


def test_simulate_from_a_parameter_file_with_a_fresh_seed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = _parse("--bicycle", BENCHMARK, "--out", str(tmp_path / "b"), "--volts")
    assert args.func(args) == 0
    seed = int(capsys.readouterr().err.rsplit("seed ", 1)[1])
    assert yaml.safe_load((tmp_path / "b" / "truth.yaml").read_text(encoding="utf-8"))["seed"] == seed
    assert len(list((tmp_path / "b" / "volts").glob("*.npy"))) == 39


def test_simulate_refuses_a_non_empty_directory_unless_forced(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine", encoding="utf-8")
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path), "--seed", "1")
    with pytest.raises(InputFileError, match="not empty"):
        args.func(args)
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path), "--seed", "1", "--force")
    assert args.func(args) == 0
    assert (tmp_path / "notes.txt").read_text(encoding="utf-8") == "mine"
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path / "notes.txt"), "--seed", "1")
    with pytest.raises(InputFileError, match="not a directory"):
        args.func(args)


def test_bad_rig_file_is_a_one_line_error(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    text = config_file("rig.yaml").read_text(encoding="utf-8")
    rig.write_text(text.replace("sample_rate: 1000", "sample_rate: fast"), encoding="utf-8")
    line = text[: text.index("sample_rate: 1000")].count("\n") + 1
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path / "s"), "--rig", str(rig), "--seed", "1")
    with pytest.raises(RigFileError) as err:
        args.func(args)
    assert str(err.value) == f"{rig}:{line}: key 'adc.sample_rate': expected a number, got 'fast'"
    assert not (tmp_path / "s").exists()


def test_negative_seed_and_impossible_bicycle(tmp_path: Path) -> None:
    args = _parse("--bicycle", BROWSER, "--out", str(tmp_path / "s"), "--seed", "-3")
    with pytest.raises(BikeRigError, match="non-negative"):
        args.func(args)
    small = tmp_path / "small.yaml"
    small.write_text(
        Path(BENCHMARK).read_text(encoding="utf-8").replace("rR: [0.3, 0.0]", "rR: [0.2, 0.0]"), encoding="utf-8"
    )
    args = _parse("--bicycle", str(small), "--out", str(tmp_path / "s"), "--seed", "3")
    with pytest.raises(BikeRigError, match="rear wheel pendulum arm"):
        args.func(args)


def test_through_main_bad_rig_is_one_line_and_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rig = tmp_path / "rig.yaml"
    rig.write_text(config_file("rig.yaml").read_text(encoding="utf-8").replace("bits: 12", "bits: -12"), "utf-8")
    code = main(["simulate", "--bicycle", BROWSER, "--out", str(tmp_path / "s"), "--rig", str(rig)])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1
    assert err.startswith(f"bike-rig simulate: error: {rig}:") and "key 'adc.bits': expected a whole number" in err
    code = main(["simulate", "--bicycle", BROWSER, "--out", str(tmp_path / "s"), "--seed", "5"])
    assert code == 0 and (tmp_path / "s" / "session.yaml").is_file()
