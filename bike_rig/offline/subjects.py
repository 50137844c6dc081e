"""What the figures, the budget and the report are about: one bicycle from any accepted input.

:func:`load_subject` opens

* a **measurement file** (our YAML or BicycleParameters' ``Measured.txt``): the parameters are
  computed with their link to every raw reading (so the uncertainty budget can rank readings);
  periods given as raw trial files bring their samples and fits along;
* a **parameter file** (our YAML, BicycleParameters' ``Benchmark.txt`` or parameter-set YAML):
  the 25 parameters with σ, no raw readings, no trials;
* a **session bag** (a rosbag2 directory, its ``metadata.yaml`` or an ``.mcap`` file): the
  session is replayed offline (:func:`bike_rig.offline.replay.replay_bag`), every trial with its
  samples, fit, flags and times, and a timeline of what was measured when.

Nothing here imports rclpy or matplotlib.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..core.benchmark import ComMethod, ParameterSet
from ..core.errors import BikeRigError, InputFileError
from ..core.loader import load_input
from ..core.measurements import Measurements
from ..core.parameter_checks import compute_checked
from ..core.period import PeriodFit
from ..core.reading_ranges import UnitMistakeWarning
from ..core.trials import Trial
from ..pipeline.fit import TrialFit
from ..pipeline.offline import SessionTrial
from .timeline import TimelineEntry

__all__ = [
    "SubjectError",
    "Subject",
    "TimelineEntry",
    "SessionTrial",
    "file_trial",
    "incomplete_reason",
    "is_bag_path",
    "load_parameters",
    "load_subject",
    "resolve_bicycle",
]

FloatArray = NDArray[np.float64]


class SubjectError(BikeRigError):
    """An input cannot be turned into a bicycle's parameters (e.g. an incomplete session bag)."""

    def __init__(self, path: str, reason: str) -> None:
        """Keep the input and the reason; the message is ``<path>: <reason>``."""
        self.path = path
        self.reason = reason
        super().__init__(f"{path}: {reason}")


@dataclass(frozen=True)
class Subject:
    """One bicycle, ready to plot and report.

    Attributes:
        name: The bicycle's name.
        path: The input, as given.
        kind: ``measurements``, ``parameters`` or ``bag``.
        parameter_set: The 26 benchmark parameters with covariance, without a rider; ``raw`` is
            set when the input held raw readings (measurement files and bags); None for an
            incomplete bag opened with ``partial=True`` (:attr:`parameters` then refuses).
        measurements: The raw readings (None for a parameter file).
        trials: Every trial, in session (or file) order; empty for a parameter file.
        timeline: For a bag, what happened when, each thing once, in time order (times in
            :data:`bike_rig.offline.timeline.TIME_BASE`); else empty.
        notes: What a reader should know (e.g. trials left out of a replay).
        duration_s: For a bag, the session's length, s; else None.
        not_replayed: For a bag, the ids and states of trials that have no fit (e.g. aborted
            before any sample), so counts of a session's trials include them.
        missing: For an incomplete bag, the measurement keys with no usable trial; else empty.
    """

    name: str
    path: str
    kind: str
    parameter_set: ParameterSet | None
    measurements: Measurements | None
    trials: tuple[SessionTrial, ...] = ()
    timeline: tuple[TimelineEntry, ...] = ()
    notes: tuple[str, ...] = ()
    duration_s: float | None = None
    not_replayed: tuple[tuple[str, str], ...] = ()
    missing: tuple[str, ...] = ()

    @property
    def complete(self) -> bool:
        """Whether the bicycle's parameters could be computed."""
        return self.parameter_set is not None

    @property
    def parameters(self) -> ParameterSet:
        """The parameters (see :attr:`parameter_set`).

        Raises:
            SubjectError: The session is incomplete; the message names what is missing.
        """
        if self.parameter_set is None:
            raise SubjectError(self.path, incomplete_reason(self.missing))
        return self.parameter_set


def incomplete_reason(missing: tuple[str, ...]) -> str:
    """Why an incomplete session has no parameters: the keys with no usable trial."""
    return f"the session is incomplete: no usable trial for {', '.join(missing) or 'unknown'}"


def is_bag_path(path: str | Path) -> bool:
    """Whether ``path`` names a bag: a directory, a ``metadata.yaml`` or an ``.mcap`` file."""
    p = Path(path)
    return p.is_dir() or p.name == "metadata.yaml" or p.suffix.lower() == ".mcap"


def file_trial(trial: Trial | None, fit: PeriodFit, key: str, name: str, source: str) -> SessionTrial:
    """A trial read from a file (``trial``: its samples, None when not kept) and its fit."""
    result = TrialFit(
        trial_id=name,
        measurement_key=key,
        fit=fit,
        n_samples=int(fit.n_samples),
        window=fit.window,
        sample_rate_hz=math.nan if trial is None or trial.sample_rate_hz is None else trial.sample_rate_hz,
        samples=None if trial is None else np.asarray(trial.samples, dtype=float),
        sample_times=None if trial is None or trial.times is None else np.asarray(trial.times, dtype=float),
    )
    return SessionTrial(result, used=bool(fit.clean), source=source)


def _file_trials(m: Measurements) -> tuple[SessionTrial, ...]:
    out: list[SessionTrial] = []
    for key, ev in m.evidence.items():
        trials = list(getattr(ev, "trials", ())) or [None] * len(ev.fits)
        for path, fit, trial in zip(ev.files, ev.fits, trials):
            out.append(file_trial(trial, fit, str(key), Path(path).name, str(path)))
    return tuple(out)


def _bag_subject(path: str, com_method: ComMethod | None, partial: bool) -> Subject:
    from ..messages import static_readings_from_msg
    from ..pipeline.assemble import merged_readings
    from .replay import ReplaySettings, replay_session
    from .session import read_session
    from .timeline import session_timeline

    session = read_session(path)
    result = replay_session(session, ReplaySettings(com_method=com_method))
    if result.parameters is None and not partial:
        raise SubjectError(path, incomplete_reason(tuple(result.session.missing)))
    timeline = session_timeline(session)  # one time base: the rig clock from the first trial's start
    records: list[SessionTrial] = []
    for r in result.trials:
        rec = session.trials.get(r.trial_id)
        start = timeline.seconds(rec.start.stamp_ns if rec is not None and rec.start else None)
        stop = timeline.seconds(rec.stop.stamp_ns if rec is not None and rec.stop else None)
        key = r.key or (rec.measurement_key if rec is not None else "")
        fitted = r.result if key == r.key else dataclasses.replace(r.result, measurement_key=key)
        records.append(dataclasses.replace(r, result=fitted, start_s=start, stop_s=stop, source=path))
    periods = {k.key: (k.value, k.sigma) for k in result.session.periods}
    assert session.static_readings is not None  # the replay needs it
    static = static_readings_from_msg(session.static_readings)
    measurements = merged_readings(static, periods, f"{path} (replayed trials)")
    return Subject(
        name=result.bicycle or Path(path).stem,
        path=path,
        kind="bag",
        parameter_set=result.parameters,
        measurements=measurements,
        trials=tuple(records),
        timeline=timeline.entries,
        notes=tuple(result.notes),
        duration_s=session.duration / 1e9,
        not_replayed=tuple(
            (tid, rec.state) for tid, rec in session.trials.items() if tid not in {r.trial_id for r in records}
        ),
        missing=() if result.parameters is not None else tuple(result.session.missing),
    )


def resolve_bicycle(spec: str) -> str:
    """The input a user named: a path as given, or a shipped bicycle's file.

    ``browser`` or ``config/bicycles/browser.yaml`` from any folder
    (:func:`bike_rig.config.paths.resolve_shipped`).
    """
    from ..config.paths import resolve_shipped

    return resolve_shipped(spec, "bicycles")


def load_parameters(
    path: str | Path, com_method: ComMethod | str | None = None, lump_flywheel: bool = False
) -> ParameterSet:
    """The benchmark parameters of any input a bicycle is meant by, without a rider.

    A parameter file as read; a measurement file or a session bag computed from its raw
    readings (a bag's trials replayed, :func:`load_subject`) with ``com_method`` (None: the
    paper's centroid for a file, the live set's method for a bag) and ``lump_flywheel``.

    Raises:
        BikeRigError: As :func:`load_subject`.
    """
    p = resolve_bicycle(str(path))
    if is_bag_path(p):
        subject = load_subject(p, com_method)
        if not lump_flywheel or subject.measurements is None:
            return subject.parameters
        return compute_checked(subject.measurements, ComMethod(com_method or ComMethod.CENTROID), lump_flywheel)
    got = load_input(p)
    if isinstance(got, Measurements):
        return compute_checked(got, ComMethod(com_method or ComMethod.CENTROID), lump_flywheel)
    return got


def load_subject(path: str | Path, com_method: ComMethod | str | None = None, partial: bool = False) -> Subject:
    """Open one input (measurement file, parameter file or session bag) as a :class:`Subject`.

    Args:
        path: The input.
        com_method: Mass-centre method for raw readings. None: the paper's centroid for a
            file, and for a bag the method its live parameter set names.
        partial: Accept an incomplete bag: its subject has trials, readings and timeline but no
            parameters (:attr:`Subject.missing` names the keys without a usable trial).

    Raises:
        BikeRigError: The input is missing, unreadable, invalid, or (a bag) incomplete; the
            message names the file and the reason.
    """
    p = resolve_bicycle(str(path))
    path = p
    if not Path(path).exists():
        raise InputFileError(p, "no such file or directory")
    method = None if com_method is None else ComMethod(com_method)
    if is_bag_path(path):
        return _bag_subject(p, method, partial)
    with warnings.catch_warnings(record=True) as caught:  # values a wrong unit explains: shown, and kept as notes
        got = load_input(path)
    notes = tuple(str(w.message) for w in caught if issubclass(w.category, UnitMistakeWarning))
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if isinstance(got, Measurements):
        ps = compute_checked(got, method or ComMethod.CENTROID)
        return Subject(got.bicycle, p, "measurements", ps, got, _file_trials(got), notes=notes)
    return Subject(got.bicycle, p, "parameters", got, None, notes=notes)
