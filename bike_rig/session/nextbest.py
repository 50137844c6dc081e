"""The next-best measurement: which open or repeatable item would most reduce the speeds' σ.

First-order propagation through the existing uncertainty code: the weave and capsize speeds'
variance is split over the raw readings by
:func:`~bike_rig.core.uncertainty.budget.uncertainty_budget`, and each item is scored by how
much measuring it again would shrink that variance (:func:`next_best` states the method).
Units: each item's σ in its key's unit (s for periods; degree for ``gamma``, ``alpha*``);
speeds' σ in m/s.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..core.benchmark import ComMethod, compute_parameters
from ..core.errors import BikeRigError
from ..core.measurements import Measurements, hung_parts, is_period_key, orientation_indices, required_keys
from ..core.rider import add_rider, resolve_rider
from ..core.sim.rig import ReadingSigma
from ..core.sim.session import reading_sigma
from ..core.uncertainty.budget import CAPSIZE, WEAVE, BudgetError, UncertaintyBudget, uncertainty_budget
from .readings import reading_unit

__all__ = [
    "READING",
    "TRIAL",
    "NextBestError",
    "PeriodTrials",
    "Suggestion",
    "next_best",
    "nominal_reading_sigmas",
    "sigma_after_one_more_trial",
]

#: Kind of an item measured again by typing a reading.
READING = "reading"
#: Kind of an item measured again by recording a trial.
TRIAL = "trial"


class NextBestError(BikeRigError):
    """The ranking was given something it cannot use (e.g. no nominal σ for a reading)."""


@dataclass(frozen=True)
class PeriodTrials:
    """The usable trials of one period key so far.

    Attributes:
        sigmas: Each usable trial's fit σ, s.
    """

    sigmas: tuple[float, ...]

    @classmethod
    def from_count(cls, combined_sigma: float, count: int) -> PeriodTrials:
        """``count`` trials of equal σ whose combination has σ ``combined_sigma`` (s)."""
        return cls((combined_sigma * math.sqrt(count),) * count)


@dataclass(frozen=True)
class Suggestion:
    """One item measured again (or for the first time) and what it is expected to do.

    Attributes:
        key: The reading's or period's flat key (``mF``, ``gamma``, ``TtB2``).
        kind: ``"reading"`` or ``"trial"``.
        missing: The parameters lack this item (no reading or usable trial yet: absent, or
            a value or σ that is not finite).
        sigma: Its σ now, in the key's unit (inf when missing).
        sigma_after: Its expected σ after the measurement.
        weave_sigma: The weave speed's σ now, m/s (NaN while incomplete or without a weave speed).
        weave_sigma_after: Its predicted σ after the measurement, m/s.
        capsize_sigma: The capsize speed's σ now, m/s (NaN likewise).
        capsize_sigma_after: Its predicted σ after, m/s.
        score: Sum of the speeds' relative variance reductions (inf for a missing item, NaN
            when unranked).
    """

    key: str
    kind: str
    missing: bool
    sigma: float
    sigma_after: float
    weave_sigma: float
    weave_sigma_after: float
    capsize_sigma: float
    capsize_sigma_after: float
    score: float

    @property
    def weave_reduction(self) -> float:
        """Predicted reduction of the weave speed's σ, m/s."""
        return self.weave_sigma - self.weave_sigma_after

    @property
    def capsize_reduction(self) -> float:
        """Predicted reduction of the capsize speed's σ, m/s."""
        return self.capsize_sigma - self.capsize_sigma_after

    def describe(self) -> str:
        """One line for the console, e.g. ``mF (reading): σ 0.3 → 0.02 kg; weave σ 0.3 → 0.047 m/s; ...``."""
        unit = "s" if self.kind == TRIAL else reading_unit(self.key)
        what = "one more trial" if self.kind == TRIAL else "take it again"
        if self.missing:
            return f"{self.key} ({self.kind}): missing, needed for the parameters"
        head = f"{self.key} ({what}): σ {self.sigma:.2g} → {self.sigma_after:.2g} {unit}"
        if math.isnan(self.score):
            return f"{head}; the speeds' σ once the parameters are complete"
        speeds = [
            f"{name} σ {now:.3g} → {after:.3g} m/s"
            for name, now, after in (
                ("weave", self.weave_sigma, self.weave_sigma_after),
                ("capsize", self.capsize_sigma, self.capsize_sigma_after),
            )
            if math.isfinite(now)
        ]
        return "; ".join([head, *speeds])


def nominal_reading_sigmas(sigma: ReadingSigma, keys: Sequence[str]) -> dict[str, float]:
    """The rig's nominal σ of each static reading in ``keys`` (periods skipped), in the key's unit."""
    return {k: reading_sigma(k, sigma) for k in keys if not is_period_key(k)}


def sigma_after_one_more_trial(combined_sigma: float, trial_sigmas: Sequence[float], typical_sigma: float) -> float:
    """σ of a period key after one more trial of σ ``typical_sigma`` (s), combined as combine_periods does.

    Args:
        combined_sigma: The key's combined σ now, s (Birge inflation included).
        trial_sigmas: The usable trials' σ, s; empty: one trial of ``combined_sigma``.
        typical_sigma: The new trial's expected σ, s.

    Returns:
        ``max(1, σ_combined/σ_internal) / sqrt(Σ 1/σ_i² + 1/σ_t²)``, s.
    """
    sigmas = [s for s in trial_sigmas if math.isfinite(s) and s > 0] or [combined_sigma]
    weight = sum(1.0 / (s * s) for s in sigmas)
    internal = 1.0 / math.sqrt(weight)
    birge = max(1.0, combined_sigma / internal) if math.isfinite(combined_sigma) else 1.0
    return birge / math.sqrt(weight + 1.0 / (typical_sigma * typical_sigma))


def _required(m: Measurements) -> list[str]:
    keys = list(required_keys(m.readings))
    for part in hung_parts(m.readings):
        for i in orientation_indices(m.readings, part):
            keys += [f"alpha{part}{i}", f"a{part}{i}", f"Tt{part}{i}"]
    return keys


def _item_keys(items: Sequence[str]) -> list[str]:
    """Plan item ids (``mF``, ``TtB2#3``) to keys, first appearance kept."""
    out: list[str] = []
    for item in items:
        key = item.split("#", 1)[0].strip()
        if key and key not in out:
            out.append(key)
    return out


@dataclass(frozen=True)
class _Speed:
    sigma: float
    contributions: Mapping[str, float]


def _speeds(b: UncertaintyBudget) -> dict[str, _Speed]:
    out = {}
    for name in (WEAVE, CAPSIZE):
        try:
            o = b.output(name)
        except BudgetError:
            continue  # the bicycle has no such speed
        if math.isfinite(o.sigma) and o.sigma > 0:
            out[name] = _Speed(o.sigma, {s.input: s.contribution for s in o.shares})
    return out


def _after(speed: _Speed, key: str, sigma: float, sigma_after: float) -> float:
    c = speed.contributions.get(key, 0.0)
    if c == 0.0 or not sigma > 0:
        return speed.sigma
    var = speed.sigma**2 - c * c + (c * sigma_after / sigma) ** 2
    return math.sqrt(max(var, 0.0))


def _sigma_after(
    key: str,
    sigma: float,
    nominal_sigma: Mapping[str, float],
    trials: Mapping[str, PeriodTrials],
    typical_trial_sigma: Mapping[str, float],
) -> float:
    if not is_period_key(key):
        if key not in nominal_sigma:
            raise NextBestError(f"reading '{key}': no nominal σ given for a retaken reading")
        return float(nominal_sigma[key])
    got = trials.get(key, PeriodTrials(()))
    usable = [s for s in got.sigmas if math.isfinite(s) and s > 0]
    typical = typical_trial_sigma.get(key) or (statistics.median(usable) if usable else sigma)
    return sigma_after_one_more_trial(sigma, usable, float(typical))


def _kind(key: str) -> str:
    return TRIAL if is_period_key(key) else READING


def _unranked(key: str, sigma: float, missing: bool) -> Suggestion:
    nan = math.nan
    return Suggestion(key, _kind(key), missing, sigma, nan, nan, nan, nan, nan, math.inf if missing else nan)


def next_best(
    measurements: Measurements,
    items: Sequence[str],
    nominal_sigma: Mapping[str, float],
    trials: Mapping[str, PeriodTrials] | None = None,
    *,
    typical_trial_sigma: Mapping[str, float] | None = None,
    rider: str = "",
    com_method: ComMethod | str = ComMethod.CENTROID,
) -> tuple[Suggestion, ...]:
    """Rank the items by how much measuring each again would reduce the speeds' σ.

    Readings are independent, so a speed's variance is σ_v² = Σ_j c_j², c_j = |∂v/∂x_j| σ_j
    (the budget's correlated convention, with the model node's rider). Remeasuring item j
    changes only σ_j → σ_j', so σ_v'² = σ_v² − c_j² + c_j² (σ_j'/σ_j)². A retaken reading gets
    its nominal σ (the newer wins). One more trial combines as ``combine_periods`` does:
    σ' = 1 / sqrt(Σ 1/σ_i² + 1/σ_t²) times the current Birge factor (assumed to persist). The
    score is Σ over the bicycle's speeds of (σ_v² − σ_v'²) / σ_v²; ties keep plan order. While
    the set is incomplete the missing keys come first (σ and score infinite), the rest follow
    unranked (NaN). An item of σ 0 has no sensitivity and no predicted change.

    Args:
        measurements: The session's readings now: every static reading (the newest entry of
            each key) and every period key's combined value ± σ, as the parameter stage
            merges them (:func:`bike_rig.pipeline.assemble.merged_readings`).
        items: The plan's open and repeatable items, in plan order: reading keys and period
            keys (trial item ids ``TtB2#3`` count as their key).
        nominal_sigma: σ of a retaken static reading by key, in the key's unit
            (:func:`nominal_reading_sigmas`).
        trials: Each period key's usable trials; a key not given counts as one trial of its
            combined σ.
        typical_trial_sigma: The expected σ of one more trial of a key, s (default: the median
            of its usable trials' σ).
        rider: The model node's rider: ``""`` or ``"paper"``.
        com_method: The parameter stage's mass-centre method.

    Returns:
        Every item (and, while incomplete, every other missing key) as a suggestion, best first.

    Raises:
        NextBestError: A reading item has no nominal σ.
        GeometryError: The hanging orientations are degenerate (the parameters cannot be
            computed even when complete).
    """
    keys = _item_keys(items)
    readings = measurements.readings
    have = {k for k, r in readings.items() if math.isfinite(r.value) and math.isfinite(r.sigma)}
    missing = [k for k in keys if k not in have]
    missing += [k for k in _required(measurements) if k not in have and k not in missing]
    if missing:
        rest = [_unranked(k, readings[k].sigma, False) for k in keys if k not in missing]
        return tuple([_unranked(k, math.inf, True) for k in missing] + rest)
    ps = compute_parameters(measurements, ComMethod(com_method))
    r = resolve_rider(rider, files=False)
    speeds = _speeds(uncertainty_budget(ps if r is None else add_rider(ps, r)))
    trials = trials or {}
    typical = typical_trial_sigma or {}
    nan = math.nan
    out = []
    for key in keys:
        sigma = readings[key].sigma
        after = _sigma_after(key, sigma, nominal_sigma, trials, typical)
        now = {name: s.sigma for name, s in speeds.items()}
        later = {name: _after(s, key, sigma, after) for name, s in speeds.items()}
        score = sum((now[n] ** 2 - later[n] ** 2) / now[n] ** 2 for n in speeds)
        out.append(
            Suggestion(
                key,
                _kind(key),
                False,
                sigma,
                after,
                now.get(WEAVE, nan),
                later.get(WEAVE, nan),
                now.get(CAPSIZE, nan),
                later.get(CAPSIZE, nan),
                score,
            )
        )
    return tuple(sorted(out, key=lambda s: -s.score))
