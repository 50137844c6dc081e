"""The parameter node: static readings + live period estimates → the benchmark parameter set.

On start it loads the bicycle's static readings (a measurement file, bike_rig YAML or
BicycleParameters ``Measured.txt``; any periods in it are ignored) and publishes them, latched,
on ``/bike_rig/static_readings``. It subscribes to ``/bike_rig/periods`` (reliable,
transient-local: a restarted node receives the whole session's estimates again) and feeds every
estimate to :class:`bike_rig.pipeline.assemble.SessionAssembly`, which dedupes by trial id and
combines the valid, unflagged trials of each measurement key.

On ``/bike_rig/parameters`` (reliable, transient-local, depth 1) it publishes:

* the complete parameter set (values, σ, covariance, provenance) as soon as every period is
  there, and again whenever the combined periods change (a better trial arrived);
* while incomplete, a set with ``complete = false`` and ``missing`` listing what is still to
  measure, whenever that changes and every ``status_period`` s, and logs it.

An estimate that arrives after a quiet spell is evaluated at once; estimates that follow within
``EVALUATE_PERIOD_S`` of an evaluation are evaluated together at the end of that spell (a burst,
such as a restarted node catching up on a session, gives few evaluations).

Parameters (``config/parameter.yaml``, node name ``parameter``):

* ``measurements`` (string, required): the measurement file; a relative path that does not
  exist from the working directory is looked up under the config folder
  (``bicycles/browser.yaml``).
* ``com_method`` (string): mass-centre method, ``centroid`` (default, the paper's) or ``lstsq``.
* ``status_period`` (double, s): how often an incomplete state is re-published and logged;
  default 5.0.

A bad measurement file or parameter ends the process with one error line, exit status 2.
Run: ``python -m bike_rig.nodes.parameter --ros-args -p measurements:=bicycles/browser.yaml``.
"""

from __future__ import annotations

import importlib
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rclpy.node import Node

from .. import topics
from ..core.benchmark import ComMethod
from ..core.errors import BikeRigError
from ..core.loader import load_static_readings
from ..messages import MessageError, fill_benchmark_parameters, fill_static_readings, trial_fit_from_msg
from ..params import ParamSpec
from ..paths import config_file
from ..pipeline.assemble import KeyPeriod, SessionAssembly, SessionParameters
from ..pipeline.errors import AssemblyError
from ..rosqos import profile
from .params import NodeParameterError, declare_parameters
from .runner import run_node

__all__ = ["EVALUATE_PERIOD_S", "NODE_NAME", "PARAMETERS", "ParameterNode", "main", "resolve_measurements"]

NODE_NAME = "parameter"
#: Estimates are evaluated at most this often, s (later ones of a burst together).
EVALUATE_PERIOD_S = 0.05

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")

#: The parameter node's parameters (``config/parameter.yaml``).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "measurements", "",
        "Measurement file with the bicycle's static readings (bike_rig YAML or BicycleParameters "
        "Measured.txt); periods in it are ignored. Relative paths are also looked up in the config folder.",
    ),  # fmt: skip
    ParamSpec("com_method", ComMethod.CENTROID.value, "Mass-centre method: 'centroid' (paper Eq 17-19) or 'lstsq' "
              "(Eq 20).", choices=tuple(m.value for m in ComMethod)),  # fmt: skip
    ParamSpec("status_period", 5.0, "While incomplete, re-publish and log the missing periods this often, s.",
              (0.5, 3600.0)),  # fmt: skip
)


def resolve_measurements(value: str) -> Path:
    """The measurement file named by the ``measurements`` parameter.

    Raises:
        NodeParameterError: the parameter is empty.
    """
    if not value.strip():
        raise NodeParameterError(
            "parameter 'measurements' is required: the bicycle's measurement file "
            "(e.g. -p measurements:=bicycles/browser.yaml)"
        )
    path = Path(value).expanduser()
    if not path.exists() and not path.is_absolute() and config_file(value).exists():
        return config_file(value)
    return path


def _provenance(periods: Sequence[KeyPeriod]) -> tuple[tuple[str, float, float, tuple[str, ...]], ...]:
    return tuple((p.key, p.value, p.sigma, p.trial_ids) for p in periods)


class ParameterNode(Node):
    """Static readings + period estimates → BenchmarkParameters (see the module docstring)."""

    def __init__(self) -> None:
        """Declare the parameters, load the static readings and publish them, subscribe.

        Raises:
            NodeParameterError: A parameter is wrong or ``measurements`` is empty.
            BikeRigError: The measurement file cannot be read.
        """
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PARAMETERS)
        method = ComMethod(values["com_method"])
        status_period = values["status_period"]
        path = resolve_measurements(values["measurements"])
        static = load_static_readings(path)
        self._session = SessionAssembly(static, method, origin=topics.PERIODS.name)
        document = path.read_text(encoding="utf-8", errors="replace")

        self._static_pub = self.create_publisher(
            _msgs.StaticReadings, topics.STATIC_READINGS.name, profile(topics.STATIC_READINGS)
        )
        self._params_pub = self.create_publisher(
            _msgs.BenchmarkParameters, topics.PARAMETERS.name, profile(topics.PARAMETERS)
        )
        static_msg = fill_static_readings(_msgs.StaticReadings(), self._session.static, document)
        static_msg.header.stamp = self.get_clock().now().to_msg()
        self._static_pub.publish(static_msg)

        self._dirty = False
        self._last_evaluation = -float("inf")
        self._published: tuple[Any, ...] | None = None
        self._status_period = float(status_period)
        self.create_subscription(_msgs.PeriodEstimate, topics.PERIODS.name, self._on_period, profile(topics.PERIODS))
        self.create_timer(EVALUATE_PERIOD_S, self._evaluate)
        self.create_timer(self._status_period, self._status)
        self.get_logger().info(
            f"{static.bicycle}: static readings from {path}; waiting for periods "
            f"{', '.join(self._session.required_keys)} on {topics.PERIODS.name} (com method {method.value})"
        )
        self._evaluate(force=True)

    def _on_period(self, msg: Any) -> None:
        try:
            trial = trial_fit_from_msg(msg)
            self._dirty |= self._session.add(trial)
        except (AssemblyError, MessageError) as exc:
            self.get_logger().warning(f"period estimate ignored: {exc}")
        if time.monotonic() - self._last_evaluation >= EVALUATE_PERIOD_S:
            self._evaluate()

    def _evaluate(self, force: bool = False) -> None:
        if not (self._dirty or force):
            return
        self._dirty = False
        self._last_evaluation = time.monotonic()
        periods = self._session.periods()
        key = (len(periods) == len(self._session.required_keys), _provenance(periods))
        if key == self._published and not force:
            return
        try:
            result = self._session.result()
        except BikeRigError as exc:
            self.get_logger().error(f"cannot compute the parameters: {exc}")
            return
        self._published = key
        self._publish(result)

    def _status(self) -> None:
        if self._published is not None and not self._published[0]:
            self._evaluate(force=True)

    def _publish(self, result: SessionParameters) -> None:
        msg = fill_benchmark_parameters(_msgs.BenchmarkParameters(), result)
        msg.header.stamp = self.get_clock().now().to_msg()
        self._params_pub.publish(msg)
        trials = sum(len(p.trial_ids) for p in result.periods)
        if result.complete:
            self.get_logger().info(
                f"{result.bicycle}: parameter set complete ({len(result.periods)} periods from {trials} trials) "
                f"published on {topics.PARAMETERS.name}"
            )
        else:
            self.get_logger().info(
                f"{result.bicycle}: incomplete, {len(result.periods)} of {len(self._session.required_keys)} periods; "
                f"missing {', '.join(result.missing)}"
            )


def main(args: Sequence[str] | None = None) -> int:
    """Run the parameter node until SIGINT/SIGTERM (exit 2 on a bad measurement file)."""
    return run_node(ParameterNode, args, name="parameter")


if __name__ == "__main__":
    sys.exit(main())
