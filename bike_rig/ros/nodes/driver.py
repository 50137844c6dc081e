"""The driver node: reads the rate gyro through one gyro source and publishes its trials.

Parameter ``source`` chooses the backend (:mod:`bike_rig.sources`): ``sim`` (the simulated rig
walking a session plan, or with ``mode`` ``operator`` simulating each requested trial), ``can``
(a CAN gyro, python-can), ``bag`` (a recorded session replayed) or ``daq`` (NI-DAQmx). The
driver declares its own parameters (:data:`COMMON_PARAMETERS`) and every backend's (each
backend class's ``PARAMETERS``), all read-only with a description and range
(:mod:`bike_rig.ros.nodes.settings`); they can come from ``config/driver.yaml``
(``--ros-args --params-file``).

Published (reliable, transient-local, :mod:`bike_rig.config.topics`):

* ``/bike_rig/trial_events`` (TrialEvent): START before a trial's first batch (stamped with its
  first sample's rig time), STOP (or ABORT) after its last with ``sample_count``;
* ``/bike_rig/gyro`` (GyroBatch): ``samples_per_batch`` samples each at real time, times the
  time scale rounded up for a faster source (:func:`~bike_rig.pipeline.resend.batch_samples`:
  the messages per wall second stay those of real time); the last of a trial may be shorter;
  ``first_index`` their index in the trial, stamped with the rig time of their first sample,
  ``trial start + first_index / rate``.

Services: ``/bike_rig/driver/resend_samples`` (ResendSamples) answers a subscriber that lost
batches with the batches it sent (the last ``history_samples`` samples,
:class:`~bike_rig.pipeline.resend.SentBatches`). ``/bike_rig/driver/start_trial`` (StartTrial)
and ``/bike_rig/driver/stop_trial`` (StopTrial) are honoured by the hardware backends and the
sim backend in ``operator`` mode (the plan-walking sim and the bag decline). StartTrial answers
``accepted`` with the trial's id, or not with the source's one-line reason (the same request
again while its trial records gets the same answer: a resent request is no new trial); the
trial's START is published before the answer when the source has it at once (the simulated rig).
A trial that records (from its request, or its START) and gets no samples for
``silence_warning_s`` of wall time is logged as a warning once per silence, naming the source
and what to check (the bus, the wiring, the CAN id...). When a plan is finished the driver logs
it and keeps running, so that late joiners still get the topics' history — or exits
(``exit_when_done``, after the subscribers have acknowledged everything, up to 120 s, and no
resend was asked for in 3 s). With ``resume`` (an interrupted session's bag) the bag's recorded
trials are published first, unpaced, and the session continues with the source
(:mod:`bike_rig.sources.resume`).

Diagnostics (``/diagnostics``, 1 Hz): ``driver: source`` (read errors), ``driver: samples`` (the
sample rate over the last 2 s of wall time against the recording trial's rate times
``time_scale``, the time since the last sample — WARN from ``silence_warning_s``, ERROR from 3
times it —, samples late — WARN when the trial's samples are ``silence_warning_s`` or more
behind its rate since its START —, samples missing) and ``driver: gyro range`` (samples at or beyond
``gyro_range_rad_s``).
"""

from __future__ import annotations

import importlib
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node

from ...config.settings import ParamSpec, merge_specs
from ...config.topics import GYRO, RESEND_SAMPLES, START_TRIAL, STOP_TRIAL, TRIAL_EVENTS
from ...messages import fill_gyro_batch
from ...messages.fields import fill_fields, set_stamp
from ...pipeline.acquire import SampleBatch, sample_stamp_ns
from ...pipeline.diagnostics import RateMeter
from ...pipeline.health import DriverHealth, driver_statuses
from ...pipeline.resend import DEFAULT_HISTORY_SAMPLES, SentBatches, batch_samples, history_depth
from ...sources import (
    BACKENDS,
    GyroSource,
    SampleBlock,
    SourceEvent,
    TrialInfo,
    TrialRequest,
    TrialRequestError,
    TrialStarted,
    TrialStopped,
    backend_parameters,
    open_source,
)
from ...sources.base import FloatArray
from ...sources.errors import SourceError
from ...sources.resume import DEFAULT_RESUME_TIME_SCALE, ResumedSource
from ...sources.silence import DEFAULT_SILENCE_S, SilenceWatch
from ..qos import profile
from .diagnostics import DiagnosticsUpdater
from .settings import declare_parameters

__all__ = ["COMMON_PARAMETERS", "DriverNode", "driver_parameters", "main"]

# bike_rig_msgs ships no type information: imported by name
_msgs: Any = importlib.import_module("bike_rig_msgs.msg")
_srvs: Any = importlib.import_module("bike_rig_msgs.srv")

NODE_NAME = "driver"
#: Longest wait for the subscribers' acknowledgements before exiting (``exit_when_done``): a
#: subscriber far behind on a loaded machine, or stalled, still gets everything, s.
ACK_TIMEOUT_S = 120.0
#: Before exiting, how long the driver still answers resend requests: until everything is
#: acknowledged and this long after the plan's end and the last request (a subscriber that
#: lost batches asks within its ``grace_s``), s.
LINGER_S = 3.0

#: The driver's own parameters; each backend's follow (:func:`driver_parameters`).
COMMON_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("source", "sim", "gyro source backend", choices=tuple(BACKENDS)),
    ParamSpec("frame_id", "gyro", "frame_id of the gyro batches"),
    ParamSpec(
        "samples_per_batch",
        50,
        "samples per GyroBatch at real time, times the time scale rounded up for a "
        "faster sim or bag (at most 10,000; the last of a trial may hold fewer)",
        (1, 10_000),
    ),
    ParamSpec(
        "history_samples",
        DEFAULT_HISTORY_SAMPLES,
        "samples kept for late joiners (the gyro topic's "
        "transient-local history) and to resend to a subscriber that lost batches",
        (1, 2**40),
    ),
    ParamSpec("poll_period_s", 0.01, "how often the source is read, s (wall clock)", (0.001, 1.0)),
    ParamSpec("exit_when_done", False, "exit when the sim/bag plan is finished (else keep running)"),
    ParamSpec(
        "wait_for_subscribers",
        0,
        "start streaming once the gyro and trial-event topics each have this many subscribers",
        (0, 100),
    ),
    ParamSpec(
        "resume",
        "",
        "an interrupted session's bag: its recorded trials are streamed first, and new trial ids "
        "continue after them (bike-rig session --resume)",
    ),
    ParamSpec(
        "resume_time_scale",
        DEFAULT_RESUME_TIME_SCALE,
        "how fast the recorded trials of 'resume' are streamed, rig seconds per wall second",
        (1.0, 10_000.0),
    ),
    ParamSpec(
        "silence_warning_s",
        DEFAULT_SILENCE_S,
        "warn when a recording trial has had no samples this long, s (wall clock)",
        (0.05, 60.0),
    ),
    ParamSpec(
        "gyro_range_rad_s",
        0.0,
        "the gyro's measuring range, rad/s: samples at or beyond it count as clipped on /diagnostics (0: not checked)",
        (0.0, 1e6),
    ),
)


def driver_parameters() -> tuple[ParamSpec, ...]:
    """Every parameter the driver declares: its own, then every registered backend's.

    Whichever backend ``source`` chooses, all are declared, so that one parameter file serves
    every backend and ``ros2 param describe`` documents them all.
    """
    return merge_specs(COMMON_PARAMETERS, backend_parameters())


_EMPTY = np.empty(0, dtype=np.float64)


@dataclass
class _Trial:
    """A trial being published: its batching state."""

    info: TrialInfo
    start_ns: int
    published: int = 0
    rates: list[FloatArray] = field(default_factory=list)
    volts: list[FloatArray | None] = field(default_factory=list)
    first: int = 0
    buffered: int = 0
    missing: int = 0
    started_s: float = field(default_factory=time.monotonic)  # wall time the START was handled


class DriverNode(Node):
    """The driver (see the module docstring); ``finished`` turns true to end the process."""

    def __init__(self) -> None:
        """Declare the parameters, open the source, create the topics, services and timer.

        Raises:
            NodeParameterError: A driver parameter is wrong.
            SourceConfigError: A backend parameter is wrong, or the source cannot be opened.
        """
        super().__init__(NODE_NAME)
        self.values = declare_parameters(self, driver_parameters())
        self._time_scale = float(self.values["time_scale"]) if self.values["source"] in ("sim", "bag") else 1.0
        self.batch_size = batch_samples(int(self.values["samples_per_batch"]), self._time_scale)
        self.sent = SentBatches(int(self.values["history_samples"]))
        self.frame_id = str(self.values["frame_id"])
        self.exit_when_done = bool(self.values["exit_when_done"])
        self.wait_for = int(self.values["wait_for_subscribers"])
        self.source: GyroSource = open_source(self.values["source"], self.values)
        if self.values["resume"]:
            scale = float(self.values["resume_time_scale"])
            self.source = ResumedSource(str(self.values["resume"]), self.source, scale)
        # (the transient-local history holds history_samples samples, whatever the batch size)
        depth = history_depth(int(self.values["history_samples"]), self.batch_size)
        self.gyro_pub = self.create_publisher(_msgs.GyroBatch, GYRO.name, profile(replace(GYRO.qos, depth=depth)))
        self.events_pub = self.create_publisher(_msgs.TrialEvent, TRIAL_EVENTS.name, profile(TRIAL_EVENTS))
        self.start_srv = self.create_service(_srvs.StartTrial, START_TRIAL, self._on_start_trial)
        self.stop_srv = self.create_service(_srvs.StopTrial, STOP_TRIAL, self._on_stop_trial)
        self.resend_srv = self.create_service(_srvs.ResendSamples, RESEND_SAMPLES, self._on_resend)
        self.finished = False
        self._exit_at: float | None = None  # (exit_when_done: when to exit, monotonic s)
        self._done_at = 0.0
        self._trials: dict[str, _Trial] = {}
        self._last_start: tuple[TrialRequest, str, str] | None = None  # (request, trial id, message) until its STOP
        self._streaming = self.wait_for == 0
        self._done_logged = False
        self._errors = 0
        self.silence = SilenceWatch(float(self.values["silence_warning_s"]))
        self.trials_published = 0
        self.samples_published = 0
        self.timer = self.create_timer(float(self.values["poll_period_s"]), self._on_timer)
        self._rate = RateMeter()
        self._range = float(self.values["gyro_range_rad_s"])
        self.samples_missing = 0
        self.clipped = 0
        self.diagnostics = DiagnosticsUpdater(self, self._health)
        waiting = f"; waiting for {self.wait_for} gyro subscriber(s)" if self.wait_for else ""
        self.get_logger().info(f"driver ready: {self.source.describe()}{waiting}")
        self._log_notices()

    # ------------------------------------------------------------------ timer
    def _on_timer(self) -> None:
        try:
            if not self._streaming:
                # (both topics: a START sent before a reader matched reaches it only at the next heartbeat)
                matched = min(self.gyro_pub.get_subscription_count(), self.events_pub.get_subscription_count())
                if matched < self.wait_for:
                    return
                self._streaming = True
                self.get_logger().info(f"{self.gyro_pub.get_subscription_count()} gyro subscriber(s): streaming")
            self._poll_source()
            self._warn_silent()
            if self.source.finished and not self._done_logged:
                self._done_logged = True
                self.get_logger().info(
                    f"plan finished: {self.trials_published} trials, {self.samples_published} samples published"
                    + ("; exiting" if self.exit_when_done else "; still serving the topics' history")
                )
                if self.exit_when_done:
                    self._done_at = time.monotonic()
                    self._exit_at = self._done_at + LINGER_S
            if self._exit_at is not None:
                self._exit_when_acknowledged()
        except SourceError as exc:
            self._errors += 1
            if self._errors in (1, 10, 100) or self._errors % 1000 == 0:
                self.get_logger().error(f"{exc} (error {self._errors})")
        except Exception as exc:  # a callback must never raise: log and keep running
            self._errors += 1
            if self._errors in (1, 10, 100) or self._errors % 1000 == 0:
                self.get_logger().error(f"reading the {self.source.name} source failed: {exc!r}")

    def _poll_source(self) -> None:
        """Publish what the source has, and log what it noticed doing so (a log file read whole at once)."""
        self._publish_events(self.source.poll())
        self._log_notices()

    def _log_notices(self) -> None:
        for warning, text in self.source.notices():
            (self.get_logger().warning if warning else self.get_logger().info)(text)

    def _warn_silent(self) -> None:
        for silence in self.silence.due():
            what = "no samples" if silence.any_samples else "no samples yet"
            self.get_logger().warning(
                f"trial {silence.trial_id}: {what} from the {self.source.name} gyro for {silence.seconds:.1f} s — "
                f"{self.source.silence_hint()}"
            )

    def _health(self) -> list[Any]:
        """Source, samples and gyro-range statuses (:func:`bike_rig.pipeline.health.driver_statuses`)."""
        expected = sum(t.info.sample_rate_hz for t in self._trials.values()) * self._time_scale
        # while a trial records: since its request, START or last samples; else since any sample
        since = self.silence.longest() if self.silence.watched else self._rate.age()
        now = time.monotonic()
        behind = max(
            (
                now - t.started_s - (t.published + t.buffered + t.missing) / (t.info.sample_rate_hz * self._time_scale)
                for t in self._trials.values()
            ),
            default=0.0,
        )
        return driver_statuses(
            DriverHealth(
                self.source.describe(),
                self._errors,
                self.silence.watched,
                expected if self._trials else float("nan"),
                self._rate.rate(),
                since,
                self.silence.limit_s,
                self.samples_published,
                self.samples_missing,
                self.clipped,
                self._range,
                max(behind, 0.0),
            )
        )

    def _exit_when_acknowledged(self) -> None:
        """End the process once every subscriber has everything, serving resend requests meanwhile.

        Checked on each timer tick without blocking, so the resend service keeps answering; at
        most :data:`ACK_TIMEOUT_S` after the plan's end.
        """
        assert self._exit_at is not None
        now = time.monotonic()
        if now < self._exit_at:
            return
        waiting = [
            p.topic_name
            for p in (self.events_pub, self.gyro_pub)
            if p.get_subscription_count() and not p.wait_for_all_acked(Duration(nanoseconds=1))
        ]
        if waiting and now - self._done_at < ACK_TIMEOUT_S:
            return
        for topic in waiting:
            self.get_logger().warning(f"{topic}: unacknowledged after {ACK_TIMEOUT_S:g} s")
        self.finished = True

    def _wait_for_acks(self, timeout_s: float = ACK_TIMEOUT_S) -> None:
        timeout = Duration(seconds=timeout_s)
        for pub in (self.events_pub, self.gyro_pub):
            if pub.get_subscription_count() and not pub.wait_for_all_acked(timeout):
                self.get_logger().warning(f"{pub.topic_name}: unacknowledged after {timeout_s} s")

    # ------------------------------------------------------------------ publishing
    def _publish_events(self, events: list[SourceEvent]) -> None:
        for ev in events:
            if isinstance(ev, SampleBlock):
                self._on_block(ev)
            elif isinstance(ev, TrialStarted):
                self._on_started(ev)
            elif isinstance(ev, TrialStopped):
                self._on_stopped(ev)

    def _event(self, info: TrialInfo, kind: int, stamp_ns: int, sample_count: int = 0) -> Any:
        msg = _msgs.TrialEvent()
        fill_fields(msg, info)
        set_stamp(msg, stamp_ns)
        msg.header.frame_id = self.frame_id
        msg.kind = kind
        msg.sample_count = sample_count
        return msg

    def _on_started(self, ev: TrialStarted) -> None:
        if ev.info.trial_id in self._trials:
            self.get_logger().warning(f"trial {ev.info.trial_id} started twice; the second START is ignored")
            return
        if not self._trials:
            self._rate.restart()  # the rate of this trial, not of the idle time before it
        self._trials[ev.info.trial_id] = _Trial(ev.info, ev.stamp_ns)
        self.silence.started(ev.info.trial_id)
        self.events_pub.publish(self._event(ev.info, _msgs.TrialEvent.START, ev.stamp_ns))
        self.get_logger().info(f"trial {ev.info.trial_id} ({ev.info.measurement_key}) started")

    def _on_block(self, block: SampleBlock) -> None:
        t = self._trials.get(block.trial_id)
        if t is None:
            self.get_logger().warning(f"samples of trial {block.trial_id!r}, which has not started, dropped")
            return
        if block.rates.size:
            self.silence.samples(block.trial_id)
            self._rate.add(block.rates.size)
            if self._range > 0:
                self.clipped += int(np.count_nonzero(np.abs(block.rates) >= self._range))
        gap = block.first_index - (t.first + t.buffered)
        if gap > 0:
            t.missing += gap
            self.samples_missing += gap
        if t.buffered and block.first_index != t.first + t.buffered:
            self._flush(t)  # a gap: the next batch starts at the block's own index
        if not t.buffered:
            t.first = block.first_index
        t.rates.append(block.rates)
        t.volts.append(block.raw_volts)
        t.buffered += block.rates.size
        if t.buffered >= self.batch_size:
            rates = np.concatenate(t.rates)
            volts = None if any(v is None for v in t.volts) else np.concatenate([v for v in t.volts if v is not None])
            full = (t.buffered // self.batch_size) * self.batch_size
            for a in range(0, full, self.batch_size):
                self._publish_batch(
                    t,
                    t.first + a,
                    rates[a : a + self.batch_size],
                    None if volts is None else volts[a : a + self.batch_size],
                )
            t.rates = [rates[full:]] if full < rates.size else []
            t.volts = [None if volts is None else volts[full:]] if full < rates.size else []
            t.first += full
            t.buffered -= full

    def _flush(self, t: _Trial) -> None:
        if not t.buffered:
            return
        rates = np.concatenate(t.rates)
        volts = None if any(v is None for v in t.volts) else np.concatenate([v for v in t.volts if v is not None])
        self._publish_batch(t, t.first, rates, volts)
        t.rates, t.volts, t.first, t.buffered = [], [], t.first + t.buffered, 0

    def _publish_batch(self, t: _Trial, first: int, rates: FloatArray, volts: FloatArray | None) -> None:
        batch = SampleBatch(
            t.info.trial_id,
            first,
            float(t.info.sample_rate_hz),
            np.ascontiguousarray(rates, dtype=np.float64),
            _EMPTY if volts is None else np.ascontiguousarray(volts, dtype=np.float64),
            sample_stamp_ns(t.start_ns, first, t.info.sample_rate_hz),
            self.frame_id,
        )
        self.gyro_pub.publish(fill_gyro_batch(_msgs.GyroBatch(), batch))
        self.sent.add(batch)
        t.published += rates.size
        self.samples_published += rates.size

    def _on_stopped(self, ev: TrialStopped) -> None:
        self.silence.stopped(ev.trial_id)
        if self._last_start is not None and self._last_start[1] == ev.trial_id:
            self._last_start = None
        t = self._trials.pop(ev.trial_id, None)
        if t is None:
            self.get_logger().warning(f"STOP of trial {ev.trial_id!r}, which has not started, dropped")
            return
        self._flush(t)
        kind = _msgs.TrialEvent.ABORT if ev.aborted else _msgs.TrialEvent.STOP
        self.events_pub.publish(self._event(t.info, kind, ev.stamp_ns, ev.sample_count))
        self.trials_published += 1
        how = "aborted" if ev.aborted else "stopped"
        self.get_logger().info(f"trial {ev.trial_id} {how}: {t.published} samples published")
        unaccounted = ev.sample_count - t.published - t.missing
        if unaccounted > 0:
            self.samples_missing += unaccounted
        if t.published != ev.sample_count:
            self.get_logger().warning(
                f"trial {ev.trial_id}: {t.published} samples published, the source reports {ev.sample_count}"
            )

    # ------------------------------------------------------------------ services
    def _on_start_trial(self, request: Any, response: Any) -> Any:
        """Start the requested trial; the same request again while its trial records gets the same answer.

        (A client resends a request whose answer DDS dropped, which it does while the response
        path is still being matched: its trial is not refused as "already recording".)
        """
        try:
            wanted = TrialRequest(
                part=request.part,
                pendulum=request.pendulum,
                orientation=int(request.orientation),
                repeat=int(request.repeat),
                measurement_key=request.measurement_key,
                duration_s=float(request.duration_s),
                note=request.note,
            )
            if self._last_start is not None and self._last_start[0] == wanted:
                _, response.trial_id, message = self._last_start
                response.accepted, response.message = True, f"{message} (the same request again)"
                self.get_logger().info(response.message)
                return response
            info = self.source.start_trial(wanted)
            response.accepted, response.trial_id = True, info.trial_id
            response.message = f"recording trial {info.trial_id} ({info.measurement_key}), {self._duration(request)}"
            self._last_start = (wanted, info.trial_id, response.message)  # (before its events: a STOP clears it)
            self.silence.started(info.trial_id)
            if self._streaming:
                self._poll_source()  # the START, when the source has it at once
            self.get_logger().info(response.message)
        except TrialRequestError as exc:
            response.accepted, response.message = False, str(exc)
            self.get_logger().info(f"start refused: {exc}")
        except Exception as exc:  # never raise out of a callback
            response.accepted, response.message = False, f"start failed: {exc!r}"
            self.get_logger().error(response.message)
        return response

    def _on_resend(self, request: Any, response: Any) -> Any:
        """Answer a subscriber that lost batches with the batches sent (:class:`SentBatches`)."""
        try:
            answer = self.sent.resend(str(request.trial_id), int(request.first_index), int(request.count))
            response.held, response.complete, response.message = answer.held, answer.complete, answer.message
            response.batches = [fill_gyro_batch(_msgs.GyroBatch(), b) for b in answer.batches]
            if self._exit_at is not None:
                self._exit_at = max(self._exit_at, time.monotonic() + LINGER_S)
            self.get_logger().info(
                f"resent {answer.message} (asked for [{request.first_index}, "
                f"{request.first_index + request.count if request.count else 'end'}))"
            )
        except Exception as exc:  # never raise out of a callback
            response.held, response.complete, response.message = False, False, f"resend failed: {exc!r}"
            self.get_logger().error(response.message)
        return response

    def _duration(self, request: Any) -> str:
        if request.duration_s > 0:
            return f"{request.duration_s:g} s"
        return "the rig's duration" if self.source.name == "sim" else "until stopped"

    def _on_stop_trial(self, request: Any, response: Any) -> Any:
        try:
            stopped = self.source.stop_trial(request.trial_id, bool(request.abort))
            self._poll_source()  # the STOP goes out before the response
            response.accepted = True
            how = "aborted" if stopped.aborted else "stopped"
            response.message = f"trial {stopped.trial_id} {how} after {stopped.sample_count} samples"
        except TrialRequestError as exc:
            response.accepted, response.message = False, str(exc)
        except Exception as exc:
            response.accepted, response.message = False, f"stop failed: {exc!r}"
            self.get_logger().error(response.message)
        return response

    def close(self) -> None:
        """Abort the trials in progress (ABORT published and acknowledged), release the source.

        Called by the runner on the way out (SIGINT/SIGTERM), while the node can still publish.
        """
        aborted = list(self._trials.values())
        for t in aborted:
            count = t.published + t.buffered
            stamp = sample_stamp_ns(t.start_ns, count, t.info.sample_rate_hz)
            self._on_stopped(TrialStopped(t.info.trial_id, count, stamp, aborted=True))
        if aborted:
            self._wait_for_acks(timeout_s=3.0)
        self.source.close()


def main(args: list[str] | None = None) -> int:
    """Run the driver node (``--ros-args --params-file config/driver.yaml`` and ``-p`` work)."""
    from .runner import run_node

    return run_node(DriverNode, args, name=NODE_NAME)


if __name__ == "__main__":
    sys.exit(main())
