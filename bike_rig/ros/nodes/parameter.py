"""The parameter node: static readings + live period estimates → the benchmark parameter set.

On start it loads the bicycle's static readings from a measurement file (bike_rig YAML or
BicycleParameters ``Measured.txt``; any periods in it are ignored), or starts with none at all
from the bicycle's name alone, and publishes them, latched, on ``/bike_rig/static_readings``.

Readings entered during the session arrive on ``/bike_rig/readings`` (``ReadingEntry``;
reliable, transient-local, so a restarted node gets every entry again). Each is applied on top
of the file's readings with :func:`bike_rig.pipeline.readings.apply_entries` (the newest entry
of a key wins: a correction replaces the reading, and both stay recorded); the merged readings
are re-published on ``/bike_rig/static_readings`` (``source`` says ``"<file> + N reading
entries"``, ``document`` is the merged readings as a ``bike_rig-measurements/1`` document) and
the parameters are evaluated again. An entry that cannot be used (unknown key, not a finite
number, negative σ, an impossible value, or hanging orientations that become parallel) is
logged as one warning line and ignored.

It subscribes to ``/bike_rig/periods`` (reliable, transient-local: a restarted node receives
the whole session's estimates again) and feeds every estimate to
:class:`bike_rig.pipeline.assemble.SessionAssembly` (with ``partial`` readings), which dedupes
by trial id and combines the valid, unflagged trials of each measurement key. A period of a
hanging orientation whose readings are not entered yet is kept until they are. The fitter's
``FitDetails`` (``/bike_rig/fit_details``; e.g. a small-swing systematic the key's trials share)
go to the same assembly, which joins them to their trial's estimate whichever comes first.

On ``/bike_rig/parameters`` (reliable, transient-local, depth 1) it publishes:

* the complete parameter set (values, σ, covariance, provenance) as soon as every period is
  there, and again whenever the combined periods change (a better trial arrived);
* while incomplete, a set with ``complete = false`` and ``missing`` listing what is still to
  measure (the static readings still to enter, then the periods still to measure; see
  :func:`bike_rig.pipeline.assemble.required_readings`: the hanging orientations are those
  known so far from the readings and trials, at least three), whenever that changes and every
  ``status_period`` s, and logs it.

Parameters that are not physically possible (:func:`bike_rig.core.parameter_checks.compute_checked`:
a negative inertia, a tensor that is not positive definite...) are never published: the node
logs one error line naming the result and the readings it came from. A static reading of the
file that a wrong unit explains (a wheelbase in mm) is logged as a warning line
(:mod:`bike_rig.core.reading_ranges`).

Diagnostics (``/diagnostics``, 1 Hz): ``parameter: completeness`` and, from the first estimate or
entry handled, ``parameter: input lag`` (WARN while it handles them seconds after they were sent).

An estimate or entry that arrives after a quiet spell is evaluated at once; those that follow
within ``EVALUATE_PERIOD_S`` of an evaluation are evaluated together at the end of that spell (a
burst, such as a restarted node catching up on a session, gives few evaluations).

Parameters (``config/parameter.yaml``, node name ``parameter``):

* ``measurements`` (string): the measurement file; a relative path that does not exist from
  the working directory is looked up under the config folder (``bicycles/browser.yaml``).
  Empty: no file, ``bicycle`` names the bicycle and every reading is entered.
* ``bicycle`` (string): the bicycle's name, to start without a measurement file; with a file
  it must be empty or the file's bicycle. One of ``measurements`` and ``bicycle`` is required.
* ``com_method`` (string): mass-centre method, ``centroid`` (default, the paper's) or ``lstsq``.
* ``status_period`` (double, s): how often an incomplete state is re-published and logged;
  default 5.0.

A bad measurement file or parameter ends the process with one error line, exit status 2.
Run: ``python -m bike_rig.ros.nodes.parameter --ros-args -p measurements:=bicycles/browser.yaml``,
or ``-p bicycle:=Browser`` to enter every reading during the session.
"""

from __future__ import annotations

import importlib
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rclpy.node import Node

from ...config import topics
from ...config.paths import config_file
from ...config.settings import ParamSpec
from ...core.benchmark import ComMethod
from ...core.errors import BikeRigError
from ...core.io_yaml import dump_measurements_yaml
from ...core.loader import load_static_readings
from ...core.measurements import Measurements
from ...core.reading_ranges import UnitMistakeWarning
from ...messages import (
    MessageError,
    fill_benchmark_parameters,
    fill_static_readings,
    fit_details_from_msg,
    reading_entry_from_msg,
    trial_fit_from_msg,
)
from ...pipeline.assemble import KeyPeriod, SessionAssembly, SessionParameters
from ...pipeline.errors import AssemblyError
from ...pipeline.health import ParameterHealth, parameter_statuses
from ...pipeline.readings import ReadingEntry, apply_entries
from ..qos import profile
from .diagnostics import DiagnosticsUpdater
from .runner import run_node
from .settings import NodeParameterError, declare_parameters

__all__ = [
    "EVALUATE_PERIOD_S",
    "NODE_NAME",
    "PARAMETERS",
    "ParameterNode",
    "base_readings",
    "main",
    "resolve_measurements",
]

NODE_NAME = "parameter"
#: Estimates are evaluated at most this often, s (later ones of a burst together).
EVALUATE_PERIOD_S = 0.05

_msgs: Any = importlib.import_module("bike_rig_msgs.msg")

#: The parameter node's parameters (``config/parameter.yaml``).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "measurements",
        "",
        "Measurement file with the bicycle's static readings (bike_rig YAML or BicycleParameters "
        "Measured.txt); periods in it are ignored. Relative paths are also looked up in the config folder. "
        "Empty: no file (give 'bicycle'); readings entered on /bike_rig/readings are applied on top.",
    ),
    ParamSpec(
        "bicycle",
        "",
        "The bicycle's name, to start without a measurement file: every static reading is then entered "
        "on /bike_rig/readings. With a file: empty, or the file's bicycle.",
    ),
    ParamSpec(
        "com_method",
        ComMethod.CENTROID.value,
        "Mass-centre method: 'centroid' (paper Eq 17-19) or 'lstsq' (Eq 20).",
        choices=tuple(m.value for m in ComMethod),
    ),
    ParamSpec(
        "status_period", 5.0, "While incomplete, re-publish and log the missing periods this often, s.", (0.5, 3600.0)
    ),
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


def base_readings(measurements: str, bicycle: str) -> tuple[Measurements, str]:
    """The static readings to start from, and their document, from the node's parameters.

    Args:
        measurements: The ``measurements`` parameter (a file, or empty).
        bicycle: The ``bicycle`` parameter (a name, or empty).

    Returns:
        The file's static readings and its text; without a file, no readings for ``bicycle``
        (path "") and their (empty) ``bike_rig-measurements/1`` document.

    Raises:
        NodeParameterError: Both are empty, or the file's bicycle is not ``bicycle``.
        BikeRigError: The measurement file cannot be read.
    """
    name = bicycle.strip()
    if not measurements.strip():
        if not name:
            raise NodeParameterError(
                "give parameter 'measurements' (the bicycle's measurement file, e.g. "
                "-p measurements:=bicycles/browser.yaml) or 'bicycle' (its name, to enter every reading "
                "during the session, e.g. -p bicycle:=Browser)"
            )
        static = Measurements(name, {}, "")
        return static, dump_measurements_yaml(static)
    path = resolve_measurements(measurements)
    static = load_static_readings(path)
    if name and name != static.bicycle:
        raise NodeParameterError(
            f"parameter 'bicycle' = {name!r}: the measurement file {path} is of {static.bicycle!r} "
            "(leave 'bicycle' empty, or give measurements:='' to start without a file)"
        )
    return static, path.read_text(encoding="utf-8", errors="replace")


def _provenance(periods: Sequence[KeyPeriod]) -> tuple[tuple[str, float, float, tuple[str, ...]], ...]:
    return tuple((p.key, p.value, p.sigma, p.trial_ids) for p in periods)


class ParameterNode(Node):
    """Static readings + period estimates → BenchmarkParameters (see the module docstring)."""

    def __init__(self) -> None:
        """Declare the parameters, load the static readings and publish them, subscribe.

        Raises:
            NodeParameterError: A parameter is wrong, or neither ``measurements`` nor ``bicycle`` is given.
            BikeRigError: The measurement file cannot be read.
        """
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PARAMETERS)
        method = ComMethod(values["com_method"])
        status_period = values["status_period"]
        with warnings.catch_warnings(record=True) as caught:  # a reading a wrong unit explains: logged
            warnings.simplefilter("always", UnitMistakeWarning)
            self._base, self._document = base_readings(values["measurements"], values["bicycle"])
        for w in caught:
            self.get_logger().warning(str(w.message))
        self._entries: list[ReadingEntry] = []
        self._session = SessionAssembly(self._base, method, origin=topics.PERIODS.name, partial=True)

        self._static_pub = self.create_publisher(
            _msgs.StaticReadings, topics.STATIC_READINGS.name, profile(topics.STATIC_READINGS)
        )
        self._params_pub = self.create_publisher(
            _msgs.BenchmarkParameters, topics.PARAMETERS.name, profile(topics.PARAMETERS)
        )
        self._static_version = 0
        self._static_dirty = True
        self._dirty = False
        self._last_evaluation = -float("inf")
        self._published: tuple[Any, ...] | None = None
        self._complete = False
        self._status_period = float(status_period)
        self._last: SessionParameters | None = None
        self._error = ""
        self.create_subscription(_msgs.PeriodEstimate, topics.PERIODS.name, self._on_period, profile(topics.PERIODS))
        self.create_subscription(
            _msgs.FitDetails, topics.FIT_DETAILS.name, self._on_details, profile(topics.FIT_DETAILS)
        )
        self.create_subscription(_msgs.ReadingEntry, topics.READINGS.name, self._on_entry, profile(topics.READINGS))
        self.create_timer(EVALUATE_PERIOD_S, self._evaluate)
        self.create_timer(self._status_period, self._status)
        self.diagnostics = DiagnosticsUpdater(self, self._health)
        source = f"static readings from {self._base.path}" if self._base.path else "no static readings yet"
        self.get_logger().info(
            f"{self._base.bicycle}: {source} (entries on {topics.READINGS.name} are applied on top); waiting for "
            f"periods {', '.join(self._session.required_keys)} on {topics.PERIODS.name} (com method {method.value})"
        )
        self._evaluate(force=True)

    def _on_period(self, msg: Any, info: Any) -> None:
        self.diagnostics.note_input(info)
        try:
            self._dirty |= self._session.add(trial_fit_from_msg(msg))
        except (AssemblyError, MessageError) as exc:
            self.get_logger().warning(f"period estimate ignored: {exc}")
        self._soon()

    def _on_details(self, msg: Any, info: Any) -> None:
        """Hand a trial's fit details to the assembly, which joins them to its estimate."""
        self.diagnostics.note_input(info)
        try:
            details = fit_details_from_msg(msg)
        except MessageError as exc:
            self.get_logger().warning(f"fit details ignored: {exc}")
            return
        if self._session.add_details(details):
            self._dirty = True
            self._soon()

    def _on_entry(self, msg: Any, info: Any) -> None:
        """Apply one entered reading on top of the file's (a bad one: one warning line, ignored)."""
        self.diagnostics.note_input(info)
        entry = reading_entry_from_msg(msg)
        if entry in self._entries:  # the same entry delivered again
            return
        try:
            self._session.set_static(apply_entries(self._base, [*self._entries, entry]))
        except BikeRigError as exc:
            self.get_logger().warning(f"reading entry ignored: {exc}")
            return
        self._entries.append(entry)
        self._static_version += 1
        self._static_dirty = self._dirty = True
        self._soon()

    def _soon(self) -> None:
        """Evaluate now after a quiet spell; otherwise the timer does at the end of the spell."""
        if time.monotonic() - self._last_evaluation >= EVALUATE_PERIOD_S:
            self._evaluate()

    def _publish_static(self) -> None:
        """Publish the current static readings (latched): the file's, or merged with the entries."""
        static = self._session.static
        document = dump_measurements_yaml(static) if self._entries else self._document
        msg = fill_static_readings(_msgs.StaticReadings(), static, document)
        msg.source = static.path or "no static readings yet"
        msg.header.stamp = self.get_clock().now().to_msg()
        self._static_pub.publish(msg)
        self._static_dirty = False
        if self._entries:
            self.get_logger().info(
                f"{static.bicycle}: {len(static.readings)} static readings ({static.path}) published on "
                f"{topics.STATIC_READINGS.name}"
            )

    def _evaluate(self, force: bool = False) -> None:
        if self._static_dirty:
            self._publish_static()
        if not (self._dirty or force):
            return
        self._dirty = False
        self._last_evaluation = time.monotonic()
        periods = self._session.periods()
        key = (self._static_version, _provenance(periods))
        if key == self._published and not force:
            return
        try:
            result = self._session.result()
        except BikeRigError as exc:
            self.get_logger().error(f"cannot compute the parameters: {exc}")
            self._error = str(exc)
            return
        self._error = ""
        self._last = result
        self._published = key
        self._complete = result.complete
        self._publish(result)

    def _health(self) -> list[Any]:
        """The completeness status (:func:`bike_rig.pipeline.health.parameter_statuses`)."""
        r = self._last
        return parameter_statuses(
            ParameterHealth(
                self._base.bicycle,
                r is not None,
                bool(r is not None and r.complete),
                0 if r is None else len(r.periods),
                len(self._session.required_keys),
                () if r is None else tuple(r.missing_periods),
                () if r is None else tuple(r.missing_readings),
                self._error,
            )
        )

    def _status(self) -> None:
        if self._published is not None and not self._complete:
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
            readings = result.missing_readings
            entered = f"; readings to enter: {', '.join(readings)}" if readings else ""
            self.get_logger().info(
                f"{result.bicycle}: incomplete, {len(result.periods)} of {len(self._session.required_keys)} periods; "
                f"missing {', '.join(result.missing_periods) or 'no period'}{entered}"
            )


def main(args: Sequence[str] | None = None) -> int:
    """Run the parameter node until SIGINT/SIGTERM (exit 2 on a bad measurement file)."""
    return run_node(ParameterNode, args, name="parameter")


if __name__ == "__main__":
    sys.exit(main())
