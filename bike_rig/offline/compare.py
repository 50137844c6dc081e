"""A replay against the live graph's results recorded in the same bag.

With the same settings every number agrees to :data:`RELATIVE_TOLERANCE` (bit for bit in
practice): each trial's last period estimate, the last parameter set, matrices and sweep, "last"
in the publishers' own order (:mod:`bike_rig.bag.order`), never log time or stamps. With other
settings (or another fit) results differ, and how much is said in units of the live σ: the
largest move of a period, parameter or critical speed over its σ
(:attr:`LiveComparison.largest_in_sigma`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..messages import MessageError, model_matrices_from_msg, session_parameters_from_msg, stability_sweep_from_msg
from ..pipeline.errors import AssemblyError
from ..pipeline.model import ModelMatrices, StabilitySweep
from ..pipeline.offline import SessionTrial
from .session import RecordedSession

if TYPE_CHECKING:
    from .replay import ReplayResult

__all__ = ["RELATIVE_TOLERANCE", "Difference", "LiveComparison", "compare_with_live", "in_sigma", "relative_difference"]

#: Replayed and live numbers that agree to this (relative) are called identical.
RELATIVE_TOLERANCE = 1e-12


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
    in_sigma: float = math.nan
    """Largest |replay − live| / (live σ) of its values that have a σ (NaN: none)."""

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

    def largest_move(self, trials: bool) -> Difference | None:
        """The comparison whose values moved most in units of their live σ (None: none has a σ).

        Of the trial fits' periods (``trials``), or of the results: combined periods, parameters,
        critical speeds.
        """
        moved = [d for d in self.differences if not math.isnan(d.in_sigma) and d.what.startswith("trial ") == trials]
        return max(moved, key=lambda d: d.in_sigma, default=None)

    @property
    def largest_in_sigma(self) -> float:
        """The largest move of a value with a σ (periods, parameters, speeds), in live σ (NaN: none)."""
        moves = [d.in_sigma for d in self.differences if not math.isnan(d.in_sigma)]
        return max(moves, default=math.nan)

    @property
    def worst(self) -> Difference | None:
        """The largest difference."""
        return max(self.differences, key=lambda d: d.max_relative, default=None)


def relative_difference(a: Any, b: Any) -> tuple[float, int]:
    """Largest relative difference of two arrays, and where it is.

    The largest ``|a - b| / max(|a|, |b|)`` over the entries (0 where both are equal, NaN
    included) and where it is; inf if the shapes differ or one side alone is NaN.
    """
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


def in_sigma(new: ArrayLike, live: ArrayLike, sigma: ArrayLike) -> float:
    """The largest |new − live| / sigma over values with a finite, positive σ (NaN: none)."""
    x, y, s = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (new, live, sigma))
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(s) & (s > 0)
    return float(np.max(np.abs(x[ok] - y[ok]) / s[ok])) if np.any(ok) else math.nan


def _diff(what: str, a: Any, b: Any, names: Sequence[str] | None = None, moved: float = math.nan) -> Difference:
    rel, k = relative_difference(a, b)
    if rel == 0.0:
        return Difference(what, 0.0, in_sigma=moved)
    if k < 0:
        return Difference(what, rel, "different sizes")
    label = names[k] if names is not None and k < len(names) else f"entry {k}"
    x = float(np.asarray(a, dtype=np.float64).reshape(-1)[k])
    y = float(np.asarray(b, dtype=np.float64).reshape(-1)[k])
    return Difference(what, rel, f"{label}: replay {x!r}, live {y!r}", moved)


def _trial_difference(r: SessionTrial) -> Difference:
    assert r.recorded is not None
    live, new = r.recorded, r.result
    what = f"trial {r.trial_id}"
    if (live.valid, live.flag_codes, live.measurement_key) != (new.valid, new.flag_codes, new.measurement_key):
        detail = (
            f"replay valid={new.valid} flags={list(new.flag_codes)}, "
            f"live valid={live.valid} flags={list(live.flag_codes)}"
        )
        return Difference(what, math.inf, detail)
    names = (
        "period",
        "period_sigma",
        "zeta",
        "omega",
        "r2",
        "residual_rms",
        "n_samples",
        "window_start",
        "window_stop",
    )
    nf, lf = new.fit, live.fit
    a = [nf.period, nf.period_sigma, nf.zeta, nf.omega, nf.r2, nf.residual_rms, new.n_samples, *new.window]
    b = [lf.period, lf.period_sigma, lf.zeta, lf.omega, lf.r2, lf.residual_rms, live.n_samples, *live.window]
    return _diff(what, a, b, names, in_sigma([nf.period], [lf.period], [lf.period_sigma]))


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
        diffs.append(
            Difference(
                "parameters",
                math.inf,
                f"replay complete={result.complete}, live complete="
                f"{bool(live_ps.complete)} (missing {', '.join(str(k) for k in live_ps.missing)})",
            )
        )
    elif result.parameters is not None:
        try:
            ps = session_parameters_from_msg(live_ps).complete_parameters()
        except (MessageError, AssemblyError) as exc:
            diffs.append(Difference("parameters", math.inf, f"live parameter set unreadable: {exc}"))
        else:
            pv, lv = result.parameters.parameters, ps.parameters
            diffs.append(_diff("parameters", pv.values, lv.values, pv.names, in_sigma(pv.values, lv.values, lv.sigmas)))
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
        return Difference(
            what,
            math.inf,
            f"replay has periods for {', '.join(new_keys) or 'no key'}, live for {', '.join(live_keys) or 'no key'}",
        )
    live_trials = sorted(str(t) for t in msg.trial_ids)
    new_trials = sorted(f"{p.key}:{t}" for p in result.session.periods for t in p.trial_ids)
    if live_trials != new_trials:
        extra = sorted(set(new_trials) ^ set(live_trials))
        return Difference(what, math.inf, f"other trials combined ({', '.join(extra[:5])})")
    values = [v for p in result.session.periods for v in (p.value, p.sigma)]
    live = [v for pair in zip(msg.period_values, msg.period_sigmas) for v in pair]
    names = [f"{k}{s}" for k in new_keys for s in ("", " sigma")]
    return _diff(what, values, live, names, in_sigma(values[::2], live[::2], live[1::2]))


def _compare_matrices(new: ModelMatrices, msg: Any, diffs: list[Difference]) -> None:
    try:
        live = model_matrices_from_msg(msg)
    except MessageError as exc:
        diffs.append(Difference("canonical matrices", math.inf, f"live matrices unreadable: {exc}"))
        return
    if (live.rider, live.convention) != (new.rider, new.convention):
        diffs.append(
            Difference(
                "canonical matrices",
                math.inf,
                f"live rider '{live.rider}' σ {live.convention.value}, "
                f"replay rider '{new.rider}' σ {new.convention.value}",
            )
        )
        return
    names = ("M", "C1", "K0", "K2")
    diffs.append(
        _diff(
            "canonical matrices", [getattr(new.matrices, n) for n in names], [getattr(live.matrices, n) for n in names]
        )
    )
    diffs.append(
        _diff("matrix sigmas", [getattr(new.sigma, n) for n in names], [getattr(live.sigma, n) for n in names])
    )


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
        a, b = _speed_values(getattr(new, name)), _speed_values(getattr(live, name))
        diffs.append(
            _diff(f"{name} speed", a, b, (f"{name} speed", f"{name} speed sigma"), in_sigma(a[:1], b[:1], b[1:]))
        )
    sweep_new, sweep_live = new.sweep, live.sweep
    if sweep_new.speeds.shape == sweep_live.speeds.shape:
        both = np.concatenate([sweep_new.eigenvalues.real.ravel(), sweep_new.eigenvalues.imag.ravel()])
        other = np.concatenate([sweep_live.eigenvalues.real.ravel(), sweep_live.eigenvalues.imag.ravel()])
        diffs.append(_diff("eigenvalues", both, other))
