"""The node tests' shared pieces: the nodes' environment, the Browser's periods and parameter set, model requests."""

from __future__ import annotations

import os
import sys
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from bike_rig.config import topics
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ComMethod, ParameterSet
from bike_rig.core.loader import load_measurements, load_static_readings
from bike_rig.messages import (
    fill_benchmark_parameters,
    fill_period_estimate,
    set_stamp,
)
from bike_rig.pipeline.assemble import assemble
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.readings import STATIC_KEYS as READING_KEYS
from test.support.probe import Probe
from test.support.processes import RosProcess
from test.support.standin import ParameterStandIn

REPO = Path(__file__).resolve().parents[2]


BROWSER = config_file("bicycles/browser.yaml")


BROWSER_KEYS = (
    "TtP1",
    "TcR1",
    "TtR1",
    "TcF1",
    "TtF1",
    "TcB1",
    "TtB1",
    "TtB2",
    "TtB3",
    "TcH1",
    "TtH1",
    "TtH2",
    "TtH3",
)


def node_environment(ros_env: Mapping[str, str]) -> dict[str, str]:
    """The nodes' environment: the run's ROS environment, this checkout first on the path."""
    env = dict(ros_env)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    return env


def start_node(module: str, name: str, env: Mapping[str, str], log_dir: Path, *ros_args: str) -> RosProcess:
    """``python -m bike_rig.ros.nodes.<module> --ros-args ...`` as a child process."""
    argv = [sys.executable, "-m", f"bike_rig.ros.nodes.{module}", "--ros-args", *ros_args]
    return RosProcess(name, argv, env, log_dir)


def browser_trials() -> list[TrialFit]:
    """One trial per key with the Browser file's own period and σ."""
    full = load_measurements(BROWSER)
    return [
        TrialFit.from_period(f"{k}_t1", k, full.value(k), full.readings[k].sigma, True, stamp_ns=i)
        for i, k in enumerate(BROWSER_KEYS)
    ]


def publish_trials(probe: Probe, trials: Sequence[TrialFit], matched: bool = False) -> None:
    """Publish period estimates (transient local: later subscribers get them too)."""
    from bike_rig_msgs.msg import PeriodEstimate

    pub = probe.publisher(topics.PERIODS, PeriodEstimate, matched)
    for t in trials:
        pub.publish(fill_period_estimate(PeriodEstimate(), t))


STAMP_NS = 1_700_000_000_123_456_789


#: The stand-in parameter node of each probe (its node goes with the probe's context).
_STAND_INS: weakref.WeakKeyDictionary[Probe, ParameterStandIn] = weakref.WeakKeyDictionary()


def offline_set(method: ComMethod = ComMethod.CENTROID) -> ParameterSet:
    result = assemble(load_static_readings(BROWSER), browser_trials(), method)
    assert result.parameters is not None
    return result.parameters


def publish_set(probe: Probe, method: ComMethod, stamp_ns: int) -> None:
    """Publish the Browser set from a node named 'parameter' in the probe's process (the model takes only its sets)."""
    from bike_rig_msgs.msg import BenchmarkParameters

    msg = fill_benchmark_parameters(
        BenchmarkParameters(), assemble(load_static_readings(BROWSER), browser_trials(), method)
    )
    set_stamp(msg, stamp_ns)
    standin = _STAND_INS.get(probe)
    if standin is None:
        standin = _STAND_INS[probe] = ParameterStandIn(probe.context)
    probe.wait_for(standin.matched, f"a subscriber of {topics.PARAMETERS.name}")
    standin.publish(msg)


def stamp_of(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def state_space_request(speed: float, rider: str) -> Any:
    from bike_rig_msgs.srv import StateSpace

    request = StateSpace.Request()
    request.speed = speed
    request.rider = rider
    return request


ASSIST = REPO / "config" / "feedback" / "balance_assist.yaml"


def _three_orientations(part: str) -> tuple[str, ...]:
    return tuple(f"{prefix}{part}{i}" for i in (1, 2, 3) for prefix in ("alpha", "a"))


#: Every static reading of a bicycle with three frame and three fork orientations, file order:
#: each part's orientations follow its mass.
STATIC_KEYS = READING_KEYS[:-1] + _three_orientations("B") + READING_KEYS[-1:] + _three_orientations("H")
