"""The simulated rig as a gyro source: a session plan streamed in plan order, or trials on request.

``mode`` ``plan`` (default, :class:`SimSource`) walks a session's plan by itself: a ``session``
written by ``bike-rig simulate`` (its trial files in the order listed, each trial's key from its
place in the file, its file stem as trial id, ``volts/<stem>.npy`` streamed when present), or
one simulated in memory from ``bicycle``, ``rig`` and ``seed``. ``mode`` ``operator``
(:class:`~bike_rig.sources.sim_operator.OperatorSimSource`) simulates each trial of the
``bicycle`` when requested.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np

from ..config.paths import config_file
from ..config.settings import ParamSpec
from ..core.errors import BikeRigError
from ..core.io_yaml import load_yaml_document
from ..core.sim import (
    RigConfig,
    SimulatedSession,
    TrialSimulator,
    load_rig,
    load_true_parameters,
    simulate_session,
)
from ..core.sim.plan import PlannedMeasurement
from ..core.sim.writer import VOLTS_DIR
from ..core.trials import read_trial
from ..pipeline.acquire import NS_PER_S, sample_stamp_ns
from .base import (
    TIME_SCALE,
    FloatArray,
    GyroSource,
    Parameters,
    RigClock,
    SampleBlock,
    SourceEvent,
    TrialInfo,
    TrialStarted,
    TrialStopped,
)
from .errors import SourceConfigError
from .sim_operator import OperatorSimSource

__all__ = ["PlannedTrial", "SimSource", "session_file_trials", "simulated_trials"]

#: Largest block one poll yields per trial (the driver cuts blocks into batches anyway).
MAX_BLOCK = 10_000

_WHEELS = ("rear_wheel", "front_wheel")
_PARTS = ("frame", "fork")


@dataclass(frozen=True, eq=False)
class PlannedTrial:
    """One trial of the plan: what it measures and its samples.

    Attributes:
        info: The trial (id, part, key, rate...).
        rates: Samples, rad/s.
        volts: Raw ADC volts, same length, or None.
    """

    info: TrialInfo
    rates: FloatArray
    volts: FloatArray | None = None


def _constant_rate(times: FloatArray) -> float | None:
    """The sample rate of evenly spaced times [Hz] (a round number when it is one), else None."""
    if times.size < 2:
        return None
    span = float(times[-1] - times[0])
    if not span > 0:
        return None
    rate = (times.size - 1) / span
    step = np.diff(times)
    if not np.all(np.abs(step * rate - 1.0) < 1e-6):
        return None
    nearest = round(rate)
    return float(nearest) if abs(rate - nearest) < 1e-9 * rate else rate


_Entry: TypeAlias = tuple[PlannedMeasurement, tuple[object, ...], Any]


def _section_entries(section: str, body: Mapping[str, Any]) -> list[_Entry]:
    """The period entries of one section (a wheel, the rod, the frame or the fork), in order."""
    if section in _WHEELS or section == "calibration_rod":
        return [
            (PlannedMeasurement(section, key.removesuffix("_period")), (section, key), body[key])
            for key in ("compound_period", "torsional_period")
            if key in body
        ]
    out: list[_Entry] = []
    if section not in _PARTS:
        return out
    for key, value in body.items():
        if key == "compound_period":
            out.append((PlannedMeasurement(section, "compound"), (section, key), value))
        elif key == "orientations" and isinstance(value, list):
            for i, o in enumerate(value):
                if isinstance(o, Mapping) and "torsional_period" in o:
                    where = (section, "orientations", i, "torsional_period")
                    out.append((PlannedMeasurement(section, "torsional", i + 1), where, o["torsional_period"]))
    return out


def _period_entries(data: Any) -> list[_Entry]:
    """The period entries of a measurement document, in document order, with their place."""
    out: list[_Entry] = []
    if not isinstance(data, Mapping):
        return out
    for section, body in data.items():
        if isinstance(body, Mapping):
            out.extend(_section_entries(section, body))
    return out


def _where(path: tuple[object, ...]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


class _TrialFileError(Exception):
    """A trial file of a session that cannot be streamed (the message names it)."""


def _planned_trial(session_dir: Path, name: str, planned: PlannedMeasurement, repeat: int) -> PlannedTrial:
    """Trial file ``name`` of a session as a trial of the plan, with its raw volts if they exist.

    Raises:
        _TrialFileError: The file is unreadable or its times are not evenly spaced.
    """
    trial_path = session_dir / name
    try:
        trial = read_trial(trial_path)
    except BikeRigError as exc:
        raise _TrialFileError(str(exc)) from None
    if trial.times is not None:
        rate = _constant_rate(trial.times)
        if rate is None:
            raise _TrialFileError(f"{trial_path}: the times are not evenly spaced (the rig streams at one rate)")
    else:
        assert trial.sample_rate_hz is not None
        rate = trial.sample_rate_hz
    stem = trial_path.stem
    volts_path = session_dir / VOLTS_DIR / f"{stem}.npy"
    volts = None
    if volts_path.is_file():
        v = np.load(volts_path, allow_pickle=False)
        if v.ndim == 1 and v.shape[0] == trial.samples.shape[0]:
            volts = np.ascontiguousarray(v, dtype=np.float64)
    info = TrialInfo(
        trial_id=stem,
        part=planned.part,
        pendulum=planned.pendulum,
        orientation=planned.orientation or 0,
        repeat=repeat,
        measurement_key=planned.key,
        sample_rate_hz=rate,
    )
    return PlannedTrial(info, np.ascontiguousarray(trial.samples, dtype=np.float64), volts)


def session_file_trials(session: str | Path) -> list[PlannedTrial]:
    """The trials of a session file written by ``bike-rig simulate``, in the file's order.

    Raises:
        SourceConfigError: The file is missing or not a session, lists no trial files, or a
            trial file is unreadable or not evenly sampled (naming the file and the key).
    """
    path = Path(session)
    shown = str(session)

    def fail(reason: str) -> SourceConfigError:
        return SourceConfigError("sim", "session", reason, shown)

    if not path.is_file():
        raise fail("no such file" if not path.exists() else "not a regular file")
    try:
        data, lines = load_yaml_document(path)
    except BikeRigError as exc:
        raise fail(f"not a session file ({exc})") from None
    if not isinstance(data, Mapping) or data.get("format") != "bike_rig-measurements/1":
        raise fail("not a session file written by 'bike-rig simulate' (expected 'format: bike_rig-measurements/1')")
    trials: list[PlannedTrial] = []
    for planned, where, entry in _period_entries(data):
        if not (isinstance(entry, Mapping) and "trials" in entry):
            continue  # a period given as a number: nothing to stream
        files = entry["trials"]
        line = lines.get(where)
        at = f"{path.name}{'' if line is None else f':{line}'}: key '{_where(where)}'"
        if not isinstance(files, list) or not files or not all(isinstance(f, str) for f in files):
            raise fail(f"{at}: expected a list of trial files")
        for repeat, name in enumerate(files, start=1):
            try:
                trials.append(_planned_trial(path.parent, name, planned, repeat))
            except _TrialFileError as exc:
                raise fail(f"{at}: {exc}") from None
    if not trials:
        raise fail("lists no trial files (periods must be given as {trials: [...]})")
    ids = [t.info.trial_id for t in trials]
    if len(set(ids)) != len(ids):
        twice = sorted({i for i in ids if ids.count(i) > 1})
        raise fail(f"trial files with the same name ({', '.join(twice)}): trial ids must be unique")
    return trials


def simulated_trials(session: SimulatedSession) -> list[PlannedTrial]:
    """The trials of a session simulated in memory, in plan order (with raw volts)."""
    planned = {m.key: m for m in session.plan}
    out = []
    for t in session.trials:
        m = planned[t.key]
        info = TrialInfo(
            trial_id=t.name,
            part=m.part,
            pendulum=m.pendulum,
            orientation=m.orientation or 0,
            repeat=t.trial,
            measurement_key=t.key,
            sample_rate_hz=float(t.sample_rate),
        )
        out.append(PlannedTrial(info, t.rate, t.volts))
    return out


def _bicycle_on_rig(p: Parameters, bicycle: str) -> tuple[str, dict[str, float], RigConfig, str]:
    """The bicycle's name and true parameters, the rig, and a label for the log.

    Raises:
        SourceConfigError: The bicycle or the rig cannot be read (or the seed is bad).
    """
    rig_path = p.text("rig") or str(config_file("rig.yaml"))
    seed = p.integer("seed")
    try:
        name, truth = load_true_parameters(bicycle)
    except BikeRigError as exc:
        raise p.error("bicycle", str(exc), bicycle) from None
    try:
        rig = load_rig(rig_path)
    except BikeRigError as exc:
        raise p.error("rig", str(exc), rig_path) from None
    return name, truth, rig, f"{name} simulated on {rig_path}, seed {seed}"


class SimSource(GyroSource):
    """The simulated rig walking a plan of trials.

    Rig time starts at ``start_time_s`` (s since the epoch; 0: the wall clock when streaming
    begins); trial k starts when trial k−1 ended plus ``pause_between_trials_s``; sample i is at
    ``start + i / rate`` and is yielded once the scaled clock has passed it, so ``time_scale``
    20 plays 20 times faster than real time with stamps still in rig time.

    Args:
        trials: The plan, in order.
        clock: Rig time (its ``time_scale`` paces the stream; ``math.inf``: no pacing).
        pause_between_trials_s: Rig time between one trial's end and the next one's start, s.
        label: What the source streams, for the log.
    """

    name = "sim"
    PARAMETERS = (
        ParamSpec(
            "mode",
            "plan",
            "sim: 'plan' walks the session's plan; 'operator' simulates each trial requested "
            "through StartTrial (with 'bicycle')",
            choices=("plan", "operator"),
        ),
        ParamSpec("session", "", "sim: session.yaml written by 'bike-rig simulate' (streamed in plan order)"),
        ParamSpec("bicycle", "", "sim: bicycle file whose session is simulated in memory (instead of session)"),
        ParamSpec("rig", "", "sim: rig description for 'bicycle' ('' = config/rig.yaml)"),
        ParamSpec("seed", 0, "sim: seed of the in-memory simulation", (0, 2**31 - 1)),
        ParamSpec("pause_between_trials_s", 1.0, "sim: rig time between trials, s", (0.0, 3600.0)),
        ParamSpec(
            "start_time_s", 0.0, "sim: rig time of the first trial's start, s since the epoch (0 = now)", (0.0, 1e10)
        ),
        TIME_SCALE,
    )

    def __init__(
        self,
        trials: Sequence[PlannedTrial],
        clock: RigClock | None = None,
        pause_between_trials_s: float = 1.0,
        label: str = "simulated session",
    ):
        """Walk ``trials`` in order on ``clock``.

        Raises:
            SourceConfigError: A negative or non-finite pause.
        """
        if not (math.isfinite(pause_between_trials_s) and pause_between_trials_s >= 0):
            raise SourceConfigError("sim", "pause_between_trials_s", "must be >= 0", pause_between_trials_s)
        self.trials = tuple(trials)
        self.clock = clock or RigClock()
        self.pause_ns = round(pause_between_trials_s * NS_PER_S)
        self.label = label
        self._k = 0
        self._start_ns: int | None = None
        self._started = False
        self._emitted = 0

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> GyroSource:
        """The session the parameters name (:attr:`PARAMETERS`; see the module docstring).

        ``mode``; ``session`` or ``bicycle`` (+ ``rig``, ``seed``), ``time_scale``,
        ``pause_between_trials_s``, ``start_time_s``. In ``operator`` mode, ``bicycle`` (+
        ``rig``, ``seed``) only, and an :class:`~bike_rig.sources.sim_operator.OperatorSimSource`.

        Raises:
            SourceConfigError: A bad parameter, or a session, bicycle or rig that cannot be read
                or simulated.
        """
        p = Parameters(cls.name, parameters, cls.PARAMETERS)
        mode = p.text("mode")
        session = p.text("session")
        bicycle = p.text("bicycle")
        time_scale = p.number("time_scale")
        pause = p.number("pause_between_trials_s")
        start_s = p.number("start_time_s")
        clock = RigClock(round(start_s * NS_PER_S) if start_s > 0 else None, time_scale)
        if mode == "operator":
            if session:
                reason = (
                    "the operator mode simulates each requested trial from 'bicycle' (+ 'rig', 'seed'); "
                    "a written session cannot be driven trial by trial (use mode 'plan')"
                )
                raise p.error("session", reason, session)
            if not bicycle:
                raise p.error("bicycle", "the operator mode needs 'bicycle' (+ 'rig', 'seed') to simulate", "")
            name, truth, rig, label = _bicycle_on_rig(p, bicycle)
            try:
                simulator = TrialSimulator.create(truth, rig, p.integer("seed"), name)
            except BikeRigError as exc:
                raise p.error("bicycle", f"cannot be simulated on rig {rig.source}: {exc}", bicycle) from None
            return OperatorSimSource(simulator, clock, pause, label=label)
        if session and bicycle:
            reason = f"give either 'session' ({session}) or 'bicycle' (+ 'rig', 'seed'), not both"
            raise p.error("bicycle", reason, bicycle)
        if session:
            return cls(session_file_trials(session), clock, pause, label=f"session {session}")
        if not bicycle:
            raise p.error(
                "session",
                "the sim source needs 'session' (a session.yaml written by 'bike-rig simulate') "
                "or 'bicycle' (+ 'rig', 'seed') to simulate one in memory",
                "",
            )
        name, truth, rig, label = _bicycle_on_rig(p, bicycle)
        try:
            sim = simulate_session(truth, rig, p.integer("seed"), name)
        except BikeRigError as exc:
            raise p.error("bicycle", f"cannot be simulated on rig {rig.source}: {exc}", bicycle) from None
        return cls(simulated_trials(sim), clock, pause, label=label)

    def describe(self) -> str:
        """What is streamed, the number of trials and the time scale, for the log."""
        scale = self.clock.time_scale
        return f"sim: {self.label}, {len(self.trials)} trials, time scale {scale:g}"

    @property
    def finished(self) -> bool:
        """True once the last trial's STOP has been yielded."""
        return self._k >= len(self.trials)

    def poll(self) -> list[SourceEvent]:
        """The START, sample blocks and STOP events that are due on the clock, in plan order."""
        events: list[SourceEvent] = []
        now = self.clock.now_ns()
        while self._k < len(self.trials):
            trial = self.trials[self._k]
            info, n = trial.info, trial.rates.shape[0]
            if self._start_ns is None:
                self._start_ns = self.clock.start_ns
            start = self._start_ns
            if now < start:
                break
            if not self._started:
                events.append(TrialStarted(info, start))
                self._started = True
            rate = info.sample_rate_hz
            due = n if math.isinf(now) else min(n, math.floor((now - start) * rate / NS_PER_S) + 1)
            while self._emitted < due:
                a = self._emitted
                b = min(due, a + MAX_BLOCK)
                volts = None if trial.volts is None else trial.volts[a:b]
                events.append(SampleBlock(info.trial_id, a, trial.rates[a:b], volts))
                self._emitted = b
            stop = sample_stamp_ns(start, n, rate)
            if self._emitted < n or now < stop:
                break
            events.append(TrialStopped(info.trial_id, n, stop))
            self._k += 1
            self._start_ns = stop + self.pause_ns
            self._started = False
            self._emitted = 0
        return events
