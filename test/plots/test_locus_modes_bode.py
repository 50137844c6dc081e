"""Root locus (Fig 14), eigenvector phasors (Fig 15) and Bode diagram (Figs 17/18).

The drawn data equal the computed records of :mod:`bike_rig.plots.model_data`, and those are
checked against independent computations: the eigenvector against ``A x = λ x`` of the
state-space matrix, the frequency response against ``C (iω I − A)⁻¹ B``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

from bike_rig.config.paths import config_dir
from bike_rig.core.errors import BikeRigError
from bike_rig.core.frequency import frequency_response
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.bode import bode_figure
from bike_rig.plots.locus import root_locus
from bike_rig.plots.model_data import (
    FigureInputError,
    bode_curves,
    eigen_curves,
    mode_shape,
    model_parameters,
)
from bike_rig.plots.modes import eigenvector_figure, phasor_lengths

SPEEDS = np.linspace(0.0, 10.0, 201)


@pytest.fixture(scope="module")
def bikes() -> list[Subject]:
    return [load_subject(config_dir() / "bicycles" / f"{n}.yaml") for n in ("crescendo", "yellow")]


def _artist(fig: Figure, gid: str) -> Any:
    found = fig.findobj(lambda a: a.get_gid() == gid)
    assert len(found) == 1, f"{gid}: {len(found)} artists"
    return found[0]


# --------------------------------------------------------------------------------------------
# Root locus
# --------------------------------------------------------------------------------------------


def test_root_locus_points_are_the_eigenvalues(bikes: list[Subject]) -> None:
    fig = root_locus(bikes, "", SPEEDS)
    for subject in bikes:
        c = eigen_curves(subject, "", SPEEDS)
        for j in range(4):
            sc = _artist(fig, f"{subject.name}:locus:{j}")
            z = c.eigenvalues[:, j]
            np.testing.assert_array_equal(sc.get_offsets(), np.column_stack([z.real, z.imag]))
            np.testing.assert_array_equal(sc.get_array(), SPEEDS)
            ticks = _artist(fig, f"{subject.name}:ticks:{j}")
            np.testing.assert_array_equal(ticks.get_xdata(), z.real[::20])  # every 1 m/s
            np.testing.assert_array_equal(ticks.get_ydata(), z.imag[::20])


def test_root_locus_with_rider_and_errors(bikes: list[Subject]) -> None:
    fig = root_locus(bikes[:1], "paper", SPEEDS)
    c = eigen_curves(bikes[0], "paper", SPEEDS)
    np.testing.assert_array_equal(
        _artist(fig, f"{bikes[0].name}:locus:2").get_offsets()[:, 0], c.eigenvalues[:, 2].real
    )
    with pytest.raises(FigureInputError):
        root_locus([])
    with pytest.raises(BikeRigError, match="unknown rider"):
        root_locus(bikes, "ghost")


# --------------------------------------------------------------------------------------------
# Eigenvector phasors
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("mode", "speed", "rider"), [("capsize", 1.0, ""), ("weave", 5.0, ""), ("caster", 3.0, "paper")]
)
def test_mode_shape_is_an_eigenvector(bikes: list[Subject], mode: str, speed: float, rider: str) -> None:
    for subject in bikes:
        sh = mode_shape(subject, mode, speed, rider)
        ms = canonical_with_sigma(model_parameters(subject, rider))
        a, _ = state_space(ms.matrices, speed, ms.g)
        x = sh.components
        np.testing.assert_allclose(a @ x, sh.eigenvalue * x, atol=1e-10)
        assert x[sh.reference] == 1.0  # the larger angle is 1 at 0°
        assert abs(x[1 - sh.reference]) <= 1.0
        assert sh.eigenvalue.imag >= 0.0
        # Same eigenvalue as the eigenvalue figure's column of that mode at that speed.
        c = eigen_curves(subject, rider, SPEEDS)
        row = int(np.flatnonzero(SPEEDS == speed)[0])
        col = c.mode(mode)[row]
        assert min(abs(col - sh.eigenvalue)) < 1e-9 or min(abs(col.conj() - sh.eigenvalue)) < 1e-9


def test_capsize_caster_pair_is_oscillatory_below_2_m_s_without_rider(bikes: list[Subject]) -> None:
    for subject in bikes:
        assert mode_shape(subject, "capsize", 1.0).oscillatory
        assert mode_shape(subject, "caster", 1.0).eigenvalue == mode_shape(subject, "capsize", 1.0).eigenvalue
        assert not mode_shape(subject, "capsize", 1.0, "paper").oscillatory


def test_phasors_drawn_are_the_mode_shape(bikes: list[Subject]) -> None:
    fig = eigenvector_figure(bikes, "capsize", 1.0)
    for subject in bikes:
        sh = mode_shape(subject, "capsize", 1.0)
        lengths = phasor_lengths(sh)
        np.testing.assert_allclose(lengths[2:], lengths[:2], rtol=1e-12)  # |rate| = |λ| |angle|
        for i in range(4):
            line = _artist(fig, f"{subject.name}:phasor:{i}")
            assert list(line.get_xdata()) == [0.0, np.angle(sh.components[i])]
            assert list(line.get_ydata()) == [0.0, lengths[i]]


def test_mode_errors(bikes: list[Subject]) -> None:
    with pytest.raises(FigureInputError, match="unknown mode 'wobble'.*weave, capsize, caster"):
        eigenvector_figure(bikes, "wobble")
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(FigureInputError, match="speed"):
            eigenvector_figure(bikes, "weave", bad)
    with pytest.raises(FigureInputError):
        eigenvector_figure([])


# --------------------------------------------------------------------------------------------
# Bode
# --------------------------------------------------------------------------------------------


def _state_space_response(subject: Subject, speed: float, w: float, col: int, row: int, rider: str) -> complex:
    """``[C (iω I − A)⁻¹ B]_{row, col}`` with ``C = I`` (states φ, δ, φ̇, δ̇): an independent path."""
    ms = canonical_with_sigma(model_parameters(subject, rider))
    a, b = state_space(ms.matrices, speed, ms.g)
    return complex(np.linalg.solve(1j * w * np.eye(4) - a, b)[row, col])


@pytest.mark.parametrize(
    ("inp", "out", "col", "row"),
    [("steer torque", "roll angle", 1, 0), ("roll torque", "steer rate", 0, 3), ("steer torque", "steer angle", 1, 1)],
)
def test_bode_magnitude_and_phase(bikes: list[Subject], inp: str, out: str, col: int, row: int) -> None:
    omega = np.logspace(-1, 2, 61)
    fig = bode_figure(bikes, 2.0, "", inp, out, omega)
    for subject in bikes:
        c = bode_curves(subject, 2.0, "", inp, out, omega)
        mag = _artist(fig, f"{subject.name}:magnitude")
        phase = _artist(fig, f"{subject.name}:phase")
        np.testing.assert_array_equal(mag.get_xdata(), omega)
        np.testing.assert_array_equal(mag.get_ydata(), c.magnitude_db)
        np.testing.assert_array_equal(phase.get_ydata(), c.phase_deg)
        k = 30  # ω = 10**0.5 rad/s
        ms = canonical_with_sigma(subject.parameters)
        g = frequency_response(ms.matrices, ms.g, 2.0, omega[k], inp, out)
        assert mag.get_ydata()[k] == pytest.approx(20.0 * np.log10(abs(g)), abs=1e-12)
        ref = _state_space_response(subject, 2.0, float(omega[k]), col, row, "")
        assert abs(g - ref) < 1e-12 * abs(ref)
        assert np.exp(1j * np.radians(c.phase_deg[k])) == pytest.approx(ref / abs(ref), abs=1e-9)


def test_bode_with_rider(bikes: list[Subject]) -> None:
    c = bode_curves(bikes[1], 4.0, "paper", omega=np.array([2.0]))
    ref = _state_space_response(bikes[1], 4.0, 2.0, 1, 0, "paper")
    assert c.response[0] == pytest.approx(ref, rel=1e-12)
    fig = bode_figure(bikes, 4.0, "paper")
    assert "with the paper's rider" in fig.get_suptitle()


def test_bode_errors(bikes: list[Subject]) -> None:
    with pytest.raises(FigureInputError, match="unknown input 'pedal force'"):
        bode_figure(bikes, input="pedal force")
    with pytest.raises(FigureInputError, match="unknown output 'yaw angle'"):
        bode_figure(bikes, output="yaw angle")
    with pytest.raises(FigureInputError, match="frequencies"):
        bode_figure(bikes, omega=np.array([0.0, 1.0]))
    with pytest.raises(FigureInputError, match="speed"):
        bode_figure(bikes, speed=-2.0)
    with pytest.raises(FigureInputError):
        bode_figure([])
