"""Eigenvalues-versus-speed figure (paper Figs 13/16): the drawn data are the computed data.

Checks that every line, band and marker of :func:`bike_rig.plots.eigen.eigen_vs_speed` equals
:func:`bike_rig.plots.model_data.eigen_curves`, and that those equal the core's independent
answers: the marked weave and capsize speeds are :func:`bike_rig.core.whipple.critical_speeds`,
the bands are ±σ of :func:`bike_rig.core.uncertainty.eigen_sigma.eigenvalues_with_sigma`, and the ends of the
complex capsize–caster interval are double roots of the characteristic polynomial.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

from bike_rig.config.paths import config_dir
from bike_rig.core.errors import BikeRigError
from bike_rig.core.uncertainty.eigen_sigma import eigenvalues_with_sigma
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import characteristic_coefficients, critical_speeds
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.eigen import eigen_vs_speed, panel_grid
from bike_rig.plots.model_data import FigureInputError, eigen_curves, model_parameters
from bike_rig.plots.style import save_figure

SPEEDS = np.linspace(0.0, 10.0, 251)


@pytest.fixture(scope="module")
def browser() -> Subject:
    return load_subject(config_dir() / "bicycles" / "browser.yaml")


def _artist(fig: Figure, gid: str) -> Any:
    found = fig.findobj(lambda a: a.get_gid() == gid)
    assert len(found) == 1, f"{gid}: {len(found)} artists"
    return found[0]


def _span(rect: Any) -> tuple[float, float]:
    """The x range of an ``axvspan`` rectangle."""
    x0 = float(rect.get_x())
    return x0, x0 + float(rect.get_width())


@pytest.mark.parametrize("rider", ["", "paper"])
def test_lines_and_markers_are_the_computed_data(browser: Subject, rider: str) -> None:
    fig = eigen_vs_speed([browser], rider, SPEEDS)
    c = eigen_curves(browser, rider, SPEEDS)
    name = browser.name
    for j in range(4):
        z = c.eigenvalues[:, j]
        re = _artist(fig, f"{name}:re:{j}")
        np.testing.assert_array_equal(re.get_xdata(), SPEEDS)
        np.testing.assert_array_equal(re.get_ydata(), z.real)
        im = np.asarray(_artist(fig, f"{name}:im:{j}").get_ydata(), dtype=float)
        shown = np.isfinite(im)
        np.testing.assert_array_equal(im[shown], z.imag[shown])
        assert np.all(z.imag[shown] > 0.0)
        assert np.all(z.imag[~shown] <= 1e-9 * np.maximum(1.0, np.abs(z[~shown])))
    # The marked critical speeds are the core's, and the spans are ±σ.
    ms = canonical_with_sigma(model_parameters(browser, rider))
    cs = critical_speeds(ms.matrices, ms.g)
    for kind, speed, crit in (("weave", cs.weave, c.weave), ("capsize", cs.capsize, c.capsize)):
        assert speed is not None and crit is not None
        assert list(_artist(fig, f"{name}:{kind}").get_xdata()) == [speed, speed]
        assert crit.speed == pytest.approx(speed, rel=1e-12)
        assert _span(_artist(fig, f"{name}:{kind}-sigma")) == pytest.approx(
            (crit.speed - crit.sigma, crit.speed + crit.sigma), abs=1e-12
        )
        assert 0.0 < crit.sigma < 0.2


def test_bands_are_plus_minus_sigma(browser: Subject) -> None:
    fig = eigen_vs_speed([browser], "", SPEEDS)
    es = eigenvalues_with_sigma(browser.parameters, SPEEDS)
    np.testing.assert_array_equal(es.sweep.eigenvalues, eigen_curves(browser, "", SPEEDS).eigenvalues)
    for j in range(4):
        band = _artist(fig, f"{browser.name}:band:{j}")
        re, sig = es.sweep.eigenvalues[:, j].real, es.sigma_real[:, j]
        covered: set[int] = set()
        for path in band.get_paths():
            for x, y in path.vertices:
                i = int(np.flatnonzero(SPEEDS == x)[0])
                assert np.isfinite(sig[i])
                assert min(abs(y - (re[i] + sig[i])), abs(y - (re[i] - sig[i]))) < 1e-12
                covered.add(i)
        # Every speed with a σ is in the band; the ones without (near branch points) are gaps.
        assert covered == set(np.flatnonzero(np.isfinite(sig)).tolist())
    assert np.isnan(es.sigma_real).any()  # the branch points are left out, not drawn as huge bands


def test_no_bands_when_asked(browser: Subject) -> None:
    fig = eigen_vs_speed([browser], "", SPEEDS, bands=False)
    assert not fig.findobj(lambda a: str(a.get_gid()).startswith(f"{browser.name}:band:"))


def test_complex_pair_interval_ends_are_double_roots(browser: Subject) -> None:
    c = eigen_curves(browser, "", SPEEDS)
    ms = canonical_with_sigma(browser.parameters)
    ((start, stop),) = c.capsize_caster_complex
    for end, inside in ((start, +1.0), (stop, -1.0)):
        # np.roots on either side of the end: one complex pair more inside than outside.
        counts = []
        for v in (end - 1e-6 * inside, end + 1e-6 * inside):
            roots = np.roots(characteristic_coefficients(ms.matrices, ms.g, np.array([v]))[0])
            counts.append(int(np.sum(np.abs(roots.imag) > 1e-7)))
        assert counts[1] == counts[0] + 2
    assert _span(_artist(eigen_vs_speed([browser], "", SPEEDS), f"{browser.name}:pair:0")) == pytest.approx(
        (start, stop), abs=1e-12
    )


def test_six_bicycles_one_panel_each() -> None:
    names = ["browser", "browserins", "crescendo", "fisher", "stratos", "yellow"]
    subjects = [load_subject(config_dir() / "bicycles" / f"{n}.yaml") for n in names]
    fig = eigen_vs_speed(subjects, "paper", SPEEDS[::5])
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in visible] == [s.name for s in subjects]
    assert panel_grid(6) == (2, 3) and panel_grid(1) == (1, 1) and panel_grid(4) == (2, 3)
    assert not fig.findobj(lambda a: ":pair:" in str(a.get_gid()))  # no complex pair with the rider


def test_figure_writes_png_and_svg(browser: Subject, tmp_path: Any) -> None:
    written = save_figure(eigen_vs_speed([browser], "", SPEEDS[::5]), tmp_path / "eigen")
    assert [p.suffix for p in written] == [".png", ".svg"]
    assert all(p.stat().st_size > 1000 for p in written)


def test_bad_requests_are_user_errors(browser: Subject) -> None:
    with pytest.raises(FigureInputError, match="at least one bicycle"):
        eigen_vs_speed([])
    with pytest.raises(FigureInputError, match="speeds"):
        eigen_vs_speed([browser], "", np.array([-1.0, 2.0]))
    with pytest.raises(FigureInputError, match="speeds"):
        eigen_vs_speed([browser], "", np.array([1.0]))
    with pytest.raises(BikeRigError, match="unknown rider"):
        eigen_vs_speed([browser], "giant")
    with pytest.raises(FigureInputError, match="unknown mode 'wobble'"):
        eigen_curves(browser, "", SPEEDS).mode("wobble")
