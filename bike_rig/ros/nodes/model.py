"""The model node: each complete parameter set → canonical matrices, eigenvalue sweep, stability.

It subscribes to ``/bike_rig/parameters`` (reliable, transient-local: started late, it still
gets the current set) and, for every complete set, computes with
:func:`bike_rig.pipeline.assemble.compute_model` and publishes, latched (reliable, transient-local,
depth 1):

* ``/bike_rig/model/matrices`` (``CanonicalMatrices``): M, C1, K0, K2 with σ;
* ``/bike_rig/model/eigen_sweep`` (``EigenSweep``): eigenvalues at ``speed_count`` speeds from
  ``speed_min`` to ``speed_max``, mode labels, and the weave and capsize speeds with σ (NaN and
  ``has_* = false`` when the bicycle has none).

Both carry the parameter set's header stamp, so a consumer can tell which set they belong to.
Incomplete sets are ignored (the last model stays published).

A set is taken only from the parameter node's process (:mod:`bike_rig.ros.nodes.owners`: the
publisher's DDS participant, looked up in the graph); a set from another process on the domain
is ignored, said in one warning line (the first from each process, then at most every
:data:`FOREIGN_SAY_S` with a count). A set that is not physically possible
(:func:`bike_rig.core.plausibility.check`: NaN, a negative inertia...) is refused in one error
line naming the set and every broken rule, and publishes nothing: the previous model stays
latched and serves the state space.

With a ``feedback`` file the sweep, the critical speeds and the state space (``A − B K``) are
those of the closed loop of that steer-torque state feedback (the matrices stay the bicycle's).

It serves ``/bike_rig/model/state_space`` (``StateSpace``): A, B and the eigenvalues at a
requested speed, for the node's rider (``rider: ""``), no rider (``"none"``) or the paper's
(``"paper"``); ``ok = false`` with a reason before any parameter set arrived, for a speed that
is not a finite number ≥ 0, or for an unknown rider.

It subscribes to the riding speed ``/bike_rig/ride/speed`` (``std_msgs/Float64``, m/s) and
publishes, latched, ``/bike_rig/ride/state_space`` (``StateSpaceModel``): A, B and the labelled
eigenvalues at that speed for the node's rider and feedback, each with its σ. A new model is
published when the speed differs from the last published one by more than ``ride_speed_step``
(or a new parameter set arrived), at most ``ride_max_rate`` times a second: a change that comes
too soon is published when the interval is over (the latest speed then).

Diagnostics (``/diagnostics``, 1 Hz): ``model: model`` (WARN until a complete set arrived) and
``model: ride`` (the latest speed, the state spaces published, the time the last took).

Parameters (``config/model.yaml``, node name ``model``), all read-only:

* ``rider`` (string): ``""`` (none, default), ``"paper"`` (Table 1 rider in the rear frame) or a
  rider YAML file (read at start; a Yeadon rider needs ``bicycle_geometry`` in it, since the
  parameter sets on the topic carry no rider geometry). A state-space request names only
  ``""``, ``"none"`` or ``"paper"``.
* ``feedback`` (string): ``""`` (none, default) or the path of a feedback file
  (``format: bike_rig-feedback/1``, :mod:`bike_rig.core.feedback`), read at start.
* ``sigma_convention`` (string): ``correlated`` (default) or ``paper`` (independent
  parameters, the paper's Table 3); for the matrices' and the critical speeds' σ.
* ``speed_min``, ``speed_max`` (double, m/s): the sweep's range, default 0 to 10.
* ``speed_count`` (integer): number of speeds, default 201.
* ``ride_speed_step`` (double, m/s): smallest speed change that gives a new ride state space,
  default 0.1.
* ``ride_max_rate`` (double, 1/s): most ride state spaces per second, default 5.

Run: ``python -m bike_rig.ros.nodes.model --ros-args --params-file config/model.yaml``.
"""

from __future__ import annotations

import importlib
import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from rclpy.node import Node

from ...config import topics
from ...config.settings import ParamSpec
from ...core.benchmark import ParameterSet
from ...core.errors import BikeRigError
from ...core.feedback import resolve_feedback
from ...core.plausibility import ImplausibleParametersError, check
from ...core.rider import resolve_rider, rider_key
from ...core.uncertainty.matrix_sigma import SigmaConvention
from ...messages import (
    fill_canonical_matrices,
    fill_eigen_sweep,
    fill_state_space_error,
    fill_state_space_model,
    fill_state_space_response,
    ride_speed_from_msg,
    session_parameters_from_msg,
    stamp_ns,
)
from ...pipeline.health import ModelHealth, model_statuses
from ...pipeline.model import ModelMatrices, compute_model, state_space_at, state_space_with_sigma_at, with_rider
from ..qos import profile
from .diagnostics import DiagnosticsUpdater
from .owners import RELOOK_S, OwnerFilter, Released
from .runner import run_node
from .settings import NodeParameterError, declare_parameters, parameter_error

__all__ = ["FOREIGN_SAY_S", "MAX_SPEED_COUNT", "NODE_NAME", "PARAMETERS", "ModelNode", "main"]

NODE_NAME = "model"
#: Least time between two warnings about the sets of one foreign process, s.
FOREIGN_SAY_S = 10.0
#: Largest number of speeds in the sweep (the EigenSweep message grows with it).
MAX_SPEED_COUNT = 100_000

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_srvs: Any = importlib.import_module("bike_rig_msgs.srv")
_std: Any = importlib.import_module("std_msgs.msg")

#: The model node's parameters (``config/model.yaml``).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "rider",
        "",
        "Rider lumped into the rear frame: '' (none), 'paper' (Table 1) or a rider YAML file "
        "(rigid, or Yeadon with its bicycle_geometry: a parameter set on the topic has no rider geometry).",
        constraints="'', paper or a rider YAML file",
    ),
    ParamSpec(
        "feedback",
        "",
        "Steer-torque state feedback file (format bike_rig-feedback/1), '' for none: the eigen sweep, "
        "critical speeds and state space are then of the closed loop A - B K.",
        constraints="'' or a readable feedback file",
    ),
    ParamSpec(
        "sigma_convention",
        SigmaConvention.CORRELATED.value,
        "Sigma of the matrices and critical speeds: 'correlated' (full parameter covariance) or "
        "'paper' (parameters independent, the paper's Table 3).",
        choices=tuple(c.value for c in SigmaConvention),
    ),
    ParamSpec("speed_min", 0.0, "Lowest speed of the eigenvalue sweep, m/s.", (0.0, 1000.0)),
    ParamSpec("speed_max", 10.0, "Highest speed of the eigenvalue sweep, m/s.", (0.0, 1000.0)),
    ParamSpec("speed_count", 201, "Number of equally spaced speeds in the eigenvalue sweep.", (1, MAX_SPEED_COUNT)),
    ParamSpec(
        "ride_speed_step",
        0.1,
        "Smallest change of the riding speed that gives a new ride state space, m/s.",
        (0.0, 100.0),
    ),
    ParamSpec("ride_max_rate", 5.0, "Most ride state spaces published per second, 1/s.", (0.0, 1000.0), open_low=True),
)


class ModelNode(Node):
    """Parameter sets → canonical matrices, eigen sweep, state space (see the module docstring)."""

    def __init__(self) -> None:
        """Declare the parameters, create the publishers, the subscription and the service.

        Raises:
            NodeParameterError: A parameter is wrong, or the speeds are inconsistent.
        """
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PARAMETERS)
        rider = values["rider"]
        speed_min, speed_max, speed_count = values["speed_min"], values["speed_max"], values["speed_count"]
        try:
            if rider_key(rider) not in ("", "paper"):
                resolve_rider(rider)  # a rider file: read it now, so a bad one stops the node at start
        except BikeRigError as exc:
            raise parameter_error("rider", str(exc)) from None
        if rider == "none":
            rider = ""
        try:
            self._feedback = resolve_feedback(values["feedback"])
        except BikeRigError as exc:
            raise parameter_error("feedback", str(exc)) from None
        self._convention = SigmaConvention(values["sigma_convention"])
        if not speed_min <= speed_max:
            raise NodeParameterError(f"parameters 'speed_min' {speed_min} > 'speed_max' {speed_max}")
        if speed_count == 1 and speed_min != speed_max:
            raise NodeParameterError("parameter 'speed_count' is 1: set speed_min = speed_max")
        self._rider = str(rider)
        self._speeds = np.linspace(speed_min, speed_max, speed_count)

        self._parameter_set: ParameterSet | None = None
        self._models: dict[str, ModelMatrices] = {}
        self._ride_full: ParameterSet | None = None
        self._matrices_pub = self.create_publisher(
            _msgs.CanonicalMatrices, topics.MATRICES.name, profile(topics.MATRICES)
        )
        self._sweep_pub = self.create_publisher(_msgs.EigenSweep, topics.EIGEN_SWEEP.name, profile(topics.EIGEN_SWEEP))
        self._owners: OwnerFilter[Any] = OwnerFilter(self)
        self._foreign: dict[str, tuple[int, float]] = {}  # participant -> (sets ignored, when last said)
        self.create_subscription(
            _msgs.BenchmarkParameters, topics.PARAMETERS.name, self._on_parameters, profile(topics.PARAMETERS)
        )
        # while a set waits for discovery to name its process, look again (stopped otherwise)
        self._owner_timer = self.create_timer(RELOOK_S, self._release_sets)
        self._owner_timer.cancel()
        self.create_service(_srvs.StateSpace, topics.STATE_SPACE, self._on_state_space)

        self._ride_step = float(values["ride_speed_step"])
        self._ride_interval_s = 1.0 / float(values["ride_max_rate"])
        self._ride_speed: float | None = None  # the latest speed received, m/s
        self._ride_published: float | None = None  # the speed of the last published model
        self._ride_last_ns = -math.inf  # node-clock time of the last publication, ns
        self._ride_compute_ms = math.nan  # time the last one took to compute
        self._ride_count = 0  # ride state spaces published
        self._ride_speeds = 0  # speeds received
        self._ride_pub = self.create_publisher(
            _msgs.StateSpaceModel, topics.RIDE_STATE_SPACE.name, profile(topics.RIDE_STATE_SPACE)
        )
        self.create_subscription(_std.Float64, topics.RIDE_SPEED.name, self._on_speed, profile(topics.RIDE_SPEED))
        self.create_timer(self._ride_interval_s, self._publish_ride)
        self._models_published = 0
        self._last_model_ms = math.nan
        self._speed_at = -math.inf  # monotonic time of the latest speed
        self.diagnostics = DiagnosticsUpdater(self, self._health)
        self.get_logger().info(
            f"waiting for parameter sets on {topics.PARAMETERS.name}; rider '{self._rider}', "
            f"{'feedback ' + repr(self._feedback.name) + ', ' if self._feedback is not None else ''}"
            f"sigma {self._convention.value}, {self._speeds.size} speeds {self._speeds[0]:g}..{self._speeds[-1]:g} m/s"
        )

    def _on_parameters(self, msg: Any, info: Any) -> None:
        self.diagnostics.note_input(info)
        self._owners.offer(topics.PARAMETERS.name, info, msg)
        self._release_sets()

    def _release_sets(self) -> None:
        """Take the sets of the parameter node's process in order, ignore the others (see the module docstring)."""
        for r in self._owners.release():
            if r.owned:
                self._take_set(r.item)
            else:
                self._ignore_foreign(r)
        if self._owners.holding:
            if self._owner_timer.is_canceled():
                self._owner_timer.reset()
        elif not self._owner_timer.is_canceled():
            self._owner_timer.cancel()

    def _ignore_foreign(self, r: Released[Any]) -> None:
        """Say that a set from another process was ignored: the first of its process, then every FOREIGN_SAY_S."""
        count, said = self._foreign.get(r.source, (0, -math.inf))
        now = time.monotonic()
        count += 1
        if now - said >= FOREIGN_SAY_S:
            more = f" ({count} sets from that process ignored so far)" if count > 1 else ""
            self.get_logger().warning(
                f"{_which(r.item)} ignored: published by {r.publisher} in another process than the parameter "
                f"node's; parameter sets are taken only from the parameter node{more}"
            )
            said = now
        self._foreign[r.source] = (count, said)

    def _take_set(self, msg: Any) -> None:
        if not msg.complete:
            self.get_logger().info(f"{msg.bicycle}: parameter set incomplete (missing {', '.join(msg.missing)})")
            return
        started = time.perf_counter()
        try:
            ps = session_parameters_from_msg(msg, topics.PARAMETERS.name).complete_parameters()
            check(ps, _which(msg))
            matrices, stability = compute_model(
                ps, self._speeds, self._rider, self._convention, self._feedback, files=True
            )
        except ImplausibleParametersError as exc:
            kept = "" if self._parameter_set is None else f" (the model of '{self._parameter_set.bicycle}' stays)"
            self.get_logger().error(f"{exc}; refused, nothing published{kept}")
            return
        except BikeRigError as exc:
            self.get_logger().error(f"{msg.bicycle}: parameter set not usable: {exc}")
            return
        self._parameter_set = ps
        self._models = {self._rider: matrices}
        self._ride_full = None
        out_m = fill_canonical_matrices(_msgs.CanonicalMatrices(), matrices)
        out_s = fill_eigen_sweep(_msgs.EigenSweep(), stability)
        out_m.header.stamp = msg.header.stamp
        out_s.header.stamp = msg.header.stamp
        self._matrices_pub.publish(out_m)
        self._sweep_pub.publish(out_s)
        self._ride_published = None  # a new model: publish the ride state space again
        self._publish_ride()
        elapsed_ms = 1e3 * (time.perf_counter() - started)
        self._models_published += 1
        self._last_model_ms = elapsed_ms

        def speed(s: Any) -> str:
            return "none" if s is None else f"{s.speed:.4f} ± {s.sigma:.2g} m/s"

        self.get_logger().info(
            f"{ps.bicycle}{' + ' + self._rider + ' rider' if self._rider else ''}: model published in "
            f"{elapsed_ms:.1f} ms; weave {speed(stability.weave)}, capsize {speed(stability.capsize)}"
        )

    def _model(self, rider: str) -> ModelMatrices:
        """The matrices for ``rider`` ('' = none) from the current set, computed once per set."""
        assert self._parameter_set is not None
        if rider not in self._models:
            # only the node's own rider (a parameter) may be a file; a request names '', none or paper
            own = rider == self._rider
            matrices, _ = compute_model(self._parameter_set, self._speeds[:1], rider, self._convention, files=own)
            self._models[rider] = matrices
        return self._models[rider]

    def _on_state_space(self, request: Any, response: Any) -> Any:
        requested = str(request.rider)
        rider = self._rider if requested == "" else ("" if requested == "none" else requested)
        if self._parameter_set is None:
            return fill_state_space_error(
                response, f"no parameter set yet: waiting for a complete set on {topics.PARAMETERS.name}"
            )
        try:
            if rider != self._rider:
                rider_key(rider, files=False)
            state = state_space_at(self._model(rider), float(request.speed), self._feedback)
        except BikeRigError as exc:
            return fill_state_space_error(response, str(exc))
        label = f"{self._parameter_set.bicycle}" + (f" + {rider} rider" if rider else "")
        if self._feedback is not None:
            label += f", closed loop ({self._feedback.name})"
        return fill_state_space_response(response, state, f"{label} at {state.speed:g} m/s")

    def _on_speed(self, msg: Any, info: Any) -> None:
        self.diagnostics.note_input(info)
        try:
            self._ride_speed = ride_speed_from_msg(msg, topics.RIDE_SPEED.name)
        except BikeRigError as exc:
            self.get_logger().warning(str(exc), throttle_duration_sec=5.0)
            return
        self._speed_at = time.monotonic()
        if self._ride_speeds == 0:
            self.get_logger().info(
                f"first ride speed {self._ride_speed:g} m/s on {topics.RIDE_SPEED.name}"
                + ("" if self._parameter_set is not None else "; the state space follows the first parameter set")
            )
        self._ride_speeds += 1
        self._publish_ride()

    def _health(self) -> list[Any]:
        """The model's and the ride's statuses (:func:`bike_rig.pipeline.health.model_statuses`)."""
        ps = self._parameter_set
        speed = math.nan if self._ride_speed is None else self._ride_speed
        return model_statuses(
            ModelHealth(
                "" if ps is None else ps.bicycle,
                self._models_published,
                self._last_model_ms,
                speed,
                time.monotonic() - self._speed_at,
                self._ride_count,
                self._ride_compute_ms,
            )
        )

    def _publish_ride(self) -> None:
        """Publish the state space at the latest speed if it moved by more than the step and the rate allows."""
        v, last = self._ride_speed, self._ride_published
        if v is None or self._parameter_set is None:
            return
        if last is not None and abs(v - last) <= self._ride_step:
            return
        now = self.get_clock().now()
        if now.nanoseconds - self._ride_last_ns < 1e9 * self._ride_interval_s:
            return  # the timer publishes it when the interval is over
        started = time.perf_counter()
        try:
            if self._ride_full is None:  # (the set with the node's rider, seated once per set)
                self._ride_full = with_rider(self._parameter_set, self._rider, files=True)
            model = state_space_with_sigma_at(
                self._parameter_set, self._model(self._rider), v, self._feedback, full=self._ride_full
            )
        except BikeRigError as exc:
            self.get_logger().error(f"ride state space at {v:g} m/s: {exc}")
            self._ride_published = v
            return
        out = fill_state_space_model(_msgs.StateSpaceModel(), model)
        out.header.stamp = now.to_msg()  # the time the rate limit counts from
        self._ride_pub.publish(out)
        self._ride_published, self._ride_last_ns = v, now.nanoseconds
        self._ride_compute_ms = 1e3 * (time.perf_counter() - started)
        self._ride_count += 1


def _which(msg: Any) -> str:
    """A ``BenchmarkParameters`` in words: ``parameter set 'Rogue' (stamp 1700000000.000000001 s)``."""
    ns = stamp_ns(msg.header)
    return f"parameter set '{msg.bicycle}' (stamp {ns // 1_000_000_000}.{ns % 1_000_000_000:09d} s)"


def main(args: Sequence[str] | None = None) -> int:
    """Run the model node until SIGINT/SIGTERM (exit 2 on a bad parameter)."""
    return run_node(ModelNode, args, name="model")


if __name__ == "__main__":
    sys.exit(main())
