"""Figures of the closed loop (``--feedback``): eigenvalues and Bode against independent references.

Eigenvalues against ``numpy.linalg.eigvals(A − B K)`` and the Bode response against
``scipy.signal.freqresp`` of the closed-loop state space, for every bicycle under
``../shared/data/bicycleparameters``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from bike_rig.cli.main import main
from bike_rig.config.paths import config_dir
from bike_rig.core.feedback import load_feedback
from bike_rig.core.frequency import INPUTS, OUTPUTS
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.plots.bode import bode_figure
from bike_rig.plots.eigen import eigen_vs_speed
from bike_rig.plots.model_data import bode_curves, eigen_curves

ASSIST_YAML = config_dir() / "feedback" / "balance_assist.yaml"
ASSIST = load_feedback(ASSIST_YAML)


def _subjects(shared: Path) -> list[Subject]:
    files = sorted((shared / "data" / "bicycleparameters").glob("*/Parameters/*Benchmark.txt"))
    assert len(files) >= 8
    return [load_subject(f) for f in files]


def _closed_loop(subject: Subject, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A − B K`` (built here from ``state_space``) and ``B`` at the speeds ``v``."""
    ms = canonical_with_sigma(subject.parameters)
    a, b = state_space(ms.matrices, v, ms.g)
    k = np.zeros(np.shape(v) + (2, 4))
    k[..., 1, :] = ASSIST.gains(v)
    return a - b @ k, np.broadcast_to(b, np.shape(a)[:-2] + (4, 2))


def test_eigen_curves_are_the_closed_loop(shared_dir: Path) -> None:
    """``eigen_curves(feedback=...)`` equals ``eigvals(A − B K)`` at every speed, every bicycle."""
    v = np.linspace(0.0, 10.0, 201)
    for subject in _subjects(shared_dir):
        c = eigen_curves(subject, speeds=v, feedback=ASSIST)
        a_cl, _ = _closed_loop(subject, c.speeds)
        ref = np.linalg.eigvals(a_cl)
        assert np.abs(c.eigenvalues[:, :, None] - ref[:, None, :]).min(axis=2).max() < 1e-9, subject.name
        assert c.feedback == "balance assist"
        has_sigma = bool(np.any(subject.parameters.parameters.covariance))  # the Benchmark bicycle has none
        assert (np.nanmax(c.sigma_real) > 0.0) == has_sigma, subject.name


@pytest.mark.parametrize("speed", [0.5, 2.0, 6.0])
def test_bode_is_the_closed_loop(shared_dir: Path, speed: float) -> None:
    """Closed-loop ``G(iω)`` equals scipy's ``freqresp`` of ``(A − B K, B, C)`` for every pair."""
    w = np.logspace(-1, 2, 50)
    for subject in _subjects(shared_dir)[:4]:
        a_cl, b = _closed_loop(subject, np.asarray(speed))
        for i, inp in enumerate(INPUTS):
            for o, out in enumerate(OUTPUTS):
                c = np.zeros((1, 4))
                c[0, o] = 1.0
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", signal.BadCoefficients)
                    _, h = signal.freqresp(signal.StateSpace(a_cl, b[:, [i]], c, np.zeros((1, 1))), w)
                got = bode_curves(subject, speed, input=inp, output=out, omega=w, feedback=ASSIST)
                assert np.max(np.abs(got.response - h) / np.abs(h)) < 1e-8, (subject.name, inp, out)


def test_figures_name_the_closed_loop(shared_dir: Path) -> None:
    """The titles say which feedback's closed loop a figure shows."""
    bikes = _subjects(shared_dir)[:2]
    assert "closed loop (balance assist)" in eigen_vs_speed(bikes, feedback=ASSIST)._suptitle.get_text()  # type: ignore[union-attr]
    assert "closed loop" not in eigen_vs_speed(bikes)._suptitle.get_text()  # type: ignore[union-attr]
    assert "closed loop (balance assist)" in bode_figure(bikes, feedback=ASSIST)._suptitle.get_text()  # type: ignore[union-attr]


def test_plot_command_takes_feedback(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``bike-rig plot eigen|bode ... --feedback FILE`` writes the figures; a bad file is one line."""
    browser = str(config_dir() / "bicycles" / "browser.yaml")
    assert main(["plot", "bode", browser, "-o", str(tmp_path), "--feedback", str(ASSIST_YAML)]) == 0
    assert capsys.readouterr().out.split() == [str(tmp_path / "bode.png")]
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-feedback/1\nk_steer: 1\n")
    assert main(["plot", "eigen", browser, "-o", str(tmp_path), "--feedback", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"bike-rig plot: error: {bad}:2: key 'k_steer': unknown key") and err.count("\n") == 1
