"""The one offline runner: the fitting, assembly and model stages over a whole session, in one process.

It runs exactly the code the fitter, parameter and model nodes run, in data-flow order, with
no ROS runtime, so a replayed bag, a simulated session and the report get the numbers the
live graph would publish (bit-identical in practice):

* :meth:`OfflineGraph.run` fits every trial, assembles the parameters once and computes the
  model once: the replay of a recording (:mod:`bike_rig.offline.replay`) and the report;
* :meth:`OfflineGraph.step` takes one trial at a time and returns what the graph publishes
  after it (the estimate, the session's state and, once complete, the model): the simulated
  live results of :mod:`bike_rig.bag.simulated`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..core.benchmark import ComMethod
from ..core.measurements import Measurements
from ..core.period import PeriodFit
from ..core.uncertainty.matrix_sigma import SigmaConvention
from .acquire import SampleBatch, TrialEventRecord
from .assemble import SessionAssembly, SessionParameters
from .errors import AssemblyError
from .fit import TrialFit, TrialFitOptions, fit_trial
from .model import ModelMatrices, StabilitySweep, compute_model

__all__ = [
    "DEFAULT_SPEEDS",
    "GraphSettings",
    "OfflineGraph",
    "OfflineRun",
    "OfflineStep",
    "SessionTrial",
    "TrialInput",
]

FloatArray = NDArray[np.float64]

#: The model node's default sweep (speed_min 0, speed_max 10, speed_count 201), m/s.
DEFAULT_SPEEDS: FloatArray = np.linspace(0.0, 10.0, 201)


@dataclass(frozen=True)
class TrialInput:
    """One trial's acquisition records, as the fitter receives them.

    Attributes:
        trial_id: The trial.
        start: Its START event, or None.
        stop: Its STOP or ABORT event, or None.
        batches: Its batches, in receiving order.
    """

    trial_id: str
    start: TrialEventRecord | None
    stop: TrialEventRecord | None
    batches: Sequence[SampleBatch]


@dataclass(frozen=True)
class GraphSettings:
    """The nodes' settings that decide the results.

    Attributes:
        fit_options: The fitter's options (a trial may be given its own, see :meth:`OfflineGraph.run`).
        com_method: The parameter node's mass-centre method.
        rider: The model node's rider ("" none, "paper", or a rider file).
        convention: The model node's σ convention.
        speeds: The model node's sweep speeds, m/s.
    """

    fit_options: TrialFitOptions = field(default_factory=TrialFitOptions)
    com_method: ComMethod = ComMethod.CENTROID
    rider: str = ""
    convention: SigmaConvention = SigmaConvention.CORRELATED
    speeds: FloatArray = field(default_factory=DEFAULT_SPEEDS.copy)


@dataclass(frozen=True)
class OfflineStep:
    """What the graph publishes after one trial.

    Attributes:
        trial: The fitter's result.
        rejected: Why the parameter stage refused it ("" when it took it).
        session: The parameter stage's state after it.
        matrices: The model's matrices (None while incomplete).
        stability: The model's sweep and critical speeds (None while incomplete).
    """

    trial: TrialFit
    rejected: str
    session: SessionParameters
    matrices: ModelMatrices | None = None
    stability: StabilitySweep | None = None


@dataclass(frozen=True)
class OfflineRun:
    """A whole session run offline.

    Attributes:
        trials: Every trial's result, in input order.
        rejected: Why the parameter stage refused a trial, by trial id.
        session: The assembly's result (periods per key, missing keys, the parameter set).
        matrices: Canonical matrices with σ (None when incomplete).
        stability: Sweep and critical speeds with σ (None when incomplete).
    """

    trials: tuple[TrialFit, ...]
    rejected: dict[str, str]
    session: SessionParameters
    matrices: ModelMatrices | None
    stability: StabilitySweep | None


class OfflineGraph:
    """The fitter, parameter and model stages of one session, without ROS.

    Args:
        static: The static readings (the parameter node's measurement file).
        settings: The nodes' settings.
        origin: Named as the source of the periods in error messages.

    Raises:
        MeasurementError: a static reading is missing or impossible.
        GeometryError: hanging orientations are degenerate.
    """

    def __init__(self, static: Measurements, settings: GraphSettings | None = None, origin: str = "period estimates"):
        """Set up the stages for one session."""
        self.settings = settings or GraphSettings()
        self.assembly = SessionAssembly(static, self.settings.com_method, origin=origin)

    def fit(self, trial: TrialInput, options: TrialFitOptions | None = None) -> TrialFit:
        """The fitting stage: one trial's period (with the settings' options unless given)."""
        return fit_trial(trial.batches, trial.start, trial.stop, options or self.settings.fit_options)

    def model(self, session: SessionParameters) -> tuple[ModelMatrices | None, StabilitySweep | None]:
        """The model stage for a complete session (None, None while incomplete)."""
        if session.parameters is None:
            return None, None
        s = self.settings
        return compute_model(session.parameters, s.speeds, s.rider, s.convention, files=True)

    def _fit_one(self, item: tuple[TrialInput, TrialFitOptions]) -> TrialFit:
        return self.fit(*item)

    def _add(self, result: TrialFit) -> str:
        try:
            self.assembly.add(result)
        except AssemblyError as exc:
            return str(exc)
        return ""

    def step(self, trial: TrialInput) -> OfflineStep:
        """Fit one trial, add it to the assembly and return what the graph publishes after it."""
        result = self.fit(trial)
        rejected = self._add(result)
        session = self.assembly.result()
        matrices, stability = self.model(session)
        return OfflineStep(result, rejected, session, matrices, stability)

    def run(
        self,
        trials: Iterable[TrialInput],
        options_for: Callable[[TrialInput], TrialFitOptions] | None = None,
    ) -> OfflineRun:
        """Fit every trial, then assemble and compute the model once.

        Args:
            trials: The session's trials.
            options_for: The fit options of each trial (the settings' when None).
        """
        inputs = [(t, options_for(t) if options_for is not None else self.settings.fit_options) for t in trials]
        fitted = [self._fit_one(item) for item in inputs]
        rejected = {r.trial_id: why for r in fitted if (why := self._add(r))}
        session = self.assembly.result()
        matrices, stability = self.model(session)
        return OfflineRun(tuple(fitted), rejected, session, matrices, stability)


@dataclass(frozen=True)
class SessionTrial:
    """One trial of a session and what became of it (replays, reports, figures).

    Attributes:
        result: The trial's fit and metadata.
        used: It entered its key's combined period.
        note: Why it was left out, beyond its flags ("" when nothing to say).
        options_from: Where a replay's fit options came from: ``recorded`` (this trial's
            estimate), ``session`` (the session's other estimates), ``default`` or
            ``override`` ("" outside a replay).
        recorded: The live estimate of the trial (the one the parameter node kept), or None.
        start_s: When the trial started, s on the rig clock from the first trial's start (bags), else None.
        stop_s: When it stopped, s on the rig clock from the first trial's start (bags), else None.
        source: The trial file, or the bag.
    """

    result: TrialFit
    used: bool = False
    note: str = ""
    options_from: str = ""
    recorded: TrialFit | None = None
    start_s: float | None = None
    stop_s: float | None = None
    source: str = ""

    @property
    def trial_id(self) -> str:
        """The trial's id (bags) or its file's name (measurement files)."""
        return self.result.trial_id

    @property
    def key(self) -> str:
        """The period it measures (``TtB1``, ``TcR1``...)."""
        return self.result.measurement_key

    @property
    def fit(self) -> PeriodFit:
        """The core's fit of Eq 23 (period, σ, ζ, r², window, the fit's own flags)."""
        return self.result.fit

    @property
    def samples(self) -> FloatArray | None:
        """The gyro samples (rad/s for the rig; a file's own unit otherwise), or None."""
        return self.result.samples

    @property
    def sample_rate_hz(self) -> float | None:
        """Their rate, Hz (None when unknown)."""
        rate = self.result.sample_rate_hz
        return rate if math.isfinite(rate) and rate > 0 else None

    @property
    def times(self) -> FloatArray | None:
        """Time of each sample, s from the trial's first sample, or None (constant rate)."""
        return self.result.sample_times
