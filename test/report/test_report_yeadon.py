"""The report's rider variant from a rider file (a Yeadon rider): numbers, Monte Carlo, figures, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import main
from bike_rig.core.rider import RiderError, add_rider, resolve_rider
from bike_rig.core.rider_yeadon import YeadonRider
from bike_rig.core.uncertainty.speed_mc import speed_monte_carlo
from bike_rig.offline.subjects import load_subject
from bike_rig.report import sections
from bike_rig.report.build import report_rider
from bike_rig.report.figures import figure_specs
from bike_rig.report.results import compute_results
from test.support.paper import shared_dir

BP = shared_dir() / "data" / "bicycleparameters"
BROWSER = str(BP / "Browser" / "RawData" / "BrowserMeasured.txt")
JASON = BP / "riders" / "Jason" / "RawData"


def _rider(tmp_path: Path) -> str:
    path = tmp_path / "jason.yaml"
    path.write_text(
        f"name: Jason\nyeadon_measurements: {JASON / 'JasonYeadonMeas.txt'}\n"
        f"yeadon_configuration: {JASON / 'JasonBrowserYeadonCFG.txt'}\n",
        encoding="utf-8",
    )
    return str(path)


def test_rider_variant_numbers_monte_carlo_and_figures(tmp_path: Path) -> None:
    subject = load_subject(BROWSER)
    spec = _rider(tmp_path)
    chosen = resolve_rider(spec)
    assert isinstance(chosen, YeadonRider)
    rider = report_rider(spec, subject)
    assert rider.sensitivity is not None and rider.mass == pytest.approx(83.5)
    results = compute_results(subject, rider)
    want = add_rider(subject.parameters, chosen)
    assert np.array_equal(results.rider.parameters.parameters.values, want.parameters.values)
    assert np.allclose(results.rider.parameters.parameters.covariance, want.parameters.covariance, rtol=1e-12, atol=0)
    assert results.rider.label == "with Jason"
    # the Monte Carlo draws the rider too: its σ agree with the linear σ that include the rider's
    mc = results.monte_carlo[1]
    for speed in (mc.weave, mc.capsize):
        assert speed.linear_sigma is not None and speed.std / speed.linear_sigma == pytest.approx(1.0, abs=0.05)
    # the figures with a rider are drawn with this rider, the others without
    riders = {s.draw.keywords.get("rider") for s in figure_specs(subject, results, spec)}  # type: ignore[attr-defined]
    assert spec in riders and "paper" not in riders
    note = sections.speeds_section(results)
    assert "own inputs (body measurements) are drawn too" in str(note)


def test_monte_carlo_sees_the_rider_sigma(tmp_path: Path) -> None:
    """Without drawing the rider, the Monte Carlo σ would stay at the bicycle's: they differ measurably."""
    subject = load_subject(BROWSER)
    assert subject.measurements is not None
    rider = report_rider(_rider(tmp_path), subject)
    exact = type(rider)(rider.mass, rider.x, rider.z, rider.Ixx, rider.Iyy, rider.Izz, rider.Ixz, rider.name)
    drawn = speed_monte_carlo(subject.measurements, 20000, 3, rider=rider)
    fixed = speed_monte_carlo(subject.measurements, 20000, 3, rider=exact)
    assert drawn.capsize.std / drawn.capsize.linear_sigma == pytest.approx(1.0, abs=0.03)
    assert fixed.capsize.std / fixed.capsize.linear_sigma == pytest.approx(1.0, abs=0.03)
    assert drawn.capsize.linear_sigma > fixed.capsize.linear_sigma * 1.01
    assert drawn.capsize.std > fixed.capsize.std * 1.01  # the same bicycle draws (seed), plus the rider's


def test_report_needs_a_rider(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(RiderError, match="without and with a rider"):
        report_rider("none", load_subject(BROWSER))
    bad = tmp_path / "bad.yaml"
    bad.write_text("yeadon_measurements: nowhere.txt\nyeadon_configuration: nowhere.txt\n", encoding="utf-8")
    assert main(["report", BROWSER, "-o", str(tmp_path / "out"), "--rider", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nowhere.txt" in err[0]
    assert not (tmp_path / "out" / "index.html").exists()
