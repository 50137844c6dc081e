"""``bike-rig ride calibrate``: simulated rides of the Browser with the paper's rider and the assist, end to end.

The rides come from the very bicycle, rider and controller given, so the rider-aboard variants
must explain them and the gain scale come out at 1 within its σ; the open-loop calibration of
the same rides must say that no variant explains them. Also: JSON, the figure, the report
section, and a user's mistake (an unknown ``--free`` name) refused with exit 2.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from test.support.cli import run
from test.support.rides import ASSIST, BROWSER, simulate_ride


@pytest.fixture(scope="module")
def rides(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    out = tmp_path_factory.mktemp("calibrate")
    return [str(simulate_ride(out / f"ride_{k}.csv", v, 14, seed=k)) for k, v in enumerate((2.5, 3.5, 4.5))]


def test_calibrate_finds_the_rider_aboard_at_the_nominal_gains(
    capsys: pytest.CaptureFixture[str], rides: list[str], tmp_path: Path
) -> None:
    code, out, _ = run(
        capsys,
        "ride",
        "calibrate",
        BROWSER,
        *rides,
        "--rider",
        "paper",
        "--feedback",
        ASSIST,
        "--json",
        "-o",
        str(tmp_path / "figs"),
    )
    assert code == 0
    got = json.loads(out)
    assert {"data", "variants", "best", "verdict", "explained", "prior_band", "posterior_band"} <= set(got)
    assert len(got["data"]["speeds"]) == 3 and len(got["variants"]) == 4
    best = got["variants"][0]
    assert best["rider"] and got["explained"]
    scaled = next(v for v in got["variants"] if v["rider"] and v["gain_scale_free"])
    assert abs(scaled["gain_scale"] - 1.0) <= 3 * scaled["gain_scale_sigma"]
    for c in scaled["gain_scale_confounders"]:  # the priors the gain scale leans on: at least 0.3 of its σ each
        assert c["parameter"] in best["parameters"] and abs(c["shift_in_gain_scale_sigma"]) >= 0.3
        assert c["shift_per_prior_sigma"] == pytest.approx(c["shift_in_gain_scale_sigma"] * scaled["gain_scale_sigma"])
    assert all(v["gain_scale_confounders"] == [] for v in got["variants"] if not v["gain_scale_free"])
    assert all(not v["rider"] for v in got["variants"][2:])  # both no-rider variants rank last
    assert set(best["parameters"]) >= {"IBzz", "lam", "c"} and len(best["covariance"]) == 26
    assert "with the rider aboard" in got["verdict"]
    assert (tmp_path / "figs" / "ride_calibration.png").stat().st_size > 0


def test_open_loop_calibration_says_no_variant_explains_the_rides(
    capsys: pytest.CaptureFixture[str], rides: list[str]
) -> None:
    code, out, _ = run(capsys, "ride", "calibrate", BROWSER, *rides, "--rider", "paper")
    assert code == 0  # it ran; the verdict is the answer
    assert "verdict: no variant explains the rides" in out
    assert "nan" not in out.lower()


def test_an_unknown_free_parameter_is_a_users_mistake(capsys: pytest.CaptureFixture[str], rides: list[str]) -> None:
    code, _, err = run(capsys, "ride", "calibrate", BROWSER, rides[0], "--free", "IBzz,Ixyz")
    assert code == 2 and "--free Ixyz: not a benchmark parameter" in err


def test_report_section_tables_the_variants(rides: list[str]) -> None:
    from bike_rig.cli.main import _parameters
    from bike_rig.core.feedback import resolve_feedback
    from bike_rig.core.rider import PAPER_RIDER
    from bike_rig.offline.rides import RecordOptions, measure_records
    from bike_rig.pipeline.ride_calibrate import calibrate_rides
    from bike_rig.report.ride import calibration_section

    segments = [m.eigenvalue for m in measure_records(rides, RecordOptions())]
    result = calibrate_rides(_parameters(BROWSER, "centroid"), segments, PAPER_RIDER, resolve_feedback(ASSIST))
    html = str(calibration_section(result, dpi=40))
    assert 'id="ride-calibration"' in html and "data:image/png;base64," in html
    assert html.count("<tr") >= 5 and "rider aboard" in html
