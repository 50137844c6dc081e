"""Recompute a recorded session offline, with no ROS runtime: the live graph's stages on the bag's messages.

The bag's messages become the pipeline's records (:mod:`bike_rig.messages`) and go through the
offline runner (:class:`bike_rig.pipeline.offline.OfflineGraph`), which calls the code the nodes
call:

1. Trials: every trial's batches (in receiving order) and its START and STOP/ABORT events are
   fitted (:func:`bike_rig.pipeline.fit.fit_trial`) with the fit options recorded in the
   trial's ``PeriodEstimate.fit_options_json`` (the options of the session's other estimates
   for a trial without one, the defaults without any), unless the caller overrides them.
2. Parameters: the static readings of the bag's last ``StaticReadings`` message (the parameter
   node's, with every reading entered during the session applied: a session bag needs no
   file), or those of a corrected readings file (:attr:`ReplaySettings.readings`, its periods
   ignored), and the trials' periods go through
   :class:`bike_rig.pipeline.assemble.SessionAssembly` (dedupe by trial id, combine each key's
   usable trials in trial-id order, compute the parameters), with the mass-centre method the
   live parameter set names.
3. Model: :func:`bike_rig.pipeline.model.compute_model` (canonical matrices with σ, eigenvalue
   sweep, weave and capsize speeds with σ), with the rider, σ convention and speeds of the
   recorded model.

:func:`bike_rig.offline.compare.compare_with_live` then compares every number with what the live
graph published last (in publication order, :mod:`bike_rig.bag.order`): with the same settings
they agree to 1e-12 relative, bit for bit in practice.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections import Counter
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..bag.errors import ReplayError
from ..config import topics
from ..core.benchmark import ComMethod, ParameterSet
from ..core.loader import load_static_readings
from ..core.measurements import Measurements, Origin
from ..core.period import WindowPolicy
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..messages import MessageError, fit_details_from_msg, static_readings_from_msg, trial_fit_from_msg
from ..pipeline.assemble import SessionAssembly, SessionParameters, required_readings
from ..pipeline.errors import AssemblyError
from ..pipeline.fit import TrialFit, TrialFitOptions
from ..pipeline.model import ModelMatrices, StabilitySweep
from ..pipeline.offline import DEFAULT_SPEEDS, GraphSettings, OfflineGraph, SessionTrial, TrialInput
from .compare import RELATIVE_TOLERANCE, LiveComparison, compare_with_live
from .session import BY_LOG_TIME, RecordedSession, RecordedTrial, read_session

__all__ = [
    "DEFAULT_SPEEDS",
    "RELATIVE_TOLERANCE",
    "FitOverrides",
    "ReplayResult",
    "ReplaySettings",
    "replay_bag",
    "replay_session",
    "result_json",
]


@dataclass(frozen=True)
class FitOverrides:
    """Fit settings to use instead of the recorded ones (None: keep the recorded value).

    Attributes:
        window: The fit window policy.
        whole_cycles: Cut the window to whole cycles (applied to the window in force).
        min_cycles: Flag fewer cycles.
        min_r2: Flag a lower r².
        max_modulation: Flag beating above this.
        max_drift: Flag a drift above this.
        use_defaults: Start from the fitter's default options instead of the recorded ones.
    """

    window: WindowPolicy | None = None
    whole_cycles: bool | None = None
    min_cycles: float | None = None
    min_r2: float | None = None
    max_modulation: float | None = None
    max_drift: float | None = None
    use_defaults: bool = False

    @property
    def active(self) -> bool:
        """Whether anything is overridden."""
        return self.use_defaults or any(
            getattr(self, f.name) is not None for f in dataclasses.fields(self) if f.name != "use_defaults"
        )

    def apply(self, options: TrialFitOptions) -> TrialFitOptions:
        """The options with the overrides applied."""
        base = TrialFitOptions() if self.use_defaults else options
        fit = base.fit
        window = self.window if self.window is not None else fit.window
        if self.whole_cycles is not None:
            window = dataclasses.replace(window, whole_cycles=self.whole_cycles)
        changes: dict[str, Any] = {"window": window}
        for name in ("min_cycles", "min_r2", "max_modulation", "max_drift"):
            value = getattr(self, name)
            if value is not None:
                changes[name] = float(value)
        return dataclasses.replace(base, fit=dataclasses.replace(fit, **changes))


@dataclass(frozen=True)
class ReplaySettings:
    """How to replay (None: as the live graph did, read from the bag).

    Attributes:
        fit: Fit settings overriding the recorded ones.
        com_method: Mass-centre method (None: the live parameter set's, else centroid).
        rider: Rider of the model, "", "paper" or a rider file (None: the live model's, else none).
        sigma_convention: σ convention (None: the live model's, else correlated).
        readings: A measurement file whose static readings replace the bag's (e.g. corrected
            after the session); its periods are ignored (None: the bag's own).
    """

    fit: FitOverrides = field(default_factory=FitOverrides)
    com_method: ComMethod | None = None
    rider: str | None = None
    sigma_convention: SigmaConvention | None = None
    readings: str | Path | None = None


@dataclass(frozen=True)
class ReplayResult:
    """Everything recomputed from a bag.

    Attributes:
        bag: The bag, as given.
        bicycle: The bicycle's name.
        trials: Every trial fitted, in the order first heard of (``options_from`` and
            ``recorded`` say where its fit options came from and what the live graph published).
        session: The assembly's result (periods per key, missing keys, the parameter set).
        matrices: Canonical matrices with σ (None when incomplete).
        stability: Sweep and critical speeds with σ (None when incomplete).
        com_method: Mass-centre method used.
        rider: Rider of the model ("" none).
        sigma_convention: σ convention used.
        speeds: Speeds of the sweep, m/s.
        fit_overridden: The fit settings differ from the recorded ones.
        notes: What the replay left out, and why (and which static readings it used when not
            the bag's).
        live: The comparison with the live results.
        readings: Where the static readings came from: the bag's ``StaticReadings`` source
            (e.g. ``"browser.yaml + 3 reading entries"``) or the file that replaced them.
        readings_swapped: The static readings came from a file, not the bag.
    """

    bag: str
    bicycle: str
    trials: tuple[SessionTrial, ...]
    session: SessionParameters
    matrices: ModelMatrices | None
    stability: StabilitySweep | None
    com_method: ComMethod
    rider: str
    sigma_convention: SigmaConvention
    speeds: np.ndarray
    fit_overridden: bool
    notes: tuple[str, ...]
    live: LiveComparison
    readings: str = ""
    readings_swapped: bool = False

    @property
    def parameters(self) -> ParameterSet | None:
        """The 25 parameters and g with σ (None when a period is missing)."""
        return self.session.parameters

    @property
    def complete(self) -> bool:
        """Every period was obtained and the parameters computed."""
        return self.session.complete


# ---------------------------------------------------------------- trials


@lru_cache(maxsize=64)
def _parsed_options(text: str) -> TrialFitOptions:
    """The (frozen) options a ``fit_options_json`` text names: a session's trials share a few texts."""
    return TrialFitOptions.from_json(text)


def _options(text: str, where: str, bag: str) -> TrialFitOptions:
    try:
        return _parsed_options(text)
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise ReplayError(bag, f"{where}: fit_options_json is not the fitter's options ({exc})") from None


def _session_options(session: RecordedSession) -> TrialFitOptions | None:
    """The fit options most of the session's estimates name (the fitter's settings)."""
    texts = Counter(str(e.fit_options_json) for t in session.trials.values() for e in t.estimates if e.fit_options_json)
    if not texts:
        return None
    text, _ = texts.most_common(1)[0]
    return _options(text, "a period estimate", session.path)


def _live_estimates(session: RecordedSession, static: Measurements, method: ComMethod) -> dict[str, TrialFit]:
    """The estimate of each trial the live parameter node kept, with its fit details.

    Each trial's last ``FitDetails`` (a bad one left out) and every recorded PeriodEstimate, in
    the order received, go through a :class:`SessionAssembly`: its rules decide which one of a
    trial's re-publications stays, and it joins the details. A bag recorded before a field of
    the details was added keeps that field at its default (NaN).
    """
    live = SessionAssembly(static, method, origin=topics.PERIODS.name)
    for msg in session.fit_details.values():
        try:
            live.add_details(fit_details_from_msg(msg))
        except MessageError:
            continue
    for t in session.trials.values():
        for msg in t.estimates:
            try:
                live.add(trial_fit_from_msg(msg))
            except (AssemblyError, MessageError):
                continue
    kept = {p.trial_id: p for p in live.trials}
    # trials whose estimates the assembly refused (e.g. an unknown key): their last one, joined alike
    for t in session.trials.values():
        if t.trial_id not in kept and t.estimate is not None:
            try:
                kept[t.trial_id] = live.joined(trial_fit_from_msg(t.estimate))
            except MessageError:
                continue
    return kept


def _trial_options(
    recorded: TrialFit | None, session_options: TrialFitOptions | None, overrides: FitOverrides, where: str, bag: str
) -> tuple[TrialFitOptions, str]:
    """A trial's fit options and where they came from."""
    if recorded is not None and recorded.fit_options_json:
        options, source = _options(recorded.fit_options_json, where, bag), "recorded"
    elif session_options is not None:
        options, source = session_options, "session"
    else:
        options, source = TrialFitOptions(), "default"
    if overrides.active:
        options, source = overrides.apply(options), "override"
    return options, source


def _input(t: RecordedTrial) -> TrialInput:
    return TrialInput(t.trial_id, t.start, t.stop, t.batches)


def _estimate_only(t: RecordedTrial) -> bool:
    """Only period estimates of the trial were recorded: no gyro batch and no trial event to fit again."""
    return len(t.batches) == 0 and t.event is None


# ---------------------------------------------------------------- settings from the bag


def _recorded_settings(session: RecordedSession) -> tuple[ComMethod | None, str | None, SigmaConvention | None]:
    method = None
    for msg in reversed(session.parameters):
        try:
            method = ComMethod(str(msg.com_method))
            break
        except ValueError:
            continue
    sweep, matrices = session.final_eigen_sweep, session.final_matrices
    rider = str(sweep.rider) if sweep is not None else (str(matrices.rider) if matrices is not None else None)
    convention = None
    if matrices is not None:
        try:
            convention = SigmaConvention(str(matrices.sigma_convention))
        except ValueError:
            convention = None
    return method, rider, convention


def _speeds(session: RecordedSession) -> np.ndarray:
    sweep = session.final_eigen_sweep
    if sweep is not None and len(sweep.speeds) > 0:
        return np.array(sweep.speeds, dtype=np.float64)
    return DEFAULT_SPEEDS.copy()


# ---------------------------------------------------------------- the replay


def _bag_readings(session: RecordedSession) -> Measurements:
    """The bag's last ``StaticReadings`` (the parameter node's, every entered reading applied).

    Raises:
        ReplayError: There is none, it is malformed, or a static reading was never entered.
    """
    bag = session.path
    if session.static_readings is None:
        raise ReplayError(
            bag,
            "no StaticReadings message: the bag must be recorded while the parameter node runs "
            "(it publishes the static readings latched); give --readings FILE to use a measurement file's",
        )
    try:
        static = static_readings_from_msg(session.static_readings)
    except MessageError as exc:
        raise ReplayError(bag, f"the StaticReadings message is malformed ({exc})") from None
    where = f"{bag}: the recorded StaticReadings (from {static.path})"  # a bad value is the bag's, not the file's
    readings = {k: dataclasses.replace(r, origin=Origin(where, k)) for k, r in static.readings.items()}
    static = dataclasses.replace(static, readings=readings)
    missing = [k for k in required_readings(static) if k not in static.readings]
    if missing:
        raise ReplayError(
            bag,
            f"the session's static readings are incomplete (missing {', '.join(missing)}); "
            "give --readings FILE with them all",
        )
    return static


def _static_readings(session: RecordedSession, settings: ReplaySettings) -> tuple[Measurements, str, str]:
    """The static readings to replay with, where they came from, and a note when not the bag's.

    Raises:
        ReplayError: The bag's readings cannot be used (:func:`_bag_readings`).
        BikeRigError: The readings file cannot be read.
    """
    if settings.readings is None:
        static = _bag_readings(session)
        return static, static.path, ""
    static = load_static_readings(settings.readings)
    recorded = session.static_readings
    what = (str(recorded.source) or "recorded") if recorded is not None else "none recorded"
    note = f"static readings from {settings.readings} instead of the bag's ({what}); its periods ignored"
    return static, str(settings.readings), note


def replay_session(session: RecordedSession, settings: ReplaySettings | None = None) -> ReplayResult:
    """Recompute a session read from a bag (see the module docstring).

    Raises:
        ReplayError: No static readings (or an incomplete set), no trials, or unusable
            recorded settings.
        BikeRigError: The static readings are impossible (as the parameter node would say),
            or the readings file cannot be read.
    """
    settings = settings or ReplaySettings()
    bag = session.path
    if not session.trials:
        raise ReplayError(bag, "no trials recorded (no gyro batches, trial events or period estimates)")
    static, readings_from, readings_note = _static_readings(session, settings)
    live_method, live_rider, live_convention = _recorded_settings(session)
    method = settings.com_method or live_method or ComMethod.CENTROID
    rider = settings.rider if settings.rider is not None else (live_rider or "")
    convention = settings.sigma_convention or live_convention or SigmaConvention.CORRELATED

    session_options = _session_options(session)
    live_estimates = _live_estimates(session, static, method)
    chosen = {
        tid: _trial_options(live_estimates.get(tid), session_options, settings.fit, f"trial {tid}", bag)
        for tid in session.trials
    }
    speeds = _speeds(session)
    graph = OfflineGraph(
        static,
        GraphSettings(com_method=method, rider=rider, convention=convention, speeds=speeds),
        origin=f"{bag} (replayed fits)",
    )
    unfit = [tid for tid, t in session.trials.items() if _estimate_only(t)]
    fit = (_input(t) for t in session.trials.values() if t.trial_id not in unfit)
    run = graph.run(fit, lambda t: chosen[t.trial_id][0])
    notes = [readings_note] if readings_note else []
    notes += session.notes
    notes += [f"trial {tid} left out: only its period estimate was recorded (no gyro data to fit)" for tid in unfit]
    notes += [f"trial {tid} left out: {why}" for tid, why in run.rejected.items()]
    used = {tid for p in run.session.periods for tid in p.trial_ids}
    trials = tuple(
        SessionTrial(
            r,
            used=r.trial_id in used,
            note=run.rejected.get(r.trial_id, ""),
            options_from=chosen[r.trial_id][1],
            recorded=live_estimates.get(r.trial_id),
            source=bag,
        )
        for r in run.trials
    )
    if session.stray_batches:
        notes.append(f"{session.stray_batches} gyro batches outside any trial ignored")
    if session.live_order == BY_LOG_TIME:
        notes.append(
            "the live results were taken in log-time order (the recorder's order could not be read): "
            "after a step of its clock they may not be the last ones published"
        )
    result, matrices, stability = run.session, run.matrices, run.stability
    out = ReplayResult(
        bag=bag,
        bicycle=static.bicycle,
        trials=trials,
        session=result,
        matrices=matrices,
        stability=stability,
        com_method=method,
        rider=rider,
        sigma_convention=convention,
        speeds=speeds,
        fit_overridden=settings.fit.active,
        notes=tuple(notes),
        live=LiveComparison((), 0, ()),
        readings=readings_from,
        readings_swapped=settings.readings is not None,
    )
    return dataclasses.replace(out, live=compare_with_live(out, session))


def replay_bag(path: str | Path, settings: ReplaySettings | None = None) -> ReplayResult:
    """Read a bag and recompute its session.

    Raises:
        BagError: The bag cannot be read or replayed (one line naming the bag and the reason).
    """
    return replay_session(read_session(path), settings)


# ---------------------------------------------------------------- plain data


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def result_json(result: ReplayResult) -> dict[str, Any]:
    """The replay as one JSON object.

    ``bike-rig params --json``'s ``bicycle`` and ``parameters`` (null when incomplete), plus
    ``weave_speed``, ``capsize_speed`` (null when absent), their σ, ``trials``, the settings and
    the comparison with the live results.
    """
    ps = result.parameters
    parameters = None
    if ps is not None:
        pv = ps.parameters
        parameters = {k: {"value": pv.value(k), "sigma": pv.sigma(k)} for k in pv.names}
    st = result.stability

    def speed(s: Any) -> tuple[float | None, float | None]:
        return (None, None) if s is None else (_num(s.speed), _num(s.sigma))

    weave, weave_sigma = speed(st.weave if st else None)
    capsize, capsize_sigma = speed(st.capsize if st else None)
    trials = [
        {
            "trial_id": r.trial_id,
            "measurement_key": r.key,
            "period": _num(r.result.period),
            "period_sigma": _num(r.result.period_sigma),
            "valid": r.result.valid,
            "flags": list(r.result.flag_codes),
            "used": r.used,
            "n_samples": r.result.n_samples,
            "n_expected": r.result.n_expected,
            "window": list(r.result.window),
            "fit_options": json.loads(r.result.fit_options_json),
            "fit_options_from": r.options_from,
            "live_period": None if r.recorded is None else _num(r.recorded.period),
        }
        for r in result.trials
    ]
    live = result.live
    return {
        "bicycle": result.bicycle,
        "parameters": parameters,
        "weave_speed": weave,
        "capsize_speed": capsize,
        "weave_speed_sigma": weave_sigma,
        "capsize_speed_sigma": capsize_sigma,
        "complete": result.complete,
        "missing": list(result.session.missing),
        "periods": [
            {"key": p.key, "value": p.value, "sigma": p.sigma, "trial_ids": list(p.trial_ids)}
            for p in result.session.periods
        ],
        "trials": trials,
        "settings": {
            "com_method": result.com_method.value,
            "rider": result.rider,
            "sigma_convention": result.sigma_convention.value,
            "fit_overridden": result.fit_overridden,
            "readings": result.readings,
            "readings_swapped": result.readings_swapped,
        },
        "live": {
            "identical": live.identical and not live.missing,
            "compared_trials": live.compared_trials,
            "max_relative_difference": {
                d.what: (None if math.isinf(d.max_relative) else d.max_relative) for d in live.differences
            },
            "differences": [f"{d.what}: {d.detail}" for d in live.differences if not d.identical],
            "largest_in_sigma": _num(live.largest_in_sigma),
            "not_compared": list(live.missing),
        },
        "notes": list(result.notes),
    }
