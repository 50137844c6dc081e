"""One session's weave and capsize speeds print alike in every command, by the one formatter.

``replay``, ``model`` and ``budget`` of one session bag, ``run``'s line when the set is complete
(:class:`bike_rig.cli.run_cmd.RunTracker` fed the model node's sweep of the bag's parameters),
the console's title and its ``speeds`` reply all write the same ``value ± σ`` text: the one of
:func:`bike_rig.core.textfmt.format_speed` (σ by the PDG rule, the value to σ's last digit). A trial's
period prints alike in ``run`` and the console.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.cli.run_cmd import RunTracker, result_lines
from bike_rig.console.app import title_text
from bike_rig.core.textfmt import format_speed, format_uncertain
from bike_rig.offline.subjects import load_parameters, load_subject
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.model import StabilitySweep, compute_model
from bike_rig.session.state import SessionTrialView, result_line
from test.support.cli import run_cli
from test.support.simulated import short_session

#: ``4.23 ± 0.05 m/s`` as each command writes it.
NUMBER = r"(-?[0-9.]+ ± [0-9.]+)"


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_simulated_bag(tmp_path_factory.mktemp("speeds") / "bag", short_session(seed=11))


@pytest.fixture(scope="module")
def sweep(bag: Path) -> StabilitySweep:
    """What the model node publishes for the bag's parameter set."""
    return compute_model(load_parameters(bag), np.linspace(0.0, 10.0, 11))[1]


def _found(pattern: str, text: str) -> str:
    m = re.search(pattern, text)
    assert m is not None, (pattern, text[-3000:])
    return m.group(1)


@pytest.mark.parametrize("mode", ["weave", "capsize"])
def test_every_command_prints_the_same_speed(bag: Path, sweep: StabilitySweep, mode: str) -> None:
    speed = getattr(sweep, mode)
    assert speed is not None and np.isfinite(speed.sigma) and speed.sigma > 0
    expected = format_speed(speed).removesuffix(" m/s")
    printed = {}
    for command in ("replay", "model", "budget"):
        code, out, err = run_cli(command, str(bag))
        assert code == 0, err
        unit = r" \[m/s\]:" if command == "budget" else ":"
        printed[command] = _found(rf"{mode} speed{unit}\s+{NUMBER}", out)
    tracker = RunTracker()
    tracker.stability = sweep
    printed["run"] = _found(rf"{mode} speed {NUMBER} m/s", tracker.speeds_text())
    compact = format_speed(speed, compact=True)
    title = title_text("Browser", 68, 68, sweep)
    assert f"{mode} {compact}" in title  # the console's title: the same digits, without spaces
    printed["console title"] = compact.replace("±", " ± ")
    assert printed == dict.fromkeys(printed, expected), printed


def test_a_trial_period_prints_alike_in_run_and_the_console(bag: Path) -> None:
    trial = load_subject(bag).trials[0]
    fit: TrialFit = trial.result
    period = format_uncertain(fit.fit.period, fit.fit.period_sigma, "s")
    run_line = result_lines(trial.trial_id, trial.key, fit)[0]
    assert f"T = {period}," in run_line, run_line

    view = SessionTrialView(trial.trial_id, trial.key, trial.key, fit=fit)
    assert f"T = {period}" in result_line(view)
