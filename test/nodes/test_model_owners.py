"""The model node takes parameter sets only from the parameter node's process, and only possible ones.

Real processes over DDS: a foreign process's set (``Rogue``, IBxx = -9.2 kg m²) never drives the
model, and an impossible set from the parameter node's own process is refused; in both cases the
last valid model stays latched and the model's log names the refusal in one line.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import pytest

from bike_rig.config import topics
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet
from bike_rig.core.loader import load_input
from test.support.nodes import (
    BROWSER,
    STAMP_NS,
    browser_trials,
    offline_set,
    publish_trials,
    stamp_of,
    start_node,
    state_space_request,
)
from test.support.probe import STEP_TIMEOUT_S, Probe
from test.support.processes import RosProcess
from test.support.standin import ROGUE_STAMP_NS, ParameterStandIn, parameter_message

pytestmark = pytest.mark.ros

ROGUE = Path(__file__).with_name("rogue_parameters.py")
SWEEP_ARGS = ("-p", "speed_count:=11")


def which(bicycle: str, stamp_ns: int) -> str:
    """How the model node names a set in its log."""
    return f"parameter set '{bicycle}' (stamp {stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d} s)"


def log_lines(node: RosProcess, text: str) -> list[str]:
    return [line for line in node.stderr_path.read_text(encoding="utf-8").splitlines() if text in line]


def wait_for_log(probe: Probe, node: RosProcess, text: str, processes: Sequence[RosProcess]) -> str:
    """The node's one log line holding ``text``, once it is written (the probe spins meanwhile)."""
    try:
        probe.wait_for(lambda: bool(log_lines(node, text)), f"{node.name} to log {text!r}")
    except AssertionError as exc:
        raise AssertionError(f"{exc}\n" + "\n".join(p.describe() for p in processes)) from None
    lines = log_lines(node, text)
    assert len(lines) == 1, lines
    return lines[0]


def latched_sweep_stamps(ros_env: dict[str, str]) -> list[int]:
    """The stamps of the eigen sweeps a late joiner gets (latched: the last one only)."""
    from bike_rig_msgs.msg import EigenSweep

    with Probe(ros_env) as late:
        box = late.listen(topics.EIGEN_SWEEP, EigenSweep)
        late.wait_for(lambda: bool(box), "the latched eigen sweep")
        return [stamp_of(m) for m in box]


def test_a_set_from_another_process_never_drives_the_model(
    probe: Probe, ros_env: dict[str, str], node_env: dict[str, str], tmp_path: Path
) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters, EigenSweep

    probe.listen(topics.PARAMETERS, BenchmarkParameters)
    sweeps = probe.listen(topics.EIGEN_SWEEP, EigenSweep)
    with (
        start_node("parameter", "parameter", node_env, tmp_path, "-p", f"measurements:={BROWSER}") as parameter,
        start_node("model", "model", node_env, tmp_path, *SWEEP_ARGS) as model,
    ):
        nodes = [parameter, model]
        publish_trials(probe, browser_trials(), matched=True)
        genuine = stamp_of(probe.wait_message(topics.PARAMETERS, lambda m: m.complete, "a complete set", nodes))
        probe.wait_message(topics.EIGEN_SWEEP, lambda m: stamp_of(m) == genuine, "the genuine set's sweep", nodes)
        # the readers of the rogue's set: the model node and the probe
        with RosProcess("rogue", [sys.executable, str(ROGUE), "2"], node_env, tmp_path) as rogue:
            assert rogue.expect("MATCHED", STEP_TIMEOUT_S) == "2"
            rogue.expect("DONE", STEP_TIMEOUT_S)
            probe.wait_for(
                lambda: any(m.bicycle == "Rogue" for m in probe.inbox[topics.PARAMETERS.name]),
                "the rogue's set on the domain",
            )
            line = wait_for_log(probe, model, which("Rogue", ROGUE_STAMP_NS), [*nodes, rogue])
            assert line.endswith(
                f"{which('Rogue', ROGUE_STAMP_NS)} ignored: published by node 'rogue' in another process than the "
                "parameter node's; parameter sets are taken only from the parameter node"
            ), line
            assert latched_sweep_stamps(ros_env) == [genuine]
            rogue_code = rogue.stop()
        codes = (model.stop(), parameter.stop(), rogue_code)
    assert codes == (0, 0, 0), model.describe() + parameter.describe()
    assert [stamp_of(m) for m in sweeps] == [genuine]
    log = model.stderr_path.read_text(encoding="utf-8")
    assert "not physically possible" not in log  # the owner rule refused it: it was never computed
    assert log.count("model published") == 1 and "Browser: model published" in log


def test_an_impossible_set_from_the_parameter_node_is_refused_and_the_last_model_stays(
    probe: Probe, ros_env: dict[str, str], node_env: dict[str, str], tmp_path: Path
) -> None:
    from bike_rig_msgs.msg import EigenSweep
    from bike_rig_msgs.srv import StateSpace

    sweeps = probe.listen(topics.EIGEN_SWEEP, EigenSweep)
    benchmark = load_input(config_file("bicycles/benchmark.yaml"))
    assert isinstance(benchmark, ParameterSet)
    browser = offline_set()
    with start_node("model", "model", node_env, tmp_path, *SWEEP_ARGS) as model, ParameterStandIn(probe.context) as pn:
        probe.wait_for(pn.matched, "the model node's subscription to the parameter sets")
        pn.publish(parameter_message(browser, STAMP_NS))
        probe.wait_message(topics.EIGEN_SWEEP, lambda m: stamp_of(m) == STAMP_NS, "the valid set's sweep", [model])

        kept = "; refused, nothing published (the model of 'Browser' stays)"
        pn.publish(parameter_message(browser, STAMP_NS + 1, changes={"zB": math.nan}))
        line = wait_for_log(probe, model, which("Browser", STAMP_NS + 1), [model])
        assert line.endswith(
            f"{which('Browser', STAMP_NS + 1)} is not physically possible: zB = nan m: every "
            f"value must be a finite number{kept}"
        ), line
        pn.publish(parameter_message(benchmark, STAMP_NS + 2, "Rogue", {"IBxx": -9.2}))
        line = wait_for_log(probe, model, which("Rogue", STAMP_NS + 2), [model])
        assert line.endswith(
            f"{which('Rogue', STAMP_NS + 2)} is not physically possible: IBxx = -9.2 kg m²: an "
            f"inertia must be positive{kept}"
        ), line
        assert line.startswith("[ERROR]"), line

        assert latched_sweep_stamps(ros_env) == [STAMP_NS]
        # the state space is still the valid set's
        got = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(5.0, ""))
        assert got.ok and got.message.startswith("Browser at 5 m/s"), got.message
        code = model.stop()
    assert code == 0, model.describe()
    assert [stamp_of(m) for m in sweeps] == [STAMP_NS]
