"""The frequency response against scipy's state-space frequency response."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import signal

from bike_rig.config.paths import config_file
from bike_rig.core.errors import ModelError
from bike_rig.core.frequency import INPUTS, OUTPUTS, bode, frequency_response
from bike_rig.core.uncertainty.matrix_sigma import MatrixSet, canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.offline.subjects import load_subject


@pytest.fixture(scope="module")
def benchmark() -> MatrixSet:
    return canonical_with_sigma(load_subject(config_file("bicycles/benchmark.yaml")).parameters)


@pytest.mark.parametrize("speed", [0.0, 2.0, 4.6, 8.0])
def test_every_pair_equals_scipy_freqresp(benchmark: MatrixSet, speed: float) -> None:
    w = np.logspace(-1, 2, 60)
    a, b = state_space(benchmark.matrices, speed, benchmark.g)
    for i, inp in enumerate(INPUTS):
        for o, out in enumerate(OUTPUTS):
            c = np.zeros((1, 4))
            c[0, o] = 1.0
            sys = signal.StateSpace(np.asarray(a, float), np.asarray(b, float)[:, [i]], c, np.zeros((1, 1)))
            _, h = _freqresp(sys, w)
            got = frequency_response(benchmark.matrices, benchmark.g, speed, w, inp, out)
            assert np.max(np.abs(got - h) / np.abs(h)) < 1e-9, (inp, out)


def _freqresp(sys: signal.StateSpace, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # scipy goes through a transfer function whose coefficients it finds badly conditioned
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)
        return signal.freqresp(sys, w)


def test_static_gain_is_the_stiffness_inverse(benchmark: MatrixSet) -> None:
    v = 3.0
    k = benchmark.g * np.asarray(benchmark.matrices.K0) + v**2 * np.asarray(benchmark.matrices.K2)
    g0 = np.linalg.inv(k)
    for i, inp in enumerate(INPUTS):
        for o, out in enumerate(OUTPUTS[:2]):
            assert frequency_response(benchmark.matrices, benchmark.g, v, 0.0, inp, out) == pytest.approx(g0[o, i])
        assert frequency_response(benchmark.matrices, benchmark.g, v, 0.0, inp, "roll rate") == 0


def test_bode_magnitude_and_phase(benchmark: MatrixSet) -> None:
    w = np.logspace(-1, 2, 200)
    bd = bode(benchmark.matrices, benchmark.g, 2.0, w)
    resp = frequency_response(benchmark.matrices, benchmark.g, 2.0, w)
    assert np.allclose(bd.magnitude_db, 20 * np.log10(np.abs(resp)))
    wrapped = np.angle(np.exp(1j * np.radians(bd.phase_deg)))
    assert np.allclose(wrapped, np.angle(resp))
    assert np.all(np.abs(np.diff(bd.phase_deg)) < 90.0)  # unwrapped: no 360° jumps


def test_unknown_names_are_errors(benchmark: MatrixSet) -> None:
    with pytest.raises(ModelError, match="unknown input 'yaw torque'"):
        frequency_response(benchmark.matrices, benchmark.g, 2.0, [1.0], "yaw torque")
    with pytest.raises(ModelError, match="unknown output"):
        frequency_response(benchmark.matrices, benchmark.g, 2.0, [1.0], output="yaw angle")
    with pytest.raises(ModelError, match="finite"):
        frequency_response(benchmark.matrices, benchmark.g, float("nan"), [1.0])
