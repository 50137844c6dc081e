"""``bike-rig ride`` with a feedback file that states its controller's rate (``rate_hz``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import cont2discrete

from bike_rig.cli.main import _parameters
from bike_rig.core.feedback import load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from test.support.cli import run
from test.support.rides import ASSIST, BROWSER, simulate_ride


@pytest.fixture(scope="module")
def ride_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_ride(tmp_path_factory.mktemp("ride") / "ride.csv", 4.0, 14, seed=5)


def _assist_at(tmp_path: Path, rate: str) -> Path:
    """The shipped balance assist with ``rate_hz: rate`` added."""
    path = tmp_path / f"assist_{rate}.yaml"
    path.write_text(Path(ASSIST).read_text() + f"rate_hz: {rate}\n")
    return path


def _shift(v: float, rate: float) -> complex:
    """The sampled-minus-continuous weave of the Browser with the paper's rider at ``v`` [m/s] (cont2discrete)."""
    ms = canonical_with_sigma(add_rider(_parameters(BROWSER, "centroid"), PAPER_RIDER))
    k = load_feedback(ASSIST).gains(v)
    a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, v, ms.g))
    cont = np.linalg.eigvals(a - np.outer(b[:, 1], k))
    ad, bd, *_ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), 1.0 / rate, method="zoh")
    samp = np.log(np.linalg.eigvals(ad - np.outer(bd[:, 1], k)).astype(complex)) * rate
    c = cont[np.argmax(cont.imag)]
    return complex(samp[np.argmin(np.abs(samp - c))] - c)


def test_validate_with_a_rate_shifts_the_model_to_the_sampled_loop(
    capsys: pytest.CaptureFixture[str], ride_csv: Path, tmp_path: Path
) -> None:
    base = ("ride", "validate", BROWSER, str(ride_csv), "--rider", "paper")
    code, out, _ = run(capsys, *base, "--feedback", ASSIST, "--json")
    assert code == 0
    cont = json.loads(out)
    code, out, _ = run(capsys, *base, "--feedback", str(_assist_at(tmp_path, "100")), "--json")
    assert code == 0
    samp = json.loads(out)
    assert len(samp["segments"]) == len(cont["segments"]) >= 2
    for c, s in zip(cont["segments"], samp["segments"], strict=True):
        shift = _shift(s["speed"], 100.0)
        assert abs(shift) > 1e-3  # the hold moves the weave
        assert s["predicted_real"] - c["predicted_real"] == pytest.approx(shift.real, rel=1e-6)
        assert s["predicted_imag"] - c["predicted_imag"] == pytest.approx(shift.imag, rel=1e-6)
        assert s["predicted_real_sigma"] == c["predicted_real_sigma"]
        assert s["predicted_imag_sigma"] == c["predicted_imag_sigma"]
    code, out, _ = run(capsys, *base, "--feedback", str(_assist_at(tmp_path, "100")))
    assert code == 0 and "note: the assist samples the state at 100 Hz" in out


def test_validate_refuses_a_controller_too_slow_for_the_weave(
    capsys: pytest.CaptureFixture[str], ride_csv: Path, tmp_path: Path
) -> None:
    argv = ("ride", "validate", BROWSER, str(ride_csv), "--rider", "paper", "--feedback")
    code, _, err = run(capsys, *argv, str(_assist_at(tmp_path, "2")))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "too slow for the mode" in err
    code, _, err = run(capsys, *argv, str(_assist_at(tmp_path, "-100")))
    assert code == 2 and "key 'rate_hz': the controller's rate is a finite number > 0 Hz" in err


def test_the_raw_log_simulator_runs_the_assist_at_the_files_rate(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    argv = ["ride", "simulate", BROWSER, "--rider", "paper", "--speed", "4", "--duration", "12", "--raw-log", "0"]
    logs = {}
    for rate in ("", "100", "50"):
        fb = ASSIST if not rate else str(_assist_at(tmp_path, rate))
        out = tmp_path / f"log{rate}.csv"
        code, _, err = run(capsys, *argv, "--feedback", fb, "-o", str(out))
        assert code == 0, err
        logs[rate] = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    np.testing.assert_array_equal(logs[""], logs["100"])  # the log's own rate, as without rate_hz
    assert np.max(np.abs(logs["50"] - logs["100"])) > 1e-3
    code, _, err = run(capsys, *argv, "--feedback", str(_assist_at(tmp_path, "314.159")), "-o", str(tmp_path / "x.csv"))
    assert code == 2 and "simple ratio" in err and len(err.strip().splitlines()) == 1


def test_calibrate_takes_the_files_rate_unless_told_otherwise(
    capsys: pytest.CaptureFixture[str], ride_csv: Path, tmp_path: Path
) -> None:
    argv = ("ride", "calibrate", BROWSER, str(ride_csv), "--rider", "paper", "--json", "--feedback")
    fb = str(_assist_at(tmp_path, "100"))
    code, out, err = run(capsys, *argv, fb)
    assert code == 0, err
    assert json.loads(out)["assist_rate_hz"] == 100.0
    code, out, err = run(capsys, *argv, fb, "--assist-rate", "50")
    assert code == 0, err
    assert json.loads(out)["assist_rate_hz"] == 50.0
    code, out, err = run(capsys, *argv, ASSIST)
    assert code == 0, err
    assert json.loads(out)["assist_rate_hz"] is None
