"""The gyro-source interface: one rate gyro, read trial by trial, behind one API.

A :class:`GyroSource` yields, in order, ``TrialStarted``, ``SampleBlock``... and ``TrialStopped``
events; backends are chosen by name (:data:`BACKENDS`, :func:`open_source`), as python-can's
are. Each backend owns its node parameters (:attr:`GyroSource.PARAMETERS`), read and checked
through :class:`Parameters`, which raises :class:`~bike_rig.sources.errors.SourceConfigError`
naming the parameter, its value and why. Plan-walking sources (``sim``, ``bag``) end when
:attr:`GyroSource.finished`; hardware ones record on request (:class:`StreamingSource`).
"""

from __future__ import annotations

import importlib
import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, ClassVar, TypeAlias

import numpy as np
from numpy.typing import NDArray

from ..config.settings import ParamSpec, ParamValue, ParamValueError, merge_specs
from ..core.sim.plan import PART_LETTERS, PlannedMeasurement
from ..pipeline.acquire import NS_PER_S, sample_stamp_ns
from .errors import SourceConfigError, TrialRequestError

__all__ = [
    "BACKENDS",
    "MAX_TIME_SCALE",
    "SAMPLE_RATE",
    "TIME_SCALE",
    "GyroSource",
    "Parameters",
    "RigClock",
    "SampleBlock",
    "SourceEvent",
    "StreamingSource",
    "TrialInfo",
    "TrialRequest",
    "TrialStarted",
    "TrialStopped",
    "backend_parameters",
    "drain",
    "open_source",
    "source_class",
    "trial_info_for",
]

FloatArray = NDArray[np.float64]

#: Backend name -> "module:class" (imported on first use, so that a missing optional library
#: only matters for the backend that needs it). A new backend is one line here.
BACKENDS: dict[str, str] = {
    "sim": "bike_rig.sources.sim:SimSource",
    "can": "bike_rig.sources.can:CanSource",
    "bag": "bike_rig.sources.bag:BagSource",
    "daq": "bike_rig.sources.daq:DaqSource",
}

PENDULUMS = ("compound", "torsional")

#: Largest ``time_scale``: 1000 × 1 kHz is 20,000 batches per second, the most a reliable
#: subscriber keeps up with.
MAX_TIME_SCALE = 1000.0

#: Pacing of the backends that replay or simulate (sim, bag, the simulated CAN gyro).
TIME_SCALE = ParamSpec(
    "time_scale", 1.0, "sim/bag (and the simulated CAN gyro): rig seconds per wall second", (0.001, MAX_TIME_SCALE)
)
#: The sample rate of the hardware gyros (can, daq), Hz.
SAMPLE_RATE = ParamSpec("sample_rate_hz", 1000.0, "can/daq: the gyro's sample rate, Hz", (1e-3, 1e6))


@dataclass(frozen=True)
class TrialInfo:
    """What a trial measures (the fields of a ``bike_rig_msgs/TrialEvent``).

    Attributes:
        trial_id: Unique within the session, e.g. ``frame_torsional_o2_t3``.
        part: ``rear_wheel``, ``front_wheel``, ``frame``, ``fork`` or ``calibration_rod``.
        pendulum: ``compound`` or ``torsional``.
        orientation: 1-based hanging orientation of the frame or fork; 0 when not applicable.
        repeat: 1-based trial number of this measurement.
        measurement_key: Flat key of the period it measures, e.g. ``TtB2``.
        sample_rate_hz: Samples per second, Hz.
        note: Free text.
    """

    trial_id: str
    part: str
    pendulum: str
    orientation: int
    repeat: int
    measurement_key: str
    sample_rate_hz: float
    note: str = ""


@dataclass(frozen=True)
class TrialStarted:
    """A trial begins; ``stamp_ns`` is the rig time of its first sample."""

    info: TrialInfo
    stamp_ns: int


@dataclass(frozen=True, eq=False)
class SampleBlock:
    """Consecutive samples of one trial.

    Attributes:
        trial_id: The trial.
        first_index: Index of ``rates[0]`` within the trial (0 for its first sample).
        rates: Angular rate, rad/s, oldest first.
        raw_volts: The sensor's raw output, V, same length, or None.
    """

    trial_id: str
    first_index: int
    rates: FloatArray
    raw_volts: FloatArray | None = None


@dataclass(frozen=True)
class TrialStopped:
    """A trial ends after ``sample_count`` samples.

    Attributes:
        trial_id: The trial.
        sample_count: Samples the trial holds.
        stamp_ns: Rig time just after its last sample, ns
            (``sample_stamp_ns(start, sample_count, rate)``).
        aborted: The operator aborted it.
    """

    trial_id: str
    sample_count: int
    stamp_ns: int
    aborted: bool = False


SourceEvent: TypeAlias = TrialStarted | SampleBlock | TrialStopped


@dataclass(frozen=True)
class TrialRequest:
    """A request to record a trial (the ``StartTrial`` service's fields).

    Attributes:
        part: See :class:`TrialInfo`.
        pendulum: ``compound`` or ``torsional``.
        orientation: 1-based, for the frame's and fork's torsional trials; else 0.
        repeat: The trial number, or 0 to take the next free one.
        measurement_key: The period's flat key, or "" to derive it from the above.
        duration_s: Seconds to record (> 0), or 0 to record until stopped.
        note: Free text.
    """

    part: str
    pendulum: str
    orientation: int = 0
    repeat: int = 0
    measurement_key: str = ""
    duration_s: float = 0.0
    note: str = ""


def trial_info_for(request: TrialRequest, sample_rate_hz: float, used_ids: set[str] | frozenset[str]) -> TrialInfo:
    """The trial a request describes, with a trial id not in ``used_ids``.

    The id is the simulated rig's name of the trial, ``<stem>_t<repeat>``
    (``frame_torsional_o2_t3``), with the request's repeat or, when it is 0, the lowest repeat
    whose id is free. An id is never reused: when the requested repeat's id is taken (a redo of
    trial 2), ``_r2``, ``_r3``... is appended (``frame_torsional_o2_t2_r2``), and the trial
    keeps its repeat number.

    Raises:
        TrialRequestError: An unknown part or pendulum, a missing orientation, a bad duration.
    """
    if request.part not in PART_LETTERS:
        raise TrialRequestError(f"unknown part {request.part!r}; expected one of {', '.join(PART_LETTERS)}")
    if request.pendulum not in PENDULUMS:
        raise TrialRequestError(f"unknown pendulum {request.pendulum!r}; expected compound or torsional")
    if not (math.isfinite(request.duration_s) and request.duration_s >= 0):
        raise TrialRequestError(f"duration_s must be > 0 s (or 0: until stopped), got {request.duration_s!r}")
    oriented = request.part in ("frame", "fork") and request.pendulum == "torsional"
    if oriented and request.orientation < 1:
        raise TrialRequestError(f"a {request.part} torsional trial needs its orientation (1, 2, 3...)")
    planned = PlannedMeasurement(request.part, request.pendulum, request.orientation if oriented else None)
    key = request.measurement_key or planned.key
    repeat = request.repeat
    if repeat < 1:
        repeat = 1
        while planned.trial_name(repeat) in used_ids:
            repeat += 1
    trial_id = base = planned.trial_name(repeat)
    n = 2
    while trial_id in used_ids:
        trial_id, n = f"{base}_r{n}", n + 1
    return TrialInfo(
        trial_id=trial_id,
        part=request.part,
        pendulum=request.pendulum,
        orientation=request.orientation if oriented else 0,
        repeat=repeat,
        measurement_key=key,
        sample_rate_hz=sample_rate_hz,
        note=request.note,
    )


class Parameters:
    """Typed access to a backend's parameters, checked against its specs.

    Each value is the mapping's, or the spec's default when the mapping lacks the name; it is
    checked with :meth:`~bike_rig.config.settings.ParamSpec.validate` (type, range, choices), and a bad
    one raises :class:`SourceConfigError` naming the source, the parameter, its value and the
    reason (e.g. ``sim source: parameter 'time_scale' = 5000.0: must be <= 1000``).

    Args:
        source: The backend's name, for the messages.
        values: The parameters given (unknown names are ignored).
        specs: The backend's parameter specs (:attr:`GyroSource.PARAMETERS`).
    """

    def __init__(self, source: str, values: Mapping[str, Any], specs: Iterable[ParamSpec]):
        """Read ``values`` for ``source`` against ``specs``."""
        self.source = source
        self.values = values
        self.specs = {s.name: s for s in specs}

    def error(self, name: str, reason: str, value: object = None) -> SourceConfigError:
        """The error for parameter ``name``."""
        return SourceConfigError(self.source, name, reason, value)

    def _read(self, name: str, kind: str) -> ParamValue:
        spec = self.specs.get(name)
        if spec is None or spec.kind != kind:
            raise KeyError(f"the {self.source} source declares no {kind} parameter {name!r}")
        value = self.values.get(name, spec.default)
        if isinstance(value, str):
            value = value.strip()
        try:
            return spec.validate(value)
        except ParamValueError as exc:
            raise self.error(name, exc.reason, value) from None

    def text(self, name: str) -> str:
        """A string parameter, stripped (one of its spec's choices, if it has any)."""
        value = self._read(name, "string")
        assert isinstance(value, str)
        return value

    def number(self, name: str) -> float:
        """A finite float parameter within its spec's range (an integer is accepted)."""
        value = self._read(name, "double")
        assert isinstance(value, float)
        return value

    def integer(self, name: str) -> int:
        """An integer parameter within its spec's range."""
        value = self._read(name, "integer")
        assert isinstance(value, int)
        return value

    def flag(self, name: str) -> bool:
        """A boolean parameter."""
        value = self._read(name, "bool")
        assert isinstance(value, bool)
        return value


class RigClock:
    """Rig time that runs ``time_scale`` times faster than the wall clock.

    It starts on the first call of :meth:`now_ns` (so that a node may wait for its
    subscribers first): then rig time is ``start_ns`` (or the wall clock at that moment when
    ``start_ns`` is None) and advances ``time_scale`` rig seconds per second. A ``time_scale``
    of ``math.inf`` makes every rig time due at once (no pacing; for tests and offline use).
    """

    def __init__(
        self,
        start_ns: int | None = None,
        time_scale: float = 1.0,
        *,
        monotonic: Callable[[], float] = time.monotonic,
        wall_ns: Callable[[], int] = time.time_ns,
    ):
        """A clock that has not started yet (``monotonic`` and ``wall_ns`` for tests).

        Raises:
            ValueError: ``time_scale`` is not > 0.
        """
        if not time_scale > 0:
            raise ValueError(f"time_scale must be > 0, got {time_scale!r}")
        self.time_scale = time_scale
        self._start_ns = start_ns
        self._monotonic = monotonic
        self._wall_ns = wall_ns
        self._m0: float | None = None

    @property
    def started(self) -> bool:
        """Whether the clock has started."""
        return self._m0 is not None

    @property
    def start_ns(self) -> int:
        """Rig time at the start [ns] (starts the clock)."""
        self.now_ns()
        assert self._start_ns is not None
        return self._start_ns

    def now_ns(self) -> int | float:
        """Rig time now [ns]: an integer, or ``math.inf`` when unpaced."""
        if self._m0 is None:
            self._m0 = self._monotonic()
            if self._start_ns is None:
                self._start_ns = self._wall_ns()
        assert self._start_ns is not None
        if math.isinf(self.time_scale):
            return math.inf
        return self._start_ns + int((self._monotonic() - self._m0) * self.time_scale * NS_PER_S)


class GyroSource(ABC):
    """One rate gyro, trial by trial.

    Events, in order: ``TrialStarted(info, stamp_ns)`` before a trial's first samples,
    ``SampleBlock(trial_id, first_index, rates, raw_volts)`` (consecutive samples, any size),
    ``TrialStopped(trial_id, sample_count, stamp_ns, aborted)`` after its last. :meth:`poll`
    returns what is due now and never blocks for long (simulated and bag sources pace
    themselves, ``time_scale`` times real time). Times are rig times in integer ns since the
    epoch; sample ``index`` is at ``stamp_ns + round(index * 1e9 / sample_rate_hz)``.

    Subclasses set :attr:`name`, :attr:`PARAMETERS` and :attr:`supports_requests` and
    implement :meth:`poll` and :meth:`from_parameters`; plan-walking sources override :attr:`finished`, hardware sources
    :meth:`start_trial` and :meth:`stop_trial` (or derive from :class:`StreamingSource`).
    """

    #: The backend's name (``sim``, ``can``, ``bag``, ``daq``).
    name: ClassVar[str] = ""
    #: The backend's parameters (the driver node declares them; :class:`Parameters` reads them).
    PARAMETERS: ClassVar[tuple[ParamSpec, ...]] = ()
    #: Whether trials are recorded on request (hardware) rather than from a plan.
    supports_requests: ClassVar[bool] = False

    @classmethod
    @abstractmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> GyroSource:
        """Build the source from the driver's parameters (unknown names are ignored).

        Raises:
            SourceConfigError: A parameter is missing, malformed or impossible.
        """

    @abstractmethod
    def poll(self) -> list[SourceEvent]:
        """The events that are due now, in order (possibly none); does not block for long."""

    @property
    def finished(self) -> bool:
        """True once a plan-walking source has yielded its last event (never for hardware)."""
        return False

    def describe(self) -> str:
        """One line for the log: what the source reads."""
        return self.name

    def notices(self) -> list[tuple[bool, str]]:
        """What the source has to tell the operator since the last call, as (is a warning, text); none here.

        The driver logs each (a warning, or information).
        """
        return []

    def silence_hint(self) -> str:
        """What to check when a recording trial gets no samples (ends the driver's warning)."""
        return f"check that the {self.name} source is delivering"

    def start_trial(self, request: TrialRequest) -> TrialInfo:
        """Record a trial from now on.

        Raises:
            TrialRequestError: The source walks its own plan, a trial is running, or the
                request is invalid.
        """
        raise TrialRequestError(f"the {self.name} source walks its own plan; trials cannot be started on request")

    def stop_trial(self, trial_id: str = "", abort: bool = False) -> TrialStopped:
        """Stop (or abort) the running trial (``trial_id`` "" for whichever runs).

        Raises:
            TrialRequestError: No such trial is running, or the source walks its own plan.
        """
        raise TrialRequestError(f"the {self.name} source walks its own plan; trials cannot be stopped on request")

    def continue_after(self, trial_ids: Sequence[str], last_stamp_ns: int) -> None:  # noqa: B027 - see below
        """Continue an interrupted session whose trials ``trial_ids`` were recorded (resume).

        Sources that record on request never reuse those ids; the simulated rig also continues
        its noise streams and its rig time after ``last_stamp_ns``. A no-op for plan-walking
        sources (a session resumes only with a source that records on request).
        """

    def close(self) -> None:  # noqa: B027 - a no-op unless the backend holds something
        """Release the hardware or the file (idempotent)."""

    def __enter__(self) -> GyroSource:
        """The source itself (closed on leaving the ``with`` block)."""
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        """Close the source."""
        self.close()


def source_class(name: str) -> type[GyroSource]:
    """The backend class of ``name``.

    Raises:
        SourceConfigError: An unknown name.
    """
    target = BACKENDS.get(name)
    if target is None:
        reason = f"unknown gyro source; expected one of {', '.join(BACKENDS)}"
        raise SourceConfigError(name, "source", reason, name, where="")
    module_name, _, class_name = target.partition(":")
    cls: type[GyroSource] = getattr(importlib.import_module(module_name), class_name)
    return cls


def backend_parameters() -> tuple[ParamSpec, ...]:
    """Every registered backend's parameter specs, each name once (the driver declares them).

    Raises:
        ValueError: Two backends specify one parameter differently (a programming error).
    """
    return merge_specs(*(source_class(name).PARAMETERS for name in BACKENDS))


def open_source(name: str, parameters: Mapping[str, Any] | None = None, **kwargs: Any) -> GyroSource:
    """Open the gyro source ``name`` (``sim``, ``can``, ``bag`` or ``daq``), python-can style.

    For example ``open_source("sim", session="run1/session.yaml", time_scale=20.0)``.

    Args:
        name: The backend.
        parameters: Its parameters (names as the driver node's).
        **kwargs: More parameters, added to ``parameters``.

    Raises:
        SourceConfigError: Unknown backend, or a bad parameter.
    """
    values = dict(parameters or {})
    values.update(kwargs)
    return source_class(name).from_parameters(values)


def drain(source: GyroSource, timeout_s: float = 60.0, idle_sleep_s: float = 0.001) -> Iterator[SourceEvent]:
    """Every event of a plan-walking source until it is finished (or ``timeout_s`` passes).

    Raises:
        TimeoutError: The source did not finish in time.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        events = source.poll()
        yield from events
        if source.finished:
            return
        if time.monotonic() > deadline:
            raise TimeoutError(f"the {source.name} source did not finish within {timeout_s} s")
        if not events:
            time.sleep(idle_sleep_s)


@dataclass
class _Recording:
    """The trial a :class:`StreamingSource` records."""

    info: TrialInfo
    target: int  # samples to record, 0 = until stopped
    requested_ns: int  # epoch time of the request, ns
    start_ns: int | None = None
    count: int = 0


class StreamingSource(GyroSource):
    """A gyro that streams samples continuously; trials are recorded on request.

    Subclasses implement :meth:`read_available`, which returns the samples delivered since the
    last call without blocking. A trial starts with the first sample read after
    :meth:`start_trial` (samples before it are read and dropped then), and ends after
    ``duration_s`` worth of samples or at :meth:`stop_trial` (which first reads what has been
    delivered until then). Its start stamp is the delivery time of its first sample, as the
    subclass reports it; a trial stopped before any sample arrived (a silent bus) is an empty
    trial stamped at its request.
    """

    supports_requests = True

    def __init__(self, sample_rate_hz: float):
        """A source streaming at ``sample_rate_hz`` Hz, not recording."""
        self.sample_rate_hz = sample_rate_hz
        self._recording: _Recording | None = None
        self._events: list[SourceEvent] = []
        self._used_ids: set[str] = set()

    @abstractmethod
    def read_available(self) -> tuple[FloatArray, FloatArray | None, int]:
        """The samples delivered since the last call (possibly none), without blocking.

        Returns:
            (rates rad/s, raw volts or None, epoch time of the first of them in ns).
        """

    def poll(self) -> list[SourceEvent]:
        """The events of the samples delivered since the last poll (and of requests since)."""
        self._take(*self.read_available())
        events, self._events = self._events, []
        return events

    def _take(self, rates: FloatArray, volts: FloatArray | None, first_ns: int) -> None:
        rec = self._recording
        if rec is None or rates.size == 0:
            return
        if rec.start_ns is None:
            rec.start_ns = first_ns
            self._events.append(TrialStarted(rec.info, first_ns))
        n = rates.size if rec.target == 0 else min(rates.size, rec.target - rec.count)
        block_volts = None if volts is None else np.array(volts[:n], dtype=np.float64)
        block = np.array(rates[:n], dtype=np.float64)
        self._events.append(SampleBlock(rec.info.trial_id, rec.count, block, block_volts))
        rec.count += n
        if rec.target and rec.count >= rec.target:
            self._finish(aborted=False)

    def _finish(self, aborted: bool) -> TrialStopped:
        rec = self._recording
        assert rec is not None
        if rec.start_ns is None:  # stopped before its first sample: an empty trial, from its request
            rec.start_ns = rec.requested_ns
            self._events.append(TrialStarted(rec.info, rec.start_ns))
        stopped = TrialStopped(
            rec.info.trial_id, rec.count, sample_stamp_ns(rec.start_ns, rec.count, rec.info.sample_rate_hz), aborted
        )
        self._events.append(stopped)
        self._recording = None
        return stopped

    def continue_after(self, trial_ids: Sequence[str], last_stamp_ns: int) -> None:
        """New trials never reuse ``trial_ids`` (the hardware's clock stamps them)."""
        self._used_ids.update(trial_ids)

    def start_trial(self, request: TrialRequest) -> TrialInfo:
        """Record a trial from the next sample delivered on (see :meth:`GyroSource.start_trial`).

        Raises:
            TrialRequestError: A trial is running, or the request is invalid.
        """
        if self._recording is not None:
            raise TrialRequestError(f"trial {self._recording.info.trial_id} is running; stop it first")
        info = trial_info_for(request, self.sample_rate_hz, self._used_ids)
        self.read_available()  # what was delivered before the request is not part of the trial
        self._used_ids.add(info.trial_id)
        target = round(request.duration_s * self.sample_rate_hz)
        self._recording = _Recording(info, target=target, requested_ns=time.time_ns())
        return info

    def stop_trial(self, trial_id: str = "", abort: bool = False) -> TrialStopped:
        """Stop (or abort) the running trial after the samples delivered until now.

        Raises:
            TrialRequestError: No trial, or another one, is running.
        """
        rec = self._recording
        if rec is None:
            raise TrialRequestError("no trial is running")
        if trial_id and trial_id != rec.info.trial_id:
            raise TrialRequestError(f"trial {trial_id!r} is not running (trial {rec.info.trial_id} is)")
        self._take(*self.read_available())  # everything delivered before the request belongs to it
        if self._recording is None:  # it reached its duration meanwhile
            last = self._events[-1]
            assert isinstance(last, TrialStopped)
            return last
        return self._finish(aborted=abort)

    @property
    def recording(self) -> TrialInfo | None:
        """The trial being recorded, if any."""
        return None if self._recording is None else self._recording.info
