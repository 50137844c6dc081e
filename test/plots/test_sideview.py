"""Side view: wheels, steer axis and mass centres where the benchmark geometry puts them.

z is down, drawn up; the ellipses equal the covariance's eigen-decomposition times the
magnification the legend states.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Ellipse

from bike_rig.config.paths import config_file
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.sideview import (
    ELLIPSE_SIGMA,
    _centres,
    ellipse_axes,
    ellipse_magnification,
    mass_centres,
    side_view,
)
from bike_rig.plots.style import bicycle_colour


@pytest.fixture(scope="module")
def browser() -> Subject:
    return load_subject(config_file("bicycles/browser.yaml"))


@pytest.fixture(scope="module")
def yellow() -> Subject:
    return load_subject(config_file("bicycles/yellow.yaml"))


def artist(fig: Figure, gid: str) -> object:
    found = fig.findobj(lambda a: a.get_gid() == gid)
    assert len(found) == 1, f"{len(found)} artists with gid {gid!r}"
    return found[0]


def stated_magnification(fig: Figure) -> float:
    """The factor the legend says the ellipses are drawn with."""
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    hits = [m for t in texts if (m := re.search(r"(\d+(?:\.\d+)?)σ ellipses, drawn ×(\d+)", t))]
    assert len(hits) == 1, texts
    assert float(hits[0].group(1)) == ELLIPSE_SIGMA
    return float(hits[0].group(2))


def test_frame_and_fork_covariance_is_the_parameter_block_with_z_flipped(browser: Subject) -> None:
    pv = browser.parameters.parameters
    centres = {c.key: c for c in mass_centres(browser.parameters)}
    for part in "BH":
        i, j = pv.index(f"x{part}"), pv.index(f"z{part}")
        block = pv.covariance[np.ix_([i, j], [i, j])]
        want = block * np.array([[1.0, -1.0], [-1.0, 1.0]])  # y = -z
        np.testing.assert_allclose(centres[part].covariance, want, rtol=1e-10, atol=1e-18)
        assert centres[part].x == pv.value(f"x{part}")
        assert centres[part].y == -pv.value(f"z{part}")
        assert block[0, 1] != 0.0  # the hanging lines correlate x and z: the flip matters
    assert centres["R"].y == pv.value("rR") and centres["F"].x == pv.value("w")


def test_whole_bicycle_centre_and_its_covariance_by_central_differences(browser: Subject) -> None:
    pv = browser.parameters.parameters
    values = pv.as_dict()
    total = next(c for c in mass_centres(browser.parameters) if c.key == "T")
    m = sum(values[k] for k in ("mR", "mB", "mH", "mF"))
    x = (values["mB"] * values["xB"] + values["mH"] * values["xH"] + values["mF"] * values["w"]) / m
    z = (
        values["mB"] * values["zB"]
        + values["mH"] * values["zH"]
        - values["mR"] * values["rR"]
        - values["mF"] * values["rF"]
    ) / m
    assert (total.x, total.y) == pytest.approx((x, -z), rel=1e-12)
    jac = np.zeros((2, len(pv.names)))
    for k, name in enumerate(pv.names):
        h = 1e-6 * max(1.0, abs(values[name]))
        up, down = dict(values), dict(values)
        up[name] += h
        down[name] -= h
        a, b = _centres(up), _centres(down)
        jac[:, k] = [(a["T_x"] - b["T_x"]) / (2 * h), (a["T_y"] - b["T_y"]) / (2 * h)]
    np.testing.assert_allclose(total.covariance, jac @ pv.covariance @ jac.T, rtol=1e-6)


def test_ellipses_are_the_eigen_decomposition_times_the_stated_magnification(browser: Subject, yellow: Subject) -> None:
    fig = side_view([browser, yellow])
    mag = stated_magnification(fig)
    largest = 0.0
    for i, subject in enumerate((browser, yellow)):
        for c in mass_centres(subject.parameters):
            e = artist(fig, f"ellipse:{i}:{c.key}")
            assert isinstance(e, Ellipse)
            vals, vecs = np.linalg.eigh(c.covariance)
            assert e.width == pytest.approx(2 * ELLIPSE_SIGMA * math.sqrt(vals[1]) * mag, rel=1e-9)
            assert e.height == pytest.approx(
                2 * ELLIPSE_SIGMA * math.sqrt(max(vals[0], 0.0)) * mag, rel=1e-9, abs=1e-12
            )
            if vals[1] > 1.5 * vals[0]:  # a defined major axis: its direction
                angle = math.radians(e.angle)
                assert abs(np.dot([math.cos(angle), math.sin(angle)], vecs[:, 1])) == pytest.approx(1.0, abs=1e-9)
            assert e.center == pytest.approx((c.x, c.y))
            largest = max(largest, math.sqrt(vals[1]))
    # mm on a metre bicycle: magnified to be seen, by a round factor, and not past ~6 cm
    assert 0.002 < largest < 0.02
    assert mag in (1, 2, 5, 10, 20, 50, 100) and 0.012 < largest * mag <= 0.06
    assert f"{largest * 1e3:.1f} mm" in " ".join(t.get_text() for t in fig.legends[0].get_texts())


def test_wheels_steer_axis_and_colours(browser: Subject, yellow: Subject) -> None:
    fig = side_view([browser, yellow])
    for i, subject in enumerate((browser, yellow)):
        v = subject.parameters.values()
        rear, front = artist(fig, f"wheel:{i}:R"), artist(fig, f"wheel:{i}:F")
        assert isinstance(rear, Circle) and isinstance(front, Circle)
        assert rear.radius == v["rR"] and rear.center == (0.0, v["rR"])
        assert front.radius == v["rF"] and front.center == (v["w"], v["rF"])
        axis = artist(fig, f"steer:{i}")
        assert isinstance(axis, Line2D)
        (x0, x1), (y0, y1) = axis.get_xdata(), axis.get_ydata()
        assert (x0, y0) == (pytest.approx(v["w"] + v["c"]), 0.0)  # meets the ground a trail ahead
        assert math.atan2(x0 - x1, y1 - y0) == pytest.approx(v["lam"])  # tilted back by λ
        assert axis.get_color() == bicycle_colour(i)
        marker = artist(fig, f"centre:{i}:B")
        assert isinstance(marker, Line2D) and marker.get_color() == bicycle_colour(i)
    assert bicycle_colour(0) != bicycle_colour(1)


def test_parameter_file_without_covariance_draws_no_magnified_ellipses() -> None:
    bench = load_subject(config_file("bicycles/benchmark.yaml"))
    fig = side_view([bench])
    assert stated_magnification(fig) == 1.0
    e = artist(fig, "ellipse:0:B")
    assert isinstance(e, Ellipse) and e.width == 0.0


def test_magnification_steps() -> None:
    assert ellipse_magnification(0.0068) == 5.0
    assert ellipse_magnification(0.004) == 10.0
    assert ellipse_magnification(0.1) == 1.0
    assert ellipse_magnification(0.0) == 1.0
    assert ellipse_magnification(float("nan")) == 1.0


def test_ellipse_axes_of_a_rotated_covariance() -> None:
    rot = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    cov = rot @ np.diag([9.0, 1.0]) @ rot.T
    a, b, angle = ellipse_axes(cov, n_sigma=2.0)
    assert (a, b) == pytest.approx((6.0, 2.0))
    assert math.radians(angle) % math.pi == pytest.approx(0.5)
