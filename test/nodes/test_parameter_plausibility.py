"""The parameter node never publishes a parameter set that is not physically possible; it names the readings."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.config import topics
from bike_rig.pipeline.fit import TrialFit
from test.support.nodes import BROWSER, browser_trials, publish_trials, start_node
from test.support.probe import Probe

pytestmark = pytest.mark.ros


def test_a_compound_period_too_short_is_logged_and_no_set_is_published(
    probe: Probe, node_env: dict[str, str], tmp_path: Path
) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters

    short = TrialFit.from_period("TcR1_t1", "TcR1", 0.1, 1e-5, True, stamp_ns=1)
    trials = [short if t.measurement_key == "TcR1" else t for t in browser_trials()]
    sets = probe.listen(topics.PARAMETERS, BenchmarkParameters)
    with start_node("parameter", "parameter_impossible", node_env, tmp_path, "-p", f"measurements:={BROWSER}") as node:
        publish_trials(probe, trials, matched=True)
        wanted = "cannot compute the parameters: "
        probe.wait_for(lambda: wanted in node.stderr_path.read_text(errors="replace"), "the error line")
        log = node.stderr_path.read_text(errors="replace")
        line = next(x for x in log.splitlines() if wanted in x)
        assert "is not physically possible: TcR1 = 0.1 s with lR = 0.29" in line
        assert "a compound period of at least" in line
        assert not any(m.complete for m in sets)
        assert node.stop() == 0, node.describe()
