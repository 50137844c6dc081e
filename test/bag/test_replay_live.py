"""The replay against a real live graph.

A simulated session through the node processes over DDS (``bike_rig.ros.demo``: driver, fitter,
parameter, model and the recorder), then replayed offline from the recorded bag: every number
equals what the graph published.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from bike_rig.config.paths import config_file
from bike_rig.offline.info import summarize
from bike_rig.offline.replay import replay_bag
from bike_rig.ros.demo import run_demo

pytestmark = pytest.mark.ros


def test_replay_of_a_live_session_is_identical(tmp_path: Path) -> None:
    rig = yaml.safe_load(config_file("rig.yaml").read_text())
    rig["trials"]["duration"] = 12  # shorter trials keep the run short (still ≥ 5 cycles of every part)
    rig_file = tmp_path / "rig.yaml"
    rig_file.write_text(yaml.safe_dump(rig))
    lines: list[str] = []
    live = run_demo(
        tmp_path / "session",
        seed=3,
        time_scale=60.0,
        samples_per_batch=50,
        timeout_s=240,
        progress=lines.append,
        rig=rig_file,
    )
    result = replay_bag(live.bag)
    assert result.complete and len(result.trials) == live.trials == 39
    assert {t.options_from for t in result.trials} == {"recorded"}
    compared = {d.what for d in result.live.differences if not d.what.startswith("trial ")}
    assert compared == {
        "combined periods",
        "parameters",
        "parameter sigmas",
        "parameter covariance",
        "canonical matrices",
        "matrix sigmas",
        "weave speed",
        "capsize speed",
        "eigenvalues",
    }
    assert result.live.compared_trials == 39 and not result.live.missing
    assert result.live.identical, [d for d in result.live.differences if not d.identical][:5]
    # the demo's own view of the live results agrees too
    ps, live_ps = result.parameters, live.session.parameters
    assert ps is not None and live_ps is not None
    for name in ps.parameters.names:
        assert ps.parameters.value(name) == pytest.approx(live_ps.parameters.value(name), rel=1e-12, abs=0)
    assert result.stability is not None and live.stability.weave is not None and result.stability.weave is not None
    assert math.isclose(result.stability.weave.speed, live.stability.weave.speed, rel_tol=1e-12)
    summary = summarize(live.bag)
    assert len(summary.trials) == 39 and all(t.usable and t.samples == t.announced for t in summary.trials)
