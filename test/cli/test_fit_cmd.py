"""``bike-rig fit``: JSON Lines, table, combined period, plots, exit statuses and user errors.

Through ``bike_rig.cli.main.main``; one test also runs the sub-command on a bare parser built
with ``fit_cmd.add_parser``, as any other entry point would.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from bike_rig.cli import fit_cmd
from bike_rig.core.errors import BikeRigError
from test.support.cli import run
from test.support.signals import coupled_trial, gyro_trial

JSON_KEYS = {
    "file",
    "period",
    "period_sigma",
    "valid",
    "flags",
    "r2",
    "zeta",
    "omega",
    "n_samples",
    "window",
    "damping_model",
    "friction",
    "friction_sigma",
    "swing_amplitude",
    "swing_kappa",
    "small_swing_period",
    "small_swing_period_sigma",
    "small_swing_systematic",
    "ends_period",
    "ends_period_sigma",
}


def bare_parser_run(argv: Sequence[str]) -> int:
    """``fit`` on a parser of its own (``add_parser`` + ``run``), errors caught as ``main`` does."""
    parser = argparse.ArgumentParser(prog="bike-rig")
    fit_cmd.add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(list(argv))
    try:
        return int(args.func(args))
    except BikeRigError as exc:
        print(f"bike-rig {args.command}: error: {exc}", file=sys.stderr)
        return 2


@pytest.fixture
def trials(tmp_path: Path) -> list[Path]:
    """Three clean trials of a 1.6 s period, as .npy with times, CSV rates and .mat."""
    files = []
    t1 = gyro_trial(1, period=1.6)
    np.save(tmp_path / "t1.npy", np.column_stack([t1.times, t1.samples]))
    files.append(tmp_path / "t1.npy")
    t2 = gyro_trial(2, period=1.6)
    (tmp_path / "t2.csv").write_text("rate\n" + "\n".join(f"{v:.9g}" for v in t2.samples) + "\n")
    files.append(tmp_path / "t2.csv")
    t3 = gyro_trial(3, period=1.6)
    savemat(tmp_path / "t3.mat", {"data": t3.samples, "sampleRate": 1000.0})
    files.append(tmp_path / "t3.mat")
    return files


def test_json_lines(capsys: pytest.CaptureFixture[str], trials: list[Path]) -> None:
    code, out, err = run(capsys, "fit", *map(str, trials), "--json", "--rate", "1000")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) == 3
    for path, line in zip(trials, lines):
        doc = json.loads(line)
        assert set(doc) == JSON_KEYS
        assert doc["file"] == str(path)
        assert doc["valid"] is True and doc["flags"] == []
        assert abs(doc["period"] - 1.6) < 4 * doc["period_sigma"]
        assert doc["window"][0] == 1000 and doc["window"][1] - doc["window"][0] == doc["n_samples"]
        assert 0.9 < doc["r2"] <= 1 and doc["omega"] > 0 and doc["zeta"] > 0
        assert doc["damping_model"] == "viscous" and doc["friction"] == 0.0 and doc["small_swing_period"] is None


def test_table_and_combined_period(capsys: pytest.CaptureFixture[str], trials: list[Path]) -> None:
    code, out, _ = run(capsys, "fit", *map(str, trials), "--rate", "1000")
    assert code == 0
    assert "T [s]" in out and "σ [s]" in out
    assert out.count(" ok") == 3
    combined = re.search(
        r"combined period of all trials: T = ([0-9.]+) ± ([0-9.]+) s \(3 used, 0 flagged, 0 without", out
    )
    assert combined, out
    assert abs(float(combined[1]) - 1.6) < 3 * float(combined[2])
    assert "window: lead-in 1 s, whole cycles" in out
    code, single, _ = run(capsys, "fit", str(trials[0]))
    assert code == 0 and "combined" not in single


def test_invalid_trial_is_reported_not_an_error(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    np.save(tmp_path / "noise.npy", np.random.default_rng(0).standard_normal(20000))
    np.save(tmp_path / "good.npy", gyro_trial(4).samples)
    files = [str(tmp_path / "noise.npy"), str(tmp_path / "good.npy")]
    code, out, _ = run(capsys, "fit", *files, "--rate", "1000", "--json")
    assert code == 0
    bad, good = (json.loads(line) for line in out.splitlines())
    assert bad["valid"] is False and bad["period"] is None and bad["r2"] is None
    assert bad["flags"][0]["code"] == "no_oscillation" and "noise" in bad["flags"][0]["reason"]
    assert good["valid"] is True
    code, out, _ = run(capsys, "fit", *files, "--rate", "1000")
    assert code == 0 and "no period: redo" in out and "! no_oscillation:" in out
    assert "(1 used, 0 flagged, 1 without period" in out
    assert run(capsys, "fit", *files, "--rate", "1000", "--strict")[0] == 1
    assert run(capsys, "fit", files[1], "--rate", "1000", "--strict")[0] == 0


def test_flagged_trial_is_left_out_of_the_combination(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    np.save(tmp_path / "beat.npy", coupled_trial(1, period=1.2, exchange=0.6).samples)
    np.save(tmp_path / "ok.npy", gyro_trial(5, period=1.2).samples)
    code, out, _ = run(capsys, "fit", str(tmp_path / "beat.npy"), str(tmp_path / "ok.npy"), "--rate", "1000")
    assert code == 0
    assert "flagged: redo" in out and "! beating:" in out
    assert "(1 used, 1 flagged, 0 without period" in out and "trial beat left out, redo it" in out


def test_groups_by_period_key(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    files = []
    for order, period in (("First", 1.3), ("Second", 1.9)):
        for k in (1, 2):
            name = f"BrowserFrameTorsional{order}{k}.mat"
            samples = gyro_trial(10 * k + len(order), period=period).samples
            savemat(
                tmp_path / name,
                {
                    "data": samples,
                    "ActualRate": 1000.0,
                    "bicycle": "Browser",
                    "part": "Frame",
                    "pendulum": "Torsional",
                    "angleOrder": order,
                    "trial": str(k),
                },
            )
            files.append(str(tmp_path / name))
    code, out, _ = run(capsys, "fit", *files)
    assert code == 0
    assert "BrowserFrameTorsionalFirst1" in out
    for key, period in (("TtB1", 1.3), ("TtB2", 1.9)):
        found = re.search(rf"combined period of {key}: T = ([0-9.]+) ± ([0-9.]+) s \(2 used", out)
        assert found, out
        assert abs(float(found[1]) - period) < 4 * float(found[2])


def test_window_options(capsys: pytest.CaptureFixture[str], trials: list[Path]) -> None:
    f = str(trials[0])
    doc = json.loads(run(capsys, "fit", f, "--json", "--start", "2", "--stop", "20", "--no-whole-cycles")[1])
    assert doc["window"] == [2000, 20000]
    doc = json.loads(run(capsys, "fit", f, "--json", "--lead-in", "3")[1])
    assert doc["window"][0] == 3000
    doc = json.loads(run(capsys, "fit", f, "--json", "--envelope", "0.5")[1])
    assert doc["valid"] and doc["window"][0] < 2000
    doc = json.loads(run(capsys, "fit", f, "--json", "--min-cycles", "30")[1])
    assert [flag["code"] for flag in doc["flags"]] == ["too_few_cycles"]


def test_plots(capsys: pytest.CaptureFixture[str], trials: list[Path], tmp_path: Path) -> None:
    np.save(tmp_path / "noise.npy", np.random.default_rng(0).standard_normal(5000))
    out_dir = tmp_path / "plots" / "nested"
    files = [str(trials[0]), str(trials[0]), str(tmp_path / "noise.npy")]
    code, _, _ = run(capsys, "fit", *files, "--plot", str(out_dir), "--rate", "1000")
    assert code == 0
    pngs = sorted(p.name for p in out_dir.iterdir())
    assert pngs == ["noise.png", "t1.png", "t1_2.png"]
    for name in pngs:
        assert (out_dir / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out_dir / "t1.png").stat().st_size > 20_000


def test_matplotlib_is_not_imported_at_import_time() -> None:
    import subprocess

    code = "import sys, bike_rig.cli.fit_cmd; print('matplotlib' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--lead-in", "2", "--start", "3"], "choose one window: --lead-in or --start/--stop"),
        (["--envelope", "2"], "window: envelope fraction must be in (0, 1)"),
        (["--start", "5", "--stop", "1"], "window: stop (1.0 s) must be after start (5.0 s)"),
        (["--lead-in", "-1"], "lead-in must be >= 0 s"),
        (["--rate", "0"], "--rate must be a positive number"),
        (["--min-r2", "nan"], "--min-r2 must be a non-negative number"),
    ],
)
def test_usage_errors(capsys: pytest.CaptureFixture[str], trials: list[Path], extra: list[str], message: str) -> None:
    code, out, err = run(capsys, "fit", str(trials[0]), *extra)
    assert code == 2 and out == ""
    assert err.startswith("bike-rig fit: error: ") and message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_file_errors_stop_before_any_output(
    capsys: pytest.CaptureFixture[str], trials: list[Path], tmp_path: Path
) -> None:
    (tmp_path / "bad.csv").write_text("time,rate\n0,1\n0.001,oops\n")
    code, out, err = run(capsys, "fit", str(trials[0]), str(tmp_path / "bad.csv"), "--json")
    assert code == 2 and out == ""
    assert err == f"bike-rig fit: error: {tmp_path / 'bad.csv'}:3: non-numeric value 'oops' in column 2\n"
    code, _, err = run(capsys, "fit", str(tmp_path / "missing.npy"))
    assert code == 2 and "missing.npy: no such file" in err
    code, _, err = run(capsys, "fit", str(trials[1]))  # one column of rates and no --rate
    assert code == 2 and "missing sample rate" in err and "--rate" in err
    blocker = tmp_path / "file"
    blocker.write_text("")
    code, _, err = run(capsys, "fit", str(trials[0]), "--plot", str(blocker / "sub"))
    assert code == 2 and "cannot create the plot folder" in err


def test_add_parser_and_run_on_a_bare_parser(capsys: pytest.CaptureFixture[str], trials: list[Path]) -> None:
    assert bare_parser_run(["fit", str(trials[0]), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["valid"] is True
    assert bare_parser_run(["fit", str(trials[0]), "--rate", "-1"]) == 2
    assert capsys.readouterr().err.startswith("bike-rig fit: error: --rate must be a positive number")


# ---------------------------------------------------------------- columns, time units, measurement keys


def _csv(path: Path, header: str, *columns: np.ndarray) -> Path:
    rows = [",".join(repr(float(v)) for v in row) for row in zip(*columns)]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_milliseconds_give_the_period_in_seconds(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    t = gyro_trial(21, period=1.6)
    named = _csv(tmp_path / "named.csv", "time_ms,rate", t.times * 1000.0, t.samples)
    plain = _csv(tmp_path / "plain.csv", "time,rate", t.times * 1000.0, t.samples)
    code, out, err = run(capsys, "fit", str(named), str(plain), "--json")
    assert code == 0
    for line in out.splitlines():
        doc = json.loads(line)
        assert doc["valid"] and abs(doc["period"] - 1.6) < 4 * doc["period_sigma"]  # not 1600 s
    assert err == (
        f"bike-rig fit: note: {plain}: time column 'time' read in ms: its steps of 1 are 1000 Hz in ms but 1 Hz "
        "in s (name the column time_ms or pass --time-unit ms to say so)\n"
    )
    wrong = _csv(tmp_path / "wrong.csv", "time_s,rate", t.times * 1000.0, t.samples)
    code, out, err = run(capsys, "fit", str(wrong))
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "time column 'time_s' says s" in err and "they look like ms" in err
    code, out, _ = run(capsys, "fit", str(wrong), "--time-unit", "ms", "--json")
    assert code == 0 and abs(json.loads(out)["period"] - 1.6) < 1e-3


def test_time_and_signal_options_choose_columns(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    t = gyro_trial(22, period=1.6)
    f = _csv(tmp_path / "three.csv", "time,rate,volts", t.times, t.samples, 2.5 + 0.4 * t.samples)
    code, out, err = run(capsys, "fit", str(f), "--json")
    assert code == 0 and "signal: column 'rate' of time, rate, volts" in err
    by_rate = json.loads(out)
    code, out, err = run(capsys, "fit", str(f), "--json", "--signal", "volts")
    assert code == 0 and err == ""
    by_volts = json.loads(out)
    code, out, _ = run(capsys, "fit", str(f), "--json", "--time", "0", "--signal", "2")
    assert json.loads(out) == by_volts
    assert by_volts["period"] == pytest.approx(by_rate["period"], rel=1e-9)  # volts = a + b rate: the same fit
    code, out, err = run(capsys, "fit", str(f), "--signal", "gyro")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("bike-rig fit: error: ") and "(time, rate, volts): --signal 'gyro': no such column" in err


def _sim_named(tmp_path: Path, names_periods: Sequence[tuple[str, float]]) -> list[str]:
    files = []
    for k, (name, period) in enumerate(names_periods):
        trial = gyro_trial(40 + k, period=period)
        np.save(tmp_path / name, np.column_stack([trial.times, trial.samples]))
        files.append(str(tmp_path / name))
    return files


def test_trials_of_different_measurements_are_not_combined(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    named = _sim_named(
        tmp_path,
        [("frame_torsional_o1_t1.npy", 1.3), ("frame_torsional_o1_t2.npy", 1.3), ("fork_compound_t1.npy", 1.9)],
    )
    code, out, _ = run(capsys, "fit", *named)
    assert code == 0
    found = re.search(r"combined period of TtB1: T = ([0-9.]+) ± ([0-9.]+) s \(2 used", out)
    assert found, out
    assert abs(float(found[1]) - 1.3) < 4 * float(found[2])
    assert "combined period of TcH1: T = " in out and "(1 used" in out
    assert "all trials" not in out
    # Files that name no measurement, of clearly different periods: one line says why not.
    plain = _sim_named(tmp_path, [("a.npy", 1.3), ("b.npy", 1.9)])
    code, out, _ = run(capsys, "fit", *plain)
    assert code == 0 and "combined period" not in out
    why = [line for line in out.splitlines() if line.startswith("not combined")]
    assert len(why) == 1 and "name no measurement" in why[0] and "--key" in why[0]
    # Fisher's rear and front wheel, torsional: the closest two periods of the shipped bicycles (0.097 %).
    close = _sim_named(tmp_path, [("rear.npy", 0.66505229793), ("front.npy", 0.665696467328)])
    code, out, _ = run(capsys, "fit", *close)
    assert "combined period" not in out and re.search(r"range from 0\.665\d* to 0\.6657 s \(0\.09\d %\)", out), out
    # Mixed: the keyed ones by key, the others named.
    code, out, _ = run(capsys, "fit", named[0], plain[0])
    assert "combined period of TtB1" in out and "not combined: a.npy names no measurement key" in out


def test_key_option_combines_files_as_one_measurement(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    plain = _sim_named(tmp_path, [("a.npy", 1.3), ("b.npy", 1.3)])
    code, out, _ = run(capsys, "fit", *plain, "--key", "TtB2")
    assert code == 0 and re.search(r"combined period of TtB2: T = [0-9.]+ ± [0-9.]+ s \(2 used", out), out
    code, out, err = run(capsys, "fit", *plain, "--key", "frame")
    assert code == 2 and out == "" and "--key must be a period key such as TtB1" in err


def test_a_swinging_compound_pendulum_and_the_small_swing_period_option(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from test.support.signals import pendulum_trial

    swing = np.radians(15.0)  # (the rate in rad/s of this swing: its amplitude is the swing's)
    samples, _ = pendulum_trial(
        2, loss_per_cycle=0.03, compound=True, swing=swing, rate_amplitude=swing * 2 * np.pi / 1.6
    )
    path = tmp_path / "fork_compound_t1.npy"
    np.save(path, samples)
    code, out, _ = run(capsys, "fit", str(path), "--json", "--rate", "1000")
    fitted = json.loads(out)
    code2, out2, _ = run(capsys, "fit", str(path), "--json", "--rate", "1000", "--small-swing-period")
    small = json.loads(out2)
    assert code == code2 == 0 and fitted["damping_model"] == "dry" and fitted["swing_kappa"] < 0
    assert small["period"] == small["small_swing_period"] == fitted["small_swing_period"]
    assert fitted["period"] > small["period"] and small["period"] == pytest.approx(1.6, abs=4 * small["period_sigma"])
    # the swing at the window's start (1 s in): below the 15° release, and κ ≈ −θ²/16 of the centre's
    assert np.radians(10.0) < fitted["swing_amplitude"] < np.radians(15.0)
    assert 0.3 * fitted["swing_amplitude"] ** 2 / 16 < -fitted["swing_kappa"] < fitted["swing_amplitude"] ** 2 / 16
    code, table, _ = run(capsys, "fit", str(path), "--rate", "1000")
    assert "dry" in table and "the period follows the swing" in table and "the period along the record" in table
