"""The numbers a report shows, computed once.

Per rider variant the parameters, canonical matrices with σ, critical speeds with σ and the
stable speed range; the uncertainty budget; with a steer-torque feedback, the closed loop's
speeds with σ and stable ranges per variant (:class:`ClosedLoop`).

Nothing here draws or formats; :mod:`.sections` turns these into HTML and :mod:`.figures`
reuses them where the figure functions accept them.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.benchmark import ComMethod, ParameterSet
from ..core.feedback import Feedback
from ..core.rider import PAPER_RIDER, Rider, add_rider
from ..core.uncertainty.budget import UncertaintyBudget, uncertainty_budget
from ..core.uncertainty.matrix_sigma import MatrixSet, SigmaConvention, canonical_with_sigma
from ..core.uncertainty.speed_mc import SpeedMonteCarlo, speed_monte_carlo, speed_monte_carlo_from_parameters
from ..core.uncertainty.speed_sigma import CriticalSpeedsWithSigma, critical_speeds_with_sigma
from ..core.whipple import stable_speed_range
from ..core.whipple.closed_loop import closed_loop_stable_range
from ..offline.subjects import Subject

__all__ = [
    "MONTE_CARLO_SAMPLES",
    "ClosedLoop",
    "ReportResults",
    "Variant",
    "compute_closed_loop",
    "compute_results",
    "compute_variant",
    "monte_carlo",
]

#: Draws of the Monte Carlo check of the speeds' σ (about 1 % standard error of a σ).
MONTE_CARLO_SAMPLES = 4000
#: Seed of its random draws (a report is reproducible).
MONTE_CARLO_SEED = 0


@dataclass(frozen=True)
class Variant:
    """One bicycle, without or with a rider.

    Attributes:
        label: ``"without rider"`` or ``"with <rider name>"``.
        rider: The rider, or None for the bare bicycle.
        parameters: The parameter set (the rider lumped into the rear frame).
        matrices: Canonical matrices M, C1, K0, K2 with σ (correlated convention).
        speeds: Weave and capsize speeds with σ (m/s), found from ``matrices``.
        stable: Speed intervals (m/s) where every eigenvalue has a negative real part;
            ``high`` may be ``inf``.
    """

    label: str
    rider: Rider | None
    parameters: ParameterSet
    matrices: MatrixSet
    speeds: CriticalSpeedsWithSigma
    stable: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class ClosedLoop:
    """The closed loop ``A − B K`` of a steer-torque feedback, per rider variant.

    Attributes:
        feedback: The feedback.
        speeds: Weave and capsize speeds of the closed loop with σ (m/s; the gains' σ too), one per
            variant (without, then with the rider).
        stable: The closed loop's stable speed intervals (m/s), one tuple per variant.
    """

    feedback: Feedback
    speeds: tuple[CriticalSpeedsWithSigma, ...]
    stable: tuple[tuple[tuple[float, float], ...], ...]


def compute_closed_loop(variants: tuple[Variant, ...], feedback: Feedback) -> ClosedLoop:
    """The closed loop of ``feedback`` for each variant (from its matrices)."""
    speeds = tuple(
        critical_speeds_with_sigma(v.parameters, SigmaConvention.CORRELATED, matrices=v.matrices, feedback=feedback)
        for v in variants
    )
    stable = tuple(closed_loop_stable_range(v.matrices.matrices, v.matrices.g, feedback) for v in variants)
    return ClosedLoop(feedback, speeds, stable)


@dataclass(frozen=True)
class ReportResults:
    """Everything numeric in a report.

    Attributes:
        bare: The bicycle alone.
        rider: The bicycle with the rider (the paper's rigid rider, Table 1, unless another is chosen).
        budget: The uncertainty budget of the bicycle alone.
        rider_budget: The budget of the bicycle with the rider (only its speeds are shown).
        monte_carlo: Monte Carlo checks of the speeds' σ, without and with the rider.
        closed_loop: The closed loop of a steer-torque feedback, or None (the open loop only).
    """

    bare: Variant
    rider: Variant
    budget: UncertaintyBudget
    rider_budget: UncertaintyBudget
    monte_carlo: tuple[SpeedMonteCarlo, ...]
    closed_loop: ClosedLoop | None = None

    @property
    def variants(self) -> tuple[Variant, Variant]:
        """Without, then with the rider."""
        return self.bare, self.rider


def compute_variant(ps: ParameterSet, rider: Rider | None) -> Variant:
    """Matrices, speeds and stable range of ``ps`` (plus ``rider`` when given)."""
    p = add_rider(ps, rider) if rider is not None else ps
    ms = canonical_with_sigma(p, SigmaConvention.CORRELATED)
    cs = critical_speeds_with_sigma(p, SigmaConvention.CORRELATED, matrices=ms)
    label = f"with {rider.name}" if rider is not None else "without rider"
    return Variant(label, rider, p, ms, cs, stable_speed_range(ms.matrices, ms.g))


def monte_carlo(subject: Subject, rider: Rider | None, samples: int = MONTE_CARLO_SAMPLES) -> SpeedMonteCarlo:
    """Monte Carlo of the weave and capsize speeds.

    Draws of the raw readings when the subject has them (with its parameters' mass-centre
    method), else of the parameters.
    """
    ps = subject.parameters
    if subject.measurements is not None and ps.raw is not None:
        used = {e.used for e in ps.com.values()} if ps.com else set()
        method = used.pop() if len(used) == 1 else ComMethod.CENTROID
        return speed_monte_carlo(subject.measurements, samples, MONTE_CARLO_SEED, method, rider)
    return speed_monte_carlo_from_parameters(ps, samples, MONTE_CARLO_SEED, rider)


def compute_results(subject: Subject, rider: Rider = PAPER_RIDER, feedback: Feedback | None = None) -> ReportResults:
    """All numbers of the report of ``subject`` (with ``rider`` as the rider variant).

    With ``feedback`` also the closed loop of each variant (everything else is the open loop's).
    """
    bare = compute_variant(subject.parameters, None)
    with_rider = compute_variant(subject.parameters, rider)
    return ReportResults(
        bare,
        with_rider,
        uncertainty_budget(bare.parameters),
        uncertainty_budget(with_rider.parameters),
        (monte_carlo(subject, None), monte_carlo(subject, rider)),
        None if feedback is None else compute_closed_loop((bare, with_rider), feedback),
    )
