"""The fitter node: the fitting stage (:mod:`bike_rig.pipeline.fit`) on the live graph.

Buffers each trial's gyro batches between its START and STOP events
(:class:`~bike_rig.pipeline.fit_state.FitterState`), fits the period (paper Eq 23–27) on STOP and
publishes a ``PeriodEstimate`` — valid or not, with its flags and their reasons. Batches lost
on the way are asked for again from the driver (``/bike_rig/driver/resend_samples``).

Diagnostics (``/diagnostics``, 1 Hz): ``fitter: buffer`` (open trials, buffered samples against
the budget ``max_trial_samples · max_open_trials``, the process's memory) and ``fitter: fits``
(fits pending, estimates published, the time the last fit took, foreign batches dropped).
"""

from __future__ import annotations

import importlib
import math
import os
import sys
import time
from typing import TYPE_CHECKING, Any

from ... import messages
from ...config.settings import ParamSpec
from ...core.period import FitOptions, WindowKind, WindowPolicy
from ...pipeline.fit import TrialFit, TrialFitOptions
from ...pipeline.fit_details import FitDetails
from ...pipeline.fit_state import FitterState, ResendRequest
from ...pipeline.health import FitterHealth, fitter_statuses
from .publishers import publisher_source

if TYPE_CHECKING:
    from rclpy.node import Node

__all__ = ["FitterNode", "fitter_parameters", "main"]


def fitter_parameters() -> tuple[ParamSpec, ...]:
    """The fitter's parameters (``config/fitter.yaml``): limits, then the period fit's options."""
    d = TrialFitOptions()
    w = d.fit.window
    big = float(sys.float_info.max)
    return (
        ParamSpec(
            "max_trial_samples", d.max_trial_samples, "samples kept per trial; more are dropped, flagged", (1, 2**40)
        ),
        ParamSpec("max_batch_samples", d.max_batch_samples, "a larger gyro batch is rejected and flagged", (1, 2**31)),
        ParamSpec("max_open_trials", 4, "trials buffered at once (started but not stopped)", (1, 1000)),
        ParamSpec(
            "grace_s", 1.0, "how long a STOP waits for missing batches, and batches for their START, s", (0.0, 60.0)
        ),
        ParamSpec(
            "history_grace_s",
            10.0,
            "after matching, how long the transient-local history may take to arrive (nothing incomplete is "
            "fitted meanwhile), s",
            (0.0, 600.0),
        ),
        ParamSpec(
            "window",
            w.kind.value,
            "fit window policy: lead_in, span or envelope",
            choices=tuple(k.value for k in WindowKind),
        ),
        ParamSpec("lead_in_s", w.lead_in_s, "lead_in window: seconds dropped at the start", (0.0, big)),
        ParamSpec("span_start_s", w.start_s, "span window: first time kept, s from the first sample", (0.0, big)),
        ParamSpec("span_stop_s", 0.0, "span window: end, s from the first sample (0: to the end)", (0.0, big)),
        ParamSpec(
            "envelope_fraction", w.fraction, "envelope window: stop below this fraction of the peak", (1e-9, 1.0)
        ),
        ParamSpec("whole_cycles", w.whole_cycles, "shorten the window to whole cycles"),
        ParamSpec("min_cycles", d.fit.min_cycles, "flag a window with fewer cycles", (0.0, big)),
        ParamSpec("min_r2", d.fit.min_r2, "flag a fit with a lower r²", (-big, 1.0)),
        ParamSpec("max_modulation", d.fit.max_modulation, "flag beating above this relative modulation", (0.0, big)),
        ParamSpec(
            "max_drift", d.fit.max_drift, "flag an offset drift above this fraction of the oscillation", (0.0, big)
        ),
        ParamSpec(
            "small_swing_period",
            d.fit.small_swing_period,
            "a period that follows the swing: report the small-swing one (else the fitted)",
        ),
    )


class FitterNode:
    """The ROS adapter: parameters in, messages to :class:`FitterState`, estimates out.

    Subscribes (reliable, transient-local as in :mod:`bike_rig.config.topics`) to the gyro batches and
    trial events; publishes ``PeriodEstimate`` on the periods topic. Every callback catches
    everything: a bad message is logged and the node keeps running. ``self.node`` is the
    rclpy node (named ``fitter``).
    """

    def __init__(self) -> None:
        """Build the rclpy node, its subscriptions, publisher and timer.

        Raises:
            NodeParameterError: A node parameter is invalid.
        """
        from rclpy.node import Node

        from ...config.topics import FIT_DETAILS, GYRO, PERIODS, RESEND_SAMPLES, TRIAL_EVENTS
        from ..qos import profile

        # (bike_rig_msgs ships no type information: imported by name)
        msgs: Any = importlib.import_module("bike_rig_msgs.msg")
        GyroBatch, PeriodEstimate, TrialEvent = msgs.GyroBatch, msgs.PeriodEstimate, msgs.TrialEvent

        self.node: Node = Node("fitter")
        self._estimate_type = PeriodEstimate
        self._details_type = msgs.FitDetails
        options, grace, max_open, history_grace = self._parameters()
        self.state = FitterState(options, self.node.get_logger(), grace, max_open, history_grace_s=history_grace)
        # (events first: when both are ready, the executor takes them in creation order)
        self.events_sub = self.node.create_subscription(
            TrialEvent, TRIAL_EVENTS.name, self._on_event, profile(TRIAL_EVENTS)
        )
        self.gyro_sub = self.node.create_subscription(GyroBatch, GYRO.name, self._on_batch, profile(GYRO))
        self.periods_pub = self.node.create_publisher(PeriodEstimate, PERIODS.name, profile(PERIODS))
        self.details_pub = self.node.create_publisher(msgs.FitDetails, FIT_DETAILS.name, profile(FIT_DETAILS))
        srvs: Any = importlib.import_module("bike_rig_msgs.srv")
        self._resend_type = srvs.ResendSamples
        self.resend_client: Any = self.node.create_client(srvs.ResendSamples, RESEND_SAMPLES)
        self._live = False
        self.timer = self.node.create_timer(0.05, self._on_timer)
        self._budget = options.max_trial_samples * max_open
        self._last_fit_ms = math.nan
        from .diagnostics import DiagnosticsUpdater

        self.diagnostics = DiagnosticsUpdater(self.node, self._health)
        self.node.get_logger().info(f"fitting trials with {options.to_json()}")

    def _parameters(self) -> tuple[TrialFitOptions, float, int, float]:
        """Declare the fitter's parameters and read them (``config/fitter.yaml``).

        Returns:
            The fit options, ``grace_s`` (s), ``max_open_trials`` and ``history_grace_s`` (s).

        Raises:
            NodeParameterError: A parameter has the wrong type, is out of range, or the window
                settings are inconsistent.
        """
        from .settings import declare_parameters, parameter_error

        values = declare_parameters(self.node, fitter_parameters())
        try:
            window = WindowPolicy(
                kind=WindowKind(values["window"]),
                lead_in_s=values["lead_in_s"],
                start_s=values["span_start_s"],
                stop_s=values["span_stop_s"] or None,
                fraction=values["envelope_fraction"],
                whole_cycles=values["whole_cycles"],
            )
            options = TrialFitOptions(
                FitOptions(
                    window,
                    values["min_cycles"],
                    values["min_r2"],
                    values["max_modulation"],
                    values["max_drift"],
                    values["small_swing_period"],
                ),
                values["max_trial_samples"],
                values["max_batch_samples"],
            )
        except ValueError as exc:
            raise parameter_error("window", str(exc), values["window"]) from None
        return options, values["grace_s"], values["max_open_trials"], values["history_grace_s"]

    # ------------------------------------------------------------------ callbacks (never raise)
    def _on_batch(self, msg: Any, info: Any) -> None:
        self.diagnostics.note_input(info)
        try:
            batch = messages.sample_batch_from_msg(msg)
            started = time.perf_counter()
            self._publish(self.state.on_batch(batch, batch.stamp_ns, publisher_source(info)), started)
        except Exception as exc:  # a callback must never raise: log and keep serving
            self.node.get_logger().error(f"gyro batch of trial {getattr(msg, 'trial_id', '?')!r} failed: {exc!r}")

    def _on_event(self, msg: Any, info: Any) -> None:
        self.diagnostics.note_input(info)
        try:
            event = messages.trial_event_from_msg(msg)
        except messages.MessageError as exc:
            self.node.get_logger().warning(f"trial {getattr(msg, 'trial_id', '?')}: {exc}; ignored")
            return
        try:
            started = time.perf_counter()
            self._publish(self.state.on_event(event, publisher_source(info)), started)
        except Exception as exc:
            self.node.get_logger().error(f"trial event of trial {getattr(msg, 'trial_id', '?')!r} failed: {exc!r}")

    def _on_timer(self) -> None:
        try:
            live = self.gyro_sub.get_publisher_count() > 0 and self.events_sub.get_publisher_count() > 0
            if live and not self._live:
                self.state.matched_at = self.state.clock()
            self._live = live
            self.state.can_resend = self.resend_client.service_is_ready()
            started = time.perf_counter()
            self._publish(self.state.poll(live), started)
            for want in self.state.take_resend_requests():
                self._ask_again(want)
        except Exception as exc:
            self.node.get_logger().error(f"fitter timer failed: {exc!r}")

    def _ask_again(self, want: ResendRequest) -> None:
        """Send one resend request to the driver; its answer goes to :meth:`FitterState.on_resent`."""
        request = self._resend_type.Request()
        request.trial_id, request.first_index, request.count = want.trial_id, want.first_index, want.count
        future = self.resend_client.call_async(request)

        def answered(done: Any) -> None:
            try:
                reply = done.result()
                if reply is None:
                    return
                batches = [messages.sample_batch_from_msg(m) for m in reply.batches]
                started = time.perf_counter()
                results = self.state.on_resent(want.source, want.trial_id, reply.held, reply.complete, batches)
                self._publish(results, started)
            except Exception as exc:  # a callback must never raise
                self.node.get_logger().error(f"resend answer for trial {want.trial_id!r} failed: {exc!r}")

        future.add_done_callback(answered)

    def _health(self) -> list[Any]:
        """The buffer's and the fits' statuses (:func:`bike_rig.pipeline.health.fitter_statuses`)."""
        opened = list(self.state.open.values())
        return fitter_statuses(
            FitterHealth(
                len(opened),
                sum(o.stop is not None for o in opened),
                sum(o.acc.kept for o in opened),
                self._budget,
                _rss_bytes(),
                self.state.published,
                self._last_fit_ms,
                self.state.foreign_batches,
            )
        )

    def _publish(self, results: list[TrialFit], started: float | None = None) -> None:
        if results and started is not None:
            self._last_fit_ms = 1e3 * (time.perf_counter() - started)
        for r in results:  # (the details first: the console joins them to the estimate either way)
            self.details_pub.publish(messages.fill_fit_details(self._details_type(), FitDetails.of(r)))
            self.periods_pub.publish(self.estimate(r))

    def estimate(self, r: TrialFit) -> Any:
        """The PeriodEstimate message of a result."""
        return messages.fill_period_estimate(self._estimate_type(), r)


def _rss_bytes() -> int:
    """The process's resident memory, bytes (0 where ``/proc`` does not say)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def main(args: list[str] | None = None) -> int:
    """Run the fitter node (``--ros-args --params-file config/fitter.yaml`` and ``-p`` work)."""
    from .runner import run_node

    return run_node(lambda: FitterNode().node, args, name="fitter")


if __name__ == "__main__":
    sys.exit(main())
