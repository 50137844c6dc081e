"""Recompute a recorded session offline, with no ROS runtime: the same functions the live nodes
run, on the messages the bag holds.

1. Trials: every trial's GyroBatch messages (in receiving order) and its START and STOP/ABORT
   events go through the fitter node's ROS-free :func:`bike_rig.nodes.fitter.fit_trial`, with
   the fit options recorded in the trial's ``PeriodEstimate.fit_options_json`` (the options of
   the session's other estimates for a trial without one, the defaults without any), unless
   the caller overrides them.
2. Parameters: the static readings of the bag's ``StaticReadings`` message
   (:func:`bike_rig.messages.static_readings_from_msg`) and the trials' periods go through the
   parameter node's :class:`bike_rig.core.assembly.SessionAssembly` (dedupe by trial id,
   combine each key's usable trials in trial-id order, :func:`compute_parameters`), with the
   mass-centre method the live parameter set names.
3. Model: :func:`bike_rig.core.assembly.compute_model` (canonical matrices with σ, eigenvalue
   sweep, weave and capsize speeds with σ), with the rider, σ convention and speeds of the
   recorded model.

:func:`compare_with_live` then compares every number with what the live graph published (the
last period estimate of each trial, the last parameter set, matrices and sweep): with the same
settings they agree to 1e-12 relative, bit for bit in practice.

Nothing here imports rclpy (the fitter module builds its node lazily).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import topics
from ..core.assembly import (
    AssemblyError,
    ModelMatrices,
    SessionAssembly,
    SessionParameters,
    StabilitySweep,
    TrialPeriod,
    compute_model,
)
from ..core.benchmark import ComMethod, ParameterSet
from ..core.measurements import Measurements
from ..core.period import WindowPolicy
from ..core.uncertainty.matrix_sigma import SigmaConvention
from ..messages import (
    MessageError,
    model_matrices_from_msg,
    parameter_set_from_msg,
    stability_sweep_from_msg,
    static_readings_from_msg,
    trial_period_from_msg,
)
from ..nodes.fitter import TrialFit, TrialFitOptions, fit_trial
from .errors import ReplayError
from .session import RecordedSession, RecordedTrial, read_session

__all__ = [
    "DEFAULT_SPEEDS",
    "RELATIVE_TOLERANCE",
    "Difference",
    "FitOverrides",
    "LiveComparison",
    "ReplayResult",
    "ReplaySettings",
    "ReplayedTrial",
    "compare_with_live",
    "relative_difference",
    "replay_bag",
    "replay_session",
    "result_json",
    "trial_period",
]

#: The model node's default sweep (speed_min 0, speed_max 10, speed_count 201), m/s.
DEFAULT_SPEEDS = np.linspace(0.0, 10.0, 201)
#: Replayed and live numbers that agree to this (relative) are called identical.
RELATIVE_TOLERANCE = 1e-12


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
            v is not None for k, v in dataclasses.asdict(self).items() if k != "use_defaults"
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
        rider: Rider of the model, "" or "paper" (None: the live model's, else none).
        sigma_convention: σ convention (None: the live model's, else correlated).
    """

    fit: FitOverrides = field(default_factory=FitOverrides)
    com_method: ComMethod | None = None
    rider: str | None = None
    sigma_convention: SigmaConvention | None = None


@dataclass(frozen=True)
class ReplayedTrial:
    """One trial fitted again.

    Attributes:
        trial_id: The trial.
        fit: The fitter's result.
        period: What the parameter node takes from it.
        options_from: Where the fit options came from: ``recorded`` (this trial's estimate),
            ``session`` (the session's other estimates), ``default`` or ``override``.
        recorded: The live estimate of the trial (the one the parameter node kept), or None.
        used: It entered its key's combination.
        note: Why the assembly left it out ("" when it did not).
    """

    trial_id: str
    fit: TrialFit
    period: TrialPeriod
    options_from: str
    recorded: TrialPeriod | None
    used: bool = False
    note: str = ""


@dataclass(frozen=True)
class Difference:
    """How far a replayed quantity is from the live one.

    Attributes:
        what: What is compared, e.g. ``parameters`` or ``trial frame_torsional_o2_t3``.
        max_relative: Largest relative difference over its numbers (0: identical bits;
            inf: one side is missing or the shapes differ).
        detail: The worst entry, or what is missing.
    """

    what: str
    max_relative: float
    detail: str = ""

    @property
    def identical(self) -> bool:
        """Within :data:`RELATIVE_TOLERANCE`."""
        return self.max_relative <= RELATIVE_TOLERANCE


@dataclass(frozen=True)
class LiveComparison:
    """The replay against the live graph's results.

    Attributes:
        differences: One entry per compared quantity.
        compared_trials: Trials with a live estimate and a replayed fit.
        missing: What the live graph did not publish (or the bag did not record).
    """

    differences: tuple[Difference, ...]
    compared_trials: int
    missing: tuple[str, ...]

    @property
    def identical(self) -> bool:
        """Every compared quantity within :data:`RELATIVE_TOLERANCE`."""
        return all(d.identical for d in self.differences)

    @property
    def worst(self) -> Difference | None:
        """The largest difference."""
        return max(self.differences, key=lambda d: d.max_relative, default=None)


@dataclass(frozen=True)
class ReplayResult:
    """Everything recomputed from a bag.

    Attributes:
        bag: The bag, as given.
        bicycle: The bicycle's name.
        trials: Every trial fitted, in the order first heard of.
        session: The assembly's result (periods per key, missing keys, the parameter set).
        matrices: Canonical matrices with σ (None when incomplete).
        stability: Sweep and critical speeds with σ (None when incomplete).
        com_method: Mass-centre method used.
        rider: Rider of the model ("" none).
        sigma_convention: σ convention used.
        speeds: Speeds of the sweep, m/s.
        fit_overridden: The fit settings differ from the recorded ones.
        notes: What the replay left out, and why.
        live: The comparison with the live results.
    """

    bag: str
    bicycle: str
    trials: tuple[ReplayedTrial, ...]
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

    @property
    def parameters(self) -> ParameterSet | None:
        """The 25 parameters and g with σ (None when a period is missing)."""
        return self.session.parameters

    @property
    def complete(self) -> bool:
        """Every period was obtained and the parameters computed."""
        return self.session.complete


# ---------------------------------------------------------------- trials


def trial_period(r: TrialFit) -> TrialPeriod:
    """What the parameter node reads from the ``PeriodEstimate`` the fitter publishes for ``r``
    (the same fields, the same floats)."""
    return TrialPeriod(
        trial_id=r.trial_id,
        measurement_key=r.measurement_key,
        period=float(r.period),
        period_sigma=float(r.period_sigma),
        valid=bool(r.valid),
        flags=tuple(r.flags),
        flag_reasons=tuple(r.flag_reasons),
        zeta=float(r.zeta),
        omega=float(r.omega),
        r2=float(r.r2),
        residual_rms=float(r.residual_rms),
        n_samples=int(r.n_samples),
        n_expected=int(r.n_expected),
        window=(int(r.window_start), int(r.window_stop)),
        fit_options_json=r.fit_options_json,
        stamp_ns=int(r.stamp_ns),
    )


def _options(text: str, where: str, bag: str) -> TrialFitOptions:
    try:
        return TrialFitOptions.from_json(text)
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise ReplayError(bag, f"{where}: fit_options_json is not the fitter's options ({exc})") from None


def _session_options(session: RecordedSession) -> TrialFitOptions | None:
    """The fit options most of the session's estimates name (the fitter's settings)."""
    texts = Counter(str(e.fit_options_json) for t in session.trials.values() for e in t.estimates if e.fit_options_json)
    if not texts:
        return None
    text, _ = texts.most_common(1)[0]
    return _options(text, "a period estimate", session.path)


def _live_estimates(session: RecordedSession, static: Measurements, method: ComMethod) -> dict[str, TrialPeriod]:
    """The estimate of each trial the live parameter node kept: every recorded PeriodEstimate
    goes through a :class:`SessionAssembly` in the order received (its rules decide which one
    of a trial's re-publications stays)."""
    live = SessionAssembly(static, method, origin=topics.PERIODS.name)
    for t in session.trials.values():
        for msg in t.estimates:
            try:
                live.add(trial_period_from_msg(msg))
            except (AssemblyError, MessageError):
                continue
    kept = {p.trial_id: p for p in live.trials}
    # trials whose estimates the assembly refused (e.g. an unknown key): their last one
    for t in session.trials.values():
        if t.trial_id not in kept and t.estimate is not None:
            try:
                kept[t.trial_id] = trial_period_from_msg(t.estimate)
            except MessageError:
                continue
    return kept


def _fit(
    t: RecordedTrial,
    recorded: TrialPeriod | None,
    session_options: TrialFitOptions | None,
    overrides: FitOverrides,
    bag: str,
) -> ReplayedTrial:
    if recorded is not None and recorded.fit_options_json:
        options, source = _options(recorded.fit_options_json, f"trial {t.trial_id}", bag), "recorded"
    elif session_options is not None:
        options, source = session_options, "session"
    else:
        options, source = TrialFitOptions(), "default"
    if overrides.active:
        options, source = overrides.apply(options), "override"
    fit = fit_trial(t.batches, t.start, t.stop, options)
    return ReplayedTrial(t.trial_id, fit, trial_period(fit), source, recorded)


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


def replay_session(session: RecordedSession, settings: ReplaySettings | None = None) -> ReplayResult:
    """Recompute a session read from a bag (see the module docstring).

    Raises:
        ReplayError: No static readings, no trials, or unusable recorded settings.
        BikeRigError: The static readings are impossible (as the parameter node would say).
    """
    settings = settings or ReplaySettings()
    bag = session.path
    if session.static_readings is None:
        raise ReplayError(
            bag,
            "no StaticReadings message: the bag must be recorded while the parameter node runs "
            "(it publishes the static readings latched)",
        )
    if not session.trials:
        raise ReplayError(bag, "no trials recorded (no gyro batches, trial events or period estimates)")
    try:
        static = static_readings_from_msg(session.static_readings)
    except MessageError as exc:
        raise ReplayError(bag, f"the StaticReadings message is malformed ({exc})") from None
    live_method, live_rider, live_convention = _recorded_settings(session)
    method = settings.com_method or live_method or ComMethod.CENTROID
    rider = settings.rider if settings.rider is not None else (live_rider or "")
    convention = settings.sigma_convention or live_convention or SigmaConvention.CORRELATED

    session_options = _session_options(session)
    live_estimates = _live_estimates(session, static, method)
    fitted = [_fit(t, live_estimates.get(t.trial_id), session_options, settings.fit, bag)
              for t in session.trials.values()]  # fmt: skip
    assembly = SessionAssembly(static, method, origin=f"{bag} (replayed fits)")
    notes: list[str] = []
    rejected: dict[str, str] = {}
    for r in fitted:
        try:
            assembly.add(r.period)
        except AssemblyError as exc:
            rejected[r.trial_id] = str(exc)
            notes.append(f"trial {r.trial_id} left out: {exc}")
    result = assembly.result()
    used = {tid for p in result.periods for tid in p.trial_ids}
    trials = tuple(dataclasses.replace(r, used=r.trial_id in used, note=rejected.get(r.trial_id, "")) for r in fitted)
    if session.stray_batches:
        notes.append(f"{session.stray_batches} gyro batches outside any trial ignored")

    speeds = _speeds(session)
    matrices = stability = None
    if result.parameters is not None:
        matrices, stability = compute_model(result.parameters, speeds, rider, convention)
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
    )
    return dataclasses.replace(out, live=compare_with_live(out, session))


def replay_bag(path: str | Path, settings: ReplaySettings | None = None) -> ReplayResult:
    """Read a bag and recompute its session.

    Raises:
        BagError: The bag cannot be read or replayed (one line naming the bag and the reason).
    """
    return replay_session(read_session(path), settings)


# ---------------------------------------------------------------- comparison


def relative_difference(a: Any, b: Any) -> tuple[float, int]:
    """Largest ``|a - b| / max(|a|, |b|)`` over the entries (0 where both are equal, NaN
    included) and where it is; inf if the shapes differ or one side alone is NaN."""
    x = np.asarray(a, dtype=np.float64).reshape(-1)
    y = np.asarray(b, dtype=np.float64).reshape(-1)
    if x.shape != y.shape:
        return math.inf, -1
    if x.size == 0:
        return 0.0, -1
    same = (x == y) | (np.isnan(x) & np.isnan(y))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(x - y) / np.maximum(np.abs(x), np.abs(y))
    rel = np.where(same, 0.0, rel)
    rel = np.where(np.isnan(rel), math.inf, rel)
    k = int(np.argmax(rel))
    return float(rel[k]), k


def _diff(what: str, a: Any, b: Any, names: Sequence[str] | None = None) -> Difference:
    rel, k = relative_difference(a, b)
    if rel == 0.0:
        return Difference(what, 0.0)
    if k < 0:
        return Difference(what, rel, "different sizes")
    label = names[k] if names is not None and k < len(names) else f"entry {k}"
    x = float(np.asarray(a, dtype=np.float64).reshape(-1)[k])
    y = float(np.asarray(b, dtype=np.float64).reshape(-1)[k])
    return Difference(what, rel, f"{label}: replay {x!r}, live {y!r}")


def _trial_difference(r: ReplayedTrial) -> Difference:
    assert r.recorded is not None
    live, new = r.recorded, r.period
    what = f"trial {r.trial_id}"
    if (live.valid, live.flags, live.measurement_key) != (new.valid, new.flags, new.measurement_key):
        detail = f"replay valid={new.valid} flags={list(new.flags)}, live valid={live.valid} flags={list(live.flags)}"
        return Difference(what, math.inf, detail)
    names = ("period", "period_sigma", "zeta", "omega", "r2", "residual_rms", "n_samples", "window_start",
             "window_stop")  # fmt: skip
    a = [new.period, new.period_sigma, new.zeta, new.omega, new.r2, new.residual_rms, new.n_samples, *new.window]
    b = [live.period, live.period_sigma, live.zeta, live.omega, live.r2, live.residual_rms, live.n_samples,
         *live.window]  # fmt: skip
    return _diff(what, a, b, names)


def compare_with_live(result: ReplayResult, session: RecordedSession) -> LiveComparison:
    """Compare a replay with the live results recorded in the same bag."""
    diffs: list[Difference] = []
    missing: list[str] = []
    compared = [r for r in result.trials if r.recorded is not None]
    for r in compared:
        diffs.append(_trial_difference(r))
    if not compared:
        missing.append("period estimates")

    live_ps = session.final_parameters
    if live_ps is not None:
        diffs.append(_compare_periods(result, live_ps))
    if live_ps is None:
        missing.append("parameter set")
    elif bool(live_ps.complete) != result.complete:
        diffs.append(Difference("parameters", math.inf, f"replay complete={result.complete}, live complete="
                                f"{bool(live_ps.complete)} (missing {', '.join(str(k) for k in live_ps.missing)})"))
    elif result.parameters is not None:
        try:
            ps = parameter_set_from_msg(live_ps)
        except MessageError as exc:
            diffs.append(Difference("parameters", math.inf, f"live parameter set unreadable: {exc}"))
        else:
            pv, lv = result.parameters.parameters, ps.parameters
            diffs.append(_diff("parameters", pv.values, lv.values, pv.names))
            diffs.append(_diff("parameter sigmas", pv.sigmas, lv.sigmas, pv.names))
            diffs.append(_diff("parameter covariance", pv.covariance, lv.covariance))

    if result.matrices is not None and result.stability is not None:
        live_m, live_s = session.final_matrices, session.final_eigen_sweep
        if live_m is None:
            missing.append("canonical matrices")
        else:
            _compare_matrices(result.matrices, live_m, diffs)
        if live_s is None:
            missing.append("eigenvalue sweep")
        else:
            _compare_sweep(result.stability, live_s, diffs)
    return LiveComparison(tuple(diffs), len(compared), tuple(missing))


def _compare_periods(result: ReplayResult, msg: Any) -> Difference:
    """The combined period of every key (and the trials behind it) against the live set's."""
    what = "combined periods"
    live_keys = [str(k) for k in msg.period_keys]
    new_keys = [p.key for p in result.session.periods]
    if live_keys != new_keys:
        return Difference(what, math.inf, f"replay has periods for {', '.join(new_keys) or 'no key'}, "
                          f"live for {', '.join(live_keys) or 'no key'}")  # fmt: skip
    live_trials = sorted(str(t) for t in msg.trial_ids)
    new_trials = sorted(f"{p.key}:{t}" for p in result.session.periods for t in p.trial_ids)
    if live_trials != new_trials:
        extra = sorted(set(new_trials) ^ set(live_trials))
        return Difference(what, math.inf, f"other trials combined ({', '.join(extra[:5])})")
    values = [v for p in result.session.periods for v in (p.value, p.sigma)]
    live = [v for pair in zip(msg.period_values, msg.period_sigmas) for v in pair]
    names = [f"{k}{s}" for k in new_keys for s in ("", " sigma")]
    return _diff(what, values, live, names)


def _compare_matrices(new: ModelMatrices, msg: Any, diffs: list[Difference]) -> None:
    try:
        live = model_matrices_from_msg(msg)
    except MessageError as exc:
        diffs.append(Difference("canonical matrices", math.inf, f"live matrices unreadable: {exc}"))
        return
    if (live.rider, live.convention) != (new.rider, new.convention):
        diffs.append(Difference("canonical matrices", math.inf, f"live rider '{live.rider}' σ {live.convention.value}, "
                                f"replay rider '{new.rider}' σ {new.convention.value}"))  # fmt: skip
        return
    names = ("M", "C1", "K0", "K2")
    diffs.append(_diff("canonical matrices", [getattr(new.matrices, n) for n in names],
                       [getattr(live.matrices, n) for n in names]))  # fmt: skip
    diffs.append(_diff("matrix sigmas", [getattr(new.sigma, n) for n in names],
                       [getattr(live.sigma, n) for n in names]))  # fmt: skip


def _speed_values(s: Any) -> list[float]:
    return [math.nan, math.nan] if s is None else [float(s.speed), float(s.sigma)]


def _compare_sweep(new: StabilitySweep, msg: Any, diffs: list[Difference]) -> None:
    try:
        live = stability_sweep_from_msg(msg)
    except MessageError as exc:
        diffs.append(Difference("eigenvalue sweep", math.inf, f"live sweep unreadable: {exc}"))
        return
    if live.rider != new.rider:
        diffs.append(Difference("critical speeds", math.inf, f"live rider '{live.rider}', replay '{new.rider}'"))
        return
    for name in ("weave", "capsize"):
        diffs.append(_diff(f"{name} speed", _speed_values(getattr(new, name)), _speed_values(getattr(live, name)),
                           (f"{name} speed", f"{name} speed sigma")))  # fmt: skip
    sweep_new, sweep_live = new.sweep, live.sweep
    if sweep_new.speeds.shape == sweep_live.speeds.shape:
        both = np.concatenate([sweep_new.eigenvalues.real.ravel(), sweep_new.eigenvalues.imag.ravel()])
        other = np.concatenate([sweep_live.eigenvalues.real.ravel(), sweep_live.eigenvalues.imag.ravel()])
        diffs.append(_diff("eigenvalues", both, other))


# ---------------------------------------------------------------- plain data


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def result_json(result: ReplayResult) -> dict[str, Any]:
    """The replay as one JSON object: ``bike-rig params --json``'s ``bicycle`` and
    ``parameters`` (null when incomplete), plus ``weave_speed``, ``capsize_speed`` (null when
    absent), their σ, ``trials``, the settings and the comparison with the live results."""
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
            "measurement_key": r.period.measurement_key,
            "period": _num(r.period.period),
            "period_sigma": _num(r.period.period_sigma),
            "valid": r.period.valid,
            "flags": list(r.period.flags),
            "used": r.used,
            "n_samples": r.period.n_samples,
            "n_expected": r.period.n_expected,
            "window": list(r.period.window),
            "fit_options": json.loads(r.period.fit_options_json),
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
        "periods": [{"key": p.key, "value": p.value, "sigma": p.sigma, "trial_ids": list(p.trial_ids)}
                    for p in result.session.periods],  # fmt: skip
        "trials": trials,
        "settings": {
            "com_method": result.com_method.value,
            "rider": result.rider,
            "sigma_convention": result.sigma_convention.value,
            "fit_overridden": result.fit_overridden,
        },
        "live": {
            "identical": live.identical and not live.missing,
            "compared_trials": live.compared_trials,
            "max_relative_difference": {d.what: (None if math.isinf(d.max_relative) else d.max_relative)
                                        for d in live.differences},  # fmt: skip
            "differences": [f"{d.what}: {d.detail}" for d in live.differences if not d.identical],
            "not_compared": list(live.missing),
        },
        "notes": list(result.notes),
    }

