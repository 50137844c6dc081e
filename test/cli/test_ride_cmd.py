"""``bike-rig ride``: fit, validate and simulate, end to end on simulated rides (CSV and bag)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from test.support.cli import run
from test.support.rides import ASSIST, BROWSER, simulate_ride

SEGMENT_KEYS = {"file", "speed", "real", "real_sigma", "imag", "imag_sigma", "valid", "flags"}


@pytest.fixture(scope="module")
def long_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_ride(tmp_path_factory.mktemp("ride") / "long.csv", 4.5, 25, seed=3)


def test_fit_json_has_one_object_per_segment(capsys: pytest.CaptureFixture[str], long_csv: Path) -> None:
    code, out, _ = run(capsys, "ride", "fit", str(long_csv), "--json")
    assert code == 0
    segs = json.loads(out)
    assert len(segs) == 4  # kicks at 1, 7, 13, 19 s
    for s in segs:
        assert SEGMENT_KEYS <= set(s) and s["valid"] and s["imag"] > 0 and s["file"] == str(long_csv)
        assert s["speed"] == pytest.approx(4.5, abs=0.02)  # the speed column's mean
    code, out, _ = run(capsys, "ride", "fit", str(long_csv), "--json", "--speed", "4.4", "--segments", "whole")
    (whole,) = json.loads(out)
    assert whole["speed"] == 4.4 and whole["start"] == 0.0


def test_validate_agrees_with_the_closed_loop_and_not_the_open(
    capsys: pytest.CaptureFixture[str], long_csv: Path, tmp_path: Path
) -> None:
    base = ("ride", "validate", BROWSER, str(long_csv), "--rider", "paper", "--json")
    code, out, _ = run(capsys, *base, "--feedback", ASSIST, "-o", str(tmp_path / "figs"))
    assert code == 0
    got = json.loads(out)
    assert {
        "segments",
        "predicted_real",
        "predicted_imag",
        "predicted_real_sigma",
        "predicted_imag_sigma",
        "normalised_deviation",
        "speeds",
    } <= set(got)
    assert len(got["predicted_real"]) == len(got["segments"]) == 4
    assert got["normalised_deviation"] < 3.0
    assert (tmp_path / "figs" / "ride_validation.png").stat().st_size > 0
    assert (tmp_path / "figs" / "segments_long.png").stat().st_size > 0
    code, out, _ = run(capsys, *base)  # the open loop: the rider's bicycle without the assist
    assert code == 0 and json.loads(out)["normalised_deviation"] > 10.0


def test_bag_records_are_read_with_the_imu_default(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bag = simulate_ride(tmp_path / "ride_bag", 4.0, 14)
    code, out, _ = run(
        capsys, "ride", "fit", str(bag), "--json", "--speed", "4.0", "--torque-topic", "/ride/steer_torque"
    )
    segs = json.loads(out)
    assert code == 0 and len(segs) == 2 and all(s["valid"] for s in segs)
    assert np.all(np.array([s["imag"] for s in segs]) > 0)
    # without --speed: the speed is read from the live graph's speed topic, which the bag has
    code, out, _ = run(capsys, "ride", "fit", str(bag), "--json", "--torque-topic", "/ride/steer_torque")
    assert code == 0 and [s["speed"] for s in json.loads(out)] == pytest.approx([4.0, 4.0], abs=0.02)
    code, _, err = run(capsys, "ride", "fit", str(bag), "--topic", "/nope")
    assert code == 2 and "no topic /nope" in err and "/imu/data" in err
    code, _, err = run(capsys, "ride", "fit", str(bag), "--field", "angular_velocity.w")
    assert code == 2 and "no field 'angular_velocity.w'" in err


@pytest.mark.parametrize(
    ("argv", "expect"),
    [
        (("ride", "fit", "missing.csv"), "missing.csv: no such file"),
        (("ride", "fit", "{csv}", "--signal", "yaw"), "no signal column 'yaw'"),
        (("ride", "fit", "{csv}", "--speed", "-1"), "--speed must be"),
        (("ride", "validate", BROWSER, "{nospeed}"), "has no speed"),
        (("ride", "simulate", BROWSER, "--speed", "4", "--duration", "0", "-o", "{tmp}/x.csv"), "--duration must be"),
        (("ride", "fit", "{tmp}", "--topic", "/nope"), "not a rosbag2 bag"),
    ],
)
def test_user_mistakes_end_in_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, long_csv: Path, argv: tuple[str, ...], expect: str
) -> None:
    nospeed = tmp_path / "nospeed.csv"
    nospeed.write_text(
        "\n".join(line.split(",")[0] + "," + line.split(",")[1] for line in long_csv.read_text().splitlines()[:400])
    )
    args = [a.format(csv=long_csv, nospeed=nospeed, tmp=tmp_path) for a in argv]
    code, _, err = run(capsys, *args)
    assert code == 2 and expect in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_plot_ride_is_a_registered_figure_drawn_only_for_records(
    capsys: pytest.CaptureFixture[str], long_csv: Path, tmp_path: Path
) -> None:
    code, out, _ = run(
        capsys,
        "plot",
        "ride",
        BROWSER,
        "--rider",
        "paper",
        "--feedback",
        ASSIST,
        "--ride",
        str(long_csv),
        "-o",
        str(tmp_path),
    )
    assert code == 0 and out.split() == [str(tmp_path / "ride_rider.png")]
    code, _, err = run(capsys, "plot", "ride", BROWSER, "-o", str(tmp_path))
    assert code == 2 and "--ride RECORD" in err


def test_validate_gives_a_verdict_in_words_per_speed_and_overall(
    capsys: pytest.CaptureFixture[str], long_csv: Path
) -> None:
    base = ("ride", "validate", BROWSER, str(long_csv), "--rider", "paper", "--feedback", ASSIST)
    code, out, _ = run(capsys, *base)
    assert code == 0 and "nan" not in out.lower()
    assert "4.50 m/s (4 segments)" in out and ": agrees within " in out
    assert out.splitlines()[-1].startswith("verdict: the model agrees with the ride at the one speed")
    code, out, _ = run(capsys, *base, "--json")
    got = json.loads(out)
    assert got["verdict"] == "agrees" and got["verdict_text"].startswith("the model agrees")
    assert {"verdict", "verdict_text", "verdict_sigma", "model_sigma_method"} <= set(got["speeds"][0])
    assert all(s["verdict"] == "agrees" and s["model_sigma_method"] == "linear" for s in got["segments"])
    code, out, _ = run(capsys, "ride", "validate", BROWSER, str(long_csv), "--rider", "paper")  # the open loop
    assert code == 0 and "verdict: the model disagrees with the ride at 1 of 1 speeds (4.50 m/s)" in out
    assert "the measured weave" in out and "nan" not in out.lower()


def test_validate_near_a_branch_point_uses_a_monte_carlo_sigma_and_says_so(
    capsys: pytest.CaptureFixture[str], long_csv: Path
) -> None:
    """At 0.783 m/s the open loop's weave pair is being born: its first-order σ is not defined."""
    base = ("ride", "validate", BROWSER, str(long_csv), "--rider", "paper", "--speed", "0.783")
    code, out, _ = run(capsys, *base)
    assert code == 0 and "nan" not in out.lower()
    assert "(Monte Carlo σ)" in out and "model σ by Monte Carlo: the linear σ is not defined near a branch point" in out
    code, out, _ = run(capsys, *base, "--json")
    got = json.loads(out)
    assert got["speeds"][0]["model_sigma_method"] == "monte_carlo" and got["speeds"][0]["predicted_real_sigma"] > 0
    assert got["verdict"] in ("agrees", "tension", "disagrees") and got["normalised_deviation"] is not None


def test_validate_without_a_clean_segment_says_so_and_exits_0(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    rng = np.random.default_rng(1)
    noise = tmp_path / "noise.csv"
    t = np.arange(300) / 100.0
    rows = "".join(f"{a:.2f},{b:.5f},3.0\n" for a, b in zip(t, rng.normal(0, 0.01, t.size), strict=True))
    noise.write_text("time,roll_rate,speed\n" + rows)
    code, out, _ = run(capsys, "ride", "validate", BROWSER, str(noise), "--rider", "paper")
    assert code == 0 and "nan" not in out.lower()
    assert "3.00 m/s: no verdict: no clean segment" in out
    assert "overall normalised deviation (RMS over clean segments): none (no clean segment)" in out
    assert out.splitlines()[-1].startswith("verdict: no verdict: no clean segment")
    code, out, _ = run(capsys, "ride", "validate", BROWSER, str(noise), "--rider", "paper", "--json")
    got = json.loads(out)
    assert got["verdict"] == "no_clean_segment" and got["normalised_deviation"] is None
    assert got["speeds"][0]["verdict"] == "no_clean_segment" and got["speeds"][0]["n_used"] == 0


def test_validate_of_records_without_any_segment_says_so_and_exits_0(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A record with no kick in it (a constant roll rate, 8 s: searched for kicks): no segment, words, exit 0."""
    still = tmp_path / "still.csv"
    t = np.arange(800) / 100.0
    still.write_text("time,roll_rate,speed,steer_torque\n" + "".join(f"{a:.2f},0.0,3.0,0.0\n" for a in t))
    code, out, err = run(capsys, "ride", "validate", BROWSER, str(still), "--rider", "paper")
    assert code == 0, err
    assert "nan" not in out.lower()
    assert out.splitlines()[-1] == "verdict: no verdict: no segment found in the records"
    code, out, _ = run(capsys, "ride", "validate", BROWSER, str(still), "--rider", "paper", "--json")
    got = json.loads(out)
    assert got["verdict"] == "no_segment" and got["segments"] == [] and got["normalised_deviation"] is None


def test_fit_of_a_record_without_a_speed_prints_no_nan(capsys: pytest.CaptureFixture[str], long_csv: Path) -> None:
    """A record with no speed column and no --speed: each segment's speed is said to be unknown."""
    lines = long_csv.read_text().splitlines()
    cols = lines[0].split(",")
    keep = [i for i, c in enumerate(cols) if c != "speed"]
    bare = long_csv.with_name("no_speed.csv")
    bare.write_text("".join(",".join(ln.split(",")[i] for i in keep) + "\n" for ln in lines))
    code, out, err = run(capsys, "ride", "fit", str(bare))
    assert code == 0, err
    assert "nan" not in out.lower() and out.count("speed unknown") == 4, out


def test_fit_leaves_out_samples_that_are_not_numbers_and_says_so(
    capsys: pytest.CaptureFixture[str], long_csv: Path
) -> None:
    """Six NaN samples early in a decay: noted on stderr, and the segment is still found and fitted."""
    lines = long_csv.read_text().splitlines()
    col = lines[0].split(",").index("roll_rate")
    rows = [ln.split(",") for ln in lines[1:]]
    for row in rows:
        if 1.5 <= float(row[0]) <= 1.55:
            row[col] = "nan"
    holed = long_csv.with_name("holed.csv")
    holed.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    code, out, err = run(capsys, "ride", "fit", str(holed), "--json")
    assert code == 0, err
    assert "6 samples of roll_rate are not numbers" in err and "1.500 and 1.550 s" in err
    whole, holes = json.loads(run(capsys, "ride", "fit", str(long_csv), "--json")[1]), json.loads(out)
    assert len(holes) == len(whole) == 4
    assert holes[0]["valid"] and abs(holes[0]["real"] - whole[0]["real"]) < whole[0]["real_sigma"]
    all_nan = long_csv.with_name("all_nan.csv")
    all_nan.write_text("time,roll_rate\n0,nan\n0.01,nan\n0.02,0.1\n")
    code, _, err = run(capsys, "ride", "fit", str(all_nan))
    assert code == 2 and "1 of 3 samples of roll_rate are numbers" in err and len(err.strip().splitlines()) == 1
