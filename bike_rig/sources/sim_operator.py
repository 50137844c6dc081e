"""The simulated rig driven by an operator: each requested trial is simulated when it is asked for.

The ``sim`` source in ``mode`` ``operator``. Nothing streams until
:meth:`OperatorSimSource.start_trial`: the request is checked against the rig's plan
(:func:`planned_measurement`; refused with a :class:`~bike_rig.sources.errors.TrialRequestError`),
named ``<stem>_t<repeat>`` (ids never reused), and simulated with the session's physics and
sensor model (the k-th trial draws from the seed's k-th trial streams) for ``duration_s`` of rig
time (0: the rig's). :meth:`~OperatorSimSource.poll` streams it as the scaled clock passes;
:meth:`~OperatorSimSource.stop_trial` ends it now (ABORT when asked). One trial at a time;
unpaced (``time_scale`` inf) all samples are due at once.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..core.errors import BikeRigError
from ..core.sim import SimulatedTrial, TrialSimulator
from ..core.sim.plan import PlannedMeasurement
from ..pipeline.acquire import NS_PER_S, sample_stamp_ns
from .base import (
    PENDULUMS,
    GyroSource,
    RigClock,
    SampleBlock,
    SourceEvent,
    TrialInfo,
    TrialRequest,
    TrialStarted,
    TrialStopped,
    trial_info_for,
)
from .errors import SourceConfigError, TrialRequestError

__all__ = ["MAX_TRIAL_S", "OperatorSimSource", "planned_measurement"]

#: Longest trial the simulated rig records on request, s of rig time.
MAX_TRIAL_S = 3600.0
#: Largest block one poll yields (the driver cuts blocks into batches anyway).
MAX_BLOCK = 10_000


def _the(part: str) -> str:
    return "the " + part.replace("_", " ")


def _span(n: int) -> str:
    return "1" if n == 1 else f"1–{n}"


def _unknown_part(part: str, plan: Sequence[PlannedMeasurement]) -> TrialRequestError | None:
    """The error of a part unknown to the plan, else None."""
    parts = list(dict.fromkeys(m.part for m in plan))
    if part in parts:
        return None
    return TrialRequestError(f"unknown part {part!r}; the plan's parts are {', '.join(parts)}")


def planned_measurement(request: TrialRequest, plan: Sequence[PlannedMeasurement]) -> PlannedMeasurement:
    """The measurement of ``plan`` that ``request`` asks for.

    Args:
        request: The part, pendulum, orientation (0 where none applies) and, optionally, the
            measurement key (it must be the measurement's).
        plan: The rig's plan (:func:`~bike_rig.core.sim.plan.measurement_plan`).

    Returns:
        The planned measurement.

    Raises:
        TrialRequestError: The request is outside the plan; the message says what and why,
            e.g. ``orientation 4 is outside the plan: the frame hangs in orientations 1–3
            (rig orientations_deg.frame)``.
    """
    part, pendulum, orientation = request.part, request.pendulum, request.orientation
    unknown = _unknown_part(part, plan)
    if unknown is not None:
        raise unknown
    if pendulum not in PENDULUMS:
        raise TrialRequestError(f"unknown pendulum {pendulum!r}; expected compound or torsional")
    kinds = [m for m in plan if m.part == part and m.pendulum == pendulum]
    if not kinds:
        hung = " and ".join(sorted({m.pendulum for m in plan if m.part == part}))
        raise TrialRequestError(f"{_the(part)} is only hung as a {hung} pendulum, not as a {pendulum} one")
    oriented = [m for m in kinds if m.orientation is not None]
    if oriented:
        n = len(oriented)
        where = f"{_the(part)} hangs in orientations {_span(n)} (rig orientations_deg.{part})"
        if orientation < 1:
            raise TrialRequestError(f"a {part} {pendulum} trial needs its orientation: {where}")
        if orientation > n:
            raise TrialRequestError(f"orientation {orientation} is outside the plan: {where}")
        chosen = next(m for m in oriented if m.orientation == orientation)
    else:
        if orientation != 0:
            raise TrialRequestError(
                f"{_the(part)}'s {pendulum} pendulum has no orientation (give 0, not {orientation}); "
                "only the frame's and the fork's torsional trials have one"
            )
        chosen = kinds[0]
    key = request.measurement_key
    if key and key != chosen.key:
        what = f"{part} {pendulum}" + (f" orientation {orientation}" if chosen.orientation else "")
        raise TrialRequestError(f"measurement_key {key!r} does not match {what} (its key is {chosen.key})")
    return chosen


def _check_duration(duration_s: float, rig_durations: Sequence[float]) -> float | None:
    """The trial's duration, s, or None for the rig's.

    Raises:
        TrialRequestError: Negative, not finite or longer than :data:`MAX_TRIAL_S`.
    """
    if not (math.isfinite(duration_s) and duration_s >= 0):
        rig = "/".join(f"{d:g}" for d in rig_durations)
        raise TrialRequestError(f"duration_s must be > 0 s (or 0: the rig's {rig} s), got {duration_s!r}")
    if duration_s > MAX_TRIAL_S:
        raise TrialRequestError(
            f"duration_s {duration_s:g} s is longer than the simulated rig records (at most {MAX_TRIAL_S:g} s)"
        )
    return duration_s if duration_s > 0 else None


@dataclass
class _Running:
    """The trial being streamed."""

    info: TrialInfo
    trial: SimulatedTrial
    start_ns: int
    emitted: int = 0

    @property
    def size(self) -> int:
        return int(self.trial.rate.shape[0])

    def stamp_after(self, count: int) -> int:
        """Rig time just after sample ``count - 1``, ns."""
        return sample_stamp_ns(self.start_ns, count, self.info.sample_rate_hz)


class OperatorSimSource(GyroSource):
    """The simulated rig, trial by trial on request (see the module docstring).

    Args:
        simulator: The bicycle on the rig, with its seed.
        clock: Rig time (its ``time_scale`` paces the stream; ``math.inf``: no pacing).
        pause_between_trials_s: Unpaced clock only: rig time between one trial's end and the
            next one's start, s.
        label: What the source simulates, for the log.

    Raises:
        SourceConfigError: A negative or non-finite pause.
    """

    name = "sim"
    supports_requests = True

    def __init__(
        self,
        simulator: TrialSimulator,
        clock: RigClock | None = None,
        pause_between_trials_s: float = 1.0,
        label: str = "simulated rig",
    ):
        """Nothing streams until :meth:`start_trial`."""
        if not (math.isfinite(pause_between_trials_s) and pause_between_trials_s >= 0):
            raise SourceConfigError("sim", "pause_between_trials_s", "must be >= 0", pause_between_trials_s)
        self.simulator = simulator
        self.clock = clock or RigClock()
        self.pause_ns = round(pause_between_trials_s * NS_PER_S)
        self.label = label
        self.sample_rate_hz = float(simulator.rig.adc.sample_rate)
        self.trials_started = 0
        self._used_ids: set[str] = set()
        self._running: _Running | None = None
        self._events: list[SourceEvent] = []
        self._last_stop_ns: int | None = None

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> OperatorSimSource:
        """The sim source's parameters, in ``operator`` mode (see :meth:`SimSource.from_parameters`).

        Raises:
            SourceConfigError: A bad parameter, or a bicycle or rig that cannot be simulated.
        """
        from .sim import SimSource  # the sim module builds this source: imported here, not at the top

        source = SimSource.from_parameters({**parameters, "mode": "operator"})
        assert isinstance(source, OperatorSimSource)
        return source

    @property
    def plan(self) -> tuple[PlannedMeasurement, ...]:
        """The measurements a trial may be requested for, in the rig's order."""
        return self.simulator.plan

    @property
    def recording(self) -> TrialInfo | None:
        """The trial being recorded, if any."""
        return None if self._running is None else self._running.info

    def describe(self) -> str:
        """The bicycle and rig, and the time scale, for the log."""
        return (
            f"sim (operator mode): {self.label}, {len(self.plan)} planned measurements, trials on request, "
            f"time scale {self.clock.time_scale:g}"
        )

    def silence_hint(self) -> str:
        """Why a simulated trial goes silent: the driver's process is not keeping up."""
        return "the simulated rig is not keeping up (an overloaded machine?)"

    def _start_ns(self, now: int | float) -> int:
        if not math.isinf(now):
            return int(now)
        if self._last_stop_ns is None:
            return self.clock.start_ns
        return self._last_stop_ns + self.pause_ns

    def start_trial(self, request: TrialRequest) -> TrialInfo:
        """Simulate the requested trial and stream it from the clock's now.

        Raises:
            TrialRequestError: A trial is recording, or the request is outside the plan or
                invalid (the message says what and why).
        """
        now = self.clock.now_ns()
        self._advance(now)  # a trial whose end the clock has passed is over
        if self._running is not None:
            running = self._running.info.trial_id
            raise TrialRequestError(f"trial {running} is recording; stop or abort it first (one trial at a time)")
        m = planned_measurement(request, self.plan)
        duration = _check_duration(request.duration_s, self.simulator.rig.trials.durations)
        info = trial_info_for(request, self.sample_rate_hz, self._used_ids)
        try:
            trial = self.simulator.simulate(m, self.trials_started, info.repeat, info.trial_id, duration)
        except BikeRigError as exc:
            raise TrialRequestError(f"trial {info.trial_id} cannot be simulated: {exc}") from None
        self.trials_started += 1
        self._used_ids.add(info.trial_id)
        self._running = _Running(info, trial, self._start_ns(now))
        self._events.append(TrialStarted(info, self._running.start_ns))
        self._advance(now)
        return info

    def continue_after(self, trial_ids: Sequence[str], last_stamp_ns: int) -> None:
        """Continue an interrupted session: ids not reused, noise streams and rig time continued.

        The next trial draws the noise streams of trial ``len(trial_ids)`` of the seed (as the
        uninterrupted session's next trial would) and, when the clock has not started yet, rig
        time starts no earlier than ``pause_between_trials_s`` after ``last_stamp_ns``.
        """
        self._used_ids.update(trial_ids)
        self.trials_started = len(self._used_ids)
        if last_stamp_ns > 0:
            self._last_stop_ns = last_stamp_ns
            if not self.clock.started and not math.isinf(self.clock.time_scale):
                start = max(time.time_ns(), last_stamp_ns + self.pause_ns)
                self.clock = RigClock(start, self.clock.time_scale)

    def stop_trial(self, trial_id: str = "", abort: bool = False) -> TrialStopped:
        """End the recording trial now: STOP (ABORT when ``abort``) after the samples streamed so far.

        Raises:
            TrialRequestError: No trial, or another one, is recording.
        """
        self._advance(self.clock.now_ns())
        run = self._running
        if run is None:
            last = self._events[-1] if self._events else None
            if isinstance(last, TrialStopped) and trial_id in ("", last.trial_id):
                return last  # it reached its end meanwhile: its STOP is not out yet
            raise TrialRequestError("no trial is running")
        if trial_id and trial_id != run.info.trial_id:
            raise TrialRequestError(f"trial {trial_id!r} is not running (trial {run.info.trial_id} is)")
        return self._end(run, run.emitted, abort)

    def poll(self) -> list[SourceEvent]:
        """The events due on the clock: a requested trial's START, its samples, its STOP."""
        self._advance(self.clock.now_ns())
        events, self._events = self._events, []
        return events

    def _end(self, run: _Running, count: int, aborted: bool) -> TrialStopped:
        stopped = TrialStopped(run.info.trial_id, count, run.stamp_after(count), aborted)
        self._events.append(stopped)
        self._last_stop_ns = stopped.stamp_ns
        self._running = None
        return stopped

    def _advance(self, now: int | float) -> None:
        """Queue the running trial's samples due by ``now``, and its STOP once ``now`` passes its end."""
        run = self._running
        if run is None:
            return
        n, rate = run.size, run.info.sample_rate_hz
        if math.isinf(now):
            due = n
        else:
            due = min(n, max(0, math.floor((now - run.start_ns) * rate / NS_PER_S) + 1))
        trial = run.trial
        while run.emitted < due:
            a = run.emitted
            b = min(due, a + MAX_BLOCK)
            self._events.append(SampleBlock(run.info.trial_id, a, trial.rate[a:b], trial.volts[a:b]))
            run.emitted = b
        if run.emitted >= n and now >= run.stamp_after(n):
            self._end(run, n, aborted=False)
