"""The main job: a whole simulated rig session through the live ROS graph.

1. Simulate a measurement session of the default bicycle (``bike-rig simulate``).
2. Start the graph (``config/graph.yaml``: recorder, fitter, parameter, model, driver) as
   processes on localhost with the run's own ROS_DOMAIN_ID; the driver streams every trial at
   1 kHz rig time, sped up by a time scale.
3. Follow the session from a monitor node in this process: each trial's period as it is fitted,
   the parameter set once complete, the model.
4. When every trial has its period and the model of the final parameter set is out, stop the
   graph (the recorder last) and return the results and where the bag is.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..config.paths import config_file
from ..core.errors import BikeRigError
from ..core.sim import load_rig, simulate_session, write_session
from ..core.sim.session import load_true_parameters
from ..pipeline.assemble import SessionParameters
from ..pipeline.model import StabilitySweep
from .env import ros_environment
from .launch import load_graph
from .running import RunningGraph

__all__ = ["DemoError", "DemoResult", "run_demo"]

#: After the last trial's period, how long the parameter and model nodes may take, s.
SETTLE_S = 20.0


class DemoError(BikeRigError):
    """The demo session did not complete."""


@dataclass
class DemoResult:
    """What the demo session produced.

    Attributes:
        session: The parameters (complete) with the periods they came from.
        stability: The model's eigen sweep and critical speeds of those parameters.
        bag: The recorded bag directory.
        trials: Trials streamed; periods: period estimates received (valid or not).
        invalid: Trial ids whose fit was invalid or flagged, with the reasons.
        wall_s: Wall time of the live session, s.
    """

    session: SessionParameters
    stability: StabilitySweep
    bag: Path
    trials: int
    periods: int
    invalid: dict[str, str] = field(default_factory=dict)
    wall_s: float = 0.0


class _Monitor:
    """Subscriptions of the demo process (rclpy imported lazily: the core stays ROS-free)."""

    def __init__(self, progress: Callable[[str], None]) -> None:
        import rclpy

        from bike_rig_msgs.msg import BenchmarkParameters, EigenSweep, PeriodEstimate, TrialEvent

        from .. import messages
        from ..config import topics
        from .qos import profile

        self.rclpy = rclpy
        self.messages = messages
        self.progress = progress
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("demo_monitor", context=self.context)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.started: set[str] = set()
        self.periods: dict[str, Any] = {}
        self.parameters: Any = None
        self.sweep: Any = None
        self.node.create_subscription(TrialEvent, topics.TRIAL_EVENTS.name, self._event, profile(topics.TRIAL_EVENTS))
        self.node.create_subscription(PeriodEstimate, topics.PERIODS.name, self._period, profile(topics.PERIODS))
        self.node.create_subscription(
            BenchmarkParameters, topics.PARAMETERS.name, self._parameters, profile(topics.PARAMETERS)
        )
        self.node.create_subscription(EigenSweep, topics.EIGEN_SWEEP.name, self._sweep, profile(topics.EIGEN_SWEEP))

    def _event(self, msg: Any) -> None:
        if msg.kind == msg.START and msg.trial_id not in self.started:
            self.started.add(msg.trial_id)

    def _period(self, msg: Any) -> None:
        earlier = self.periods.get(msg.trial_id)
        if earlier is not None:
            # a re-publication (restarted fitter): keep the estimate from the most samples, as
            # the parameter node does (bike_rig.pipeline.assemble)
            if msg.n_samples > earlier.n_samples:
                self.periods[msg.trial_id] = msg
            return
        self.periods[msg.trial_id] = msg
        state = "ok" if msg.valid and not msg.flags else "REDO: " + "; ".join(msg.flag_reasons or ["no period"])
        self.progress(
            f"  [{len(self.periods):>2}] {msg.trial_id:<32} {msg.measurement_key:<5} "
            f"T = {msg.period:.6f} ± {msg.period_sigma:.1e} s  {state}"
        )

    def _parameters(self, msg: Any) -> None:
        self.parameters = msg

    def _sweep(self, msg: Any) -> None:
        self.sweep = msg

    def spin(self, seconds: float) -> None:
        self.executor.spin_once(timeout_sec=seconds)

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)


def run_demo(
    out_dir: Path,
    bicycle: Path | None = None,
    seed: int = 1,
    time_scale: float = 25.0,
    samples_per_batch: int = 200,
    timeout_s: float = 600.0,
    progress: Callable[[str], None] = print,
    rig: Path | None = None,
    on_progress: Callable[[RunningGraph, int], None] | None = None,
    recorder: Mapping[str, object] | None = None,
) -> DemoResult:
    """Run the whole simulated session through the live graph.

    Args:
        out_dir: A new or empty directory for the session, the bag and the node logs.
        bicycle: The true bicycle (default: ``config/bicycles/browser.yaml``).
        seed: Seed of the simulated session.
        time_scale: Rig seconds per wall second.
        samples_per_batch: Samples per GyroBatch message.
        timeout_s: Give up after this long (wall), s.
        progress: Where progress lines go.
        rig: The rig description (default: ``config/rig.yaml``).
        on_progress: Called with the running graph and the number of trials fitted so far,
            after every poll (fault-injection tests kill and restart nodes from it).
        recorder: More recorder parameters (e.g. ``max_bag_size``); ``output`` is the demo's.

    Raises:
        DomainIdError: ``ROS_DOMAIN_ID`` is set to something that is not a domain id (checked
            first, before anything is simulated or written).
        DemoError: a node died, or the session did not complete in time.
    """
    env = ros_environment(os.environ)
    bicycle = bicycle or config_file("bicycles/browser.yaml")
    out_dir.mkdir(parents=True, exist_ok=True)
    if any(out_dir.iterdir()):
        raise DemoError(f"{out_dir}: not empty; give a new directory for the demo session")
    name, truth = load_true_parameters(bicycle)
    session = simulate_session(truth, load_rig(rig or config_file("rig.yaml")), seed, name)
    session_yaml = write_session(session, out_dir / "session")
    n_trials = len(session.trials)
    progress(f"simulated {name}: {n_trials} trials (seed {seed}) in {session_yaml.parent}")
    bag = out_dir / "bag"
    graph = load_graph(config_file("graph.yaml")).with_parameters(
        {
            "recorder": {**(recorder or {}), "output": str(bag)},
            "parameter": {"measurements": str(session_yaml)},
            "driver": {
                "source": "sim",
                "session": str(session_yaml),
                "time_scale": float(time_scale),
                "samples_per_batch": int(samples_per_batch),
                "wait_for_subscribers": 2,  # the fitter and the recorder
            },
        }
    )
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION")})
    t0 = time.monotonic()
    with RunningGraph(graph, out_dir / "logs", domain_id=int(env["ROS_DOMAIN_ID"])) as running:
        progress(
            f"graph started: {len(graph.nodes)} nodes on ROS_DOMAIN_ID={running.domain_id} (localhost); "
            f"streaming at {time_scale:g}x rig time"
        )
        monitor = _Monitor(progress)
        try:
            final = _wait(monitor, running, n_trials, t0 + timeout_s, on_progress)
        finally:
            monitor.close()
        status = running.stop()
    wall = time.monotonic() - t0
    from .. import messages

    result = DemoResult(
        session=messages.session_parameters_from_msg(final[0], source=str(session_yaml)),
        stability=messages.stability_sweep_from_msg(final[1]),
        bag=bag,
        trials=n_trials,
        periods=len(monitor.periods),
        invalid={
            tid: "; ".join(m.flag_reasons) or "no period"
            for tid, m in monitor.periods.items()
            if not m.valid or m.flags
        },
        wall_s=wall,
    )
    bad = {n: c for n, c in status.items() if c != 0}
    if bad:
        progress(f"note: nodes that did not exit with status 0: {bad} (logs in {out_dir / 'logs'})")
    return result


def _wait(
    monitor: _Monitor,
    running: RunningGraph,
    n_trials: int,
    deadline: float,
    on_progress: Callable[[RunningGraph, int], None] | None = None,
) -> tuple[Any, Any]:
    """Spin until every trial has a period and the model of the final parameter set is out."""
    announced = False
    all_in: float | None = None  # when the last trial's period arrived
    while time.monotonic() < deadline:
        monitor.spin(0.05)
        if on_progress is not None:
            on_progress(running, len(monitor.periods))
        dead = running.dead()
        if dead:
            name, code, tail = dead[0]
            raise DemoError(f"node '{name}' died with status {code}:\n{tail}")
        params, sweep = monitor.parameters, monitor.sweep
        if params is not None and params.complete and not announced and len(monitor.periods) < n_trials:
            announced = True
            monitor.progress("  parameter set complete; refining with the remaining trials")
        if len(monitor.periods) >= n_trials and all_in is None:
            all_in = time.monotonic()
        if all_in is not None and time.monotonic() - all_in > SETTLE_S:
            missing = ", ".join(params.missing) if params is not None else "everything"
            redo = [tid for tid, m in monitor.periods.items() if not m.valid or m.flags]
            raise DemoError(
                f"every trial was fitted but the parameters are incomplete {SETTLE_S:g} s later; missing: {missing}; "
                f"trials to redo: {', '.join(sorted(redo)) or 'none'}"
            )
        if len(monitor.periods) < n_trials or params is None or not params.complete or sweep is None:
            continue
        used = set(params.trial_ids)
        wanted = {f"{m.measurement_key}:{tid}" for tid, m in monitor.periods.items() if m.valid and not m.flags}
        if used == wanted and _same_stamp(params, sweep):
            return params, sweep
    raise DemoError(
        f"the session did not complete within the time limit: {len(monitor.periods)} of {n_trials} periods, "
        f"parameters {'complete' if monitor.parameters is not None and monitor.parameters.complete else 'incomplete'}"
    )


def _same_stamp(a: Any, b: Any) -> bool:
    return bool(a.header.stamp.sec == b.header.stamp.sec and a.header.stamp.nanosec == b.header.stamp.nanosec)
