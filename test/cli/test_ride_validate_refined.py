"""``bike-rig ride validate`` with a refined-method bicycle, a Yeadon rider and the balance assist.

The Rigid bicycle's raw readings (the refined method: split fork, BicycleParameters' shared
data), the rider Jason from his Yeadon measurements, the speed-scheduled balance assist; rides
simulated from that model at three speeds. Every speed and the whole get a verdict in words,
never NaN, exit 0; at a speed where the closed loop's weave pair is being born the model's
linear σ is not defined, and the verdict uses the Monte Carlo σ and says so.
"""

from __future__ import annotations

import json
import math

import pytest

from bike_rig.config.paths import config_dir
from test.support.cli import run
from test.support.paper import shared_dir

BP = shared_dir() / "data" / "bicycleparameters"
RIGID = str(BP / "Rigid" / "RawData" / "RigidMeasured.txt")
JASON = BP / "riders" / "Jason" / "RawData"
ASSIST = str(config_dir() / "feedback" / "balance_assist.yaml")
SPEEDS = ("2", "3", "4.5")
WORDS = ("agrees within", "in tension", "disagrees")


@pytest.fixture(scope="module")
def ride(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, list[str]]:
    """(the rider file, the simulated records)."""
    d = tmp_path_factory.mktemp("refined")
    rider = d / "jason.yaml"
    rider.write_text(
        f"name: Jason\nyeadon_measurements: {JASON / 'JasonYeadonMeas.txt'}\n"
        f"yeadon_configuration: {JASON / 'JasonBrowserYeadonCFG.txt'}\n",
        encoding="utf-8",
    )
    records = []
    for i, v in enumerate(SPEEDS):
        out = d / f"ride_{v}.csv"
        argv = ("ride", "simulate", RIGID, "--rider", str(rider), "--feedback", ASSIST, "--speed", v)
        code = _main(*argv, "--duration", "14", "--seed", str(i), "-o", str(out))
        assert code == 0
        records.append(str(out))
    return str(rider), records


def _main(*argv: str) -> int:
    from bike_rig.cli.main import main

    return main(list(argv))


def test_every_speed_and_the_whole_get_a_verdict_in_words(
    capsys: pytest.CaptureFixture[str], ride: tuple[str, list[str]]
) -> None:
    rider, records = ride
    capsys.readouterr()
    base = ("ride", "validate", RIGID, *records, "--rider", rider, "--feedback", ASSIST)
    code, out, _ = run(capsys, *base)
    assert code == 0 and "nan" not in out.lower()
    speed_lines = [ln for ln in out.splitlines() if " m/s (" in ln and "segment" in ln and "measured" in ln]
    assert len(speed_lines) == len(SPEEDS), out
    assert all(any(w in ln for w in WORDS) for ln in speed_lines), speed_lines
    assert out.splitlines()[-1].startswith("verdict: the model ")
    code, out, _ = run(capsys, *base, "--json")
    assert code == 0 and "NaN" not in out and "Infinity" not in out
    got = json.loads(out)
    assert got["verdict"] in ("agrees", "tension", "disagrees") and got["verdict_text"]
    assert math.isfinite(got["normalised_deviation"])
    for s in got["speeds"]:
        assert s["verdict"] in ("agrees", "tension", "disagrees") and s["verdict_text"]
        assert s["model_sigma_method"] == "linear" and s["predicted_real_sigma"] > 0 < s["predicted_imag_sigma"]


def test_near_the_weave_pairs_birth_the_monte_carlo_sigma_is_used_and_said(
    capsys: pytest.CaptureFixture[str], ride: tuple[str, list[str]]
) -> None:
    """At 0.05 m/s the closed loop's weave pair is being born (real at 0.04, +3.4 ± 0.34i at 0.06 m/s)."""
    rider, records = ride
    capsys.readouterr()
    base = ("ride", "validate", RIGID, records[1], "--rider", rider, "--feedback", ASSIST, "--speed", "0.05")
    code, out, _ = run(capsys, *base)
    assert code == 0 and "nan" not in out.lower()
    assert "(Monte Carlo σ)" in out and "model σ by Monte Carlo: the linear σ is not defined near a branch point" in out
    assert "verdict: the model disagrees with the ride at 1 of 1 speeds (0.05 m/s)" in out
    code, out, _ = run(capsys, *base, "--json")
    assert code == 0 and "NaN" not in out
    (s,) = json.loads(out)["speeds"]
    assert s["model_sigma_method"] == "monte_carlo" and s["predicted_real_sigma"] > 0
    assert s["verdict"] == "disagrees" and "does not oscillate" in s["verdict_text"]
