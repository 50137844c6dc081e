"""The report's ride section: measured segments against the bicycle with the rider (and feedback)."""

from __future__ import annotations

import math
import re

import numpy as np

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.rider import PAPER_RIDER
from bike_rig.core.sim.ride import RideSimulation, regular_kicks, simulate_ride
from bike_rig.report.results import compute_variant
from bike_rig.report.ride import compute_ride, ride_section


def test_ride_section_tables_the_segments_per_speed_and_embeds_the_figure() -> None:
    ps = _parameters(str(config_file("bicycles/browser.yaml")), "centroid")
    variant = compute_variant(ps, PAPER_RIDER)
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None
    segments = []
    ms = variant.matrices
    for v in (3.0, 4.5):
        ride = simulate_ride(ms.matrices, ms.g, RideSimulation(v, 13.0, kicks=regular_kicks(13.0, 6.0)), fb.gains(v))
        for k in ride.kicks:
            inside = (ride.times >= k.time + 0.3) & (ride.times <= k.time + 2.3)
            segments.append(fit_segment(ride.times[inside], ride.roll_rate[inside], speed=v, source=f"{v}"))
    rides = compute_ride(variant, segments, fb)
    html = ride_section(rides, dpi=40)
    assert 'id="ride"' in html and 'id="table-ride"' in html and "data:image/png;base64," in html
    speeds = [s.combined.speed for s in rides.comparison.speeds]
    assert np.allclose(speeds, [3.0, 4.5])
    assert len(re.findall(r"<tr>", html)) >= 3  # the header and one row per speed
    assert math.isfinite(rides.comparison.overall) and rides.comparison.overall < 3.0
    assert "the closed loop with feedback" in html and "balance assist" in html


def test_report_with_rides_and_feedback_adds_the_calibration_section() -> None:
    from bike_rig.offline.subjects import load_subject
    from bike_rig.report.build import _calibration

    subject = load_subject("browser")
    fb = resolve_feedback("balance_assist")
    assert fb is not None
    ms = compute_variant(subject.parameters, PAPER_RIDER).matrices
    segments = []
    for v in (3.0, 4.5, 6.0):
        ride = simulate_ride(ms.matrices, ms.g, RideSimulation(v, 13.0, kicks=regular_kicks(13.0, 6.0)), fb.gains(v))
        for k in ride.kicks:
            inside = (ride.times >= k.time + 0.3) & (ride.times <= k.time + 2.3)
            segments.append(fit_segment(ride.times[inside], ride.roll_rate[inside], speed=v, source=f"{v}"))
    html = _calibration(subject, segments, "paper", fb, dpi=40)
    assert 'id="ride-calibration"' in html and 'id="table-ride-calibration"' in html
    assert "data:image/png;base64," in html and "not computed" not in html
    one = _calibration(subject, segments[:1], "paper", fb, dpi=40)  # one segment: a section or a note, no crash
    assert 'id="ride-calibration"' in one
