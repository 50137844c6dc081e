"""Live assembly of a bicycle's results: static readings + period estimates → parameter set →
model products (ROS-free).

The live rig measures the static readings (masses, lengths, angles) once, from a measurement
file, and the pendulum periods trial by trial. :class:`SessionAssembly` holds the static
readings, takes period estimates one by one (a trial published again under the same trial id
replaces the earlier one), combines the usable trials of each measurement key with
:func:`combine_trials`, says which keys are still missing, and, once every key has a period,
computes the 25 benchmark parameters with :func:`compute_parameters`.

:func:`compute_model` turns a parameter set into what the model node publishes: the canonical
matrices with σ, the eigenvalue sweep and the weave and capsize speeds with σ;
:func:`state_space_at` gives A, B and the eigenvalues at one speed.

Live (the parameter and model nodes) and offline (replay of a recording) use these same
functions on the same numbers, so a replayed recording gives bit-identical results.
Everything is deterministic: the same estimates, received in any order, give identical floats
(trials are combined in trial-id order and the readings are always in one canonical order).
Units: SI (periods in s, speeds in m/s, eigenvalues in 1/s); degrees only in ``gamma`` and
``alpha*`` readings.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .benchmark import ComMethod, ParameterSet, check_orientations, compute_parameters
from .errors import BikeRigError, ModelError
from .loader import is_period_key
from .measurements import Measurements, Origin, Reading, validate
from .period import CombinedPeriod, Flag, FlagCode, PeriodFit, combine_periods
from .rider import PAPER_RIDER, Rider, add_rider
from .uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from .uncertainty.speed_sigma import SpeedWithSigma, critical_speeds_with_sigma
from .whipple import MODE_LABELS, EigenvalueSweep, WhippleMatrices, eigenvalues, state_space

__all__ = [
    "RIDERS",
    "AssemblyError",
    "KeyPeriod",
    "ModelMatrices",
    "SessionAssembly",
    "SessionParameters",
    "StabilitySweep",
    "StateSpaceAt",
    "TrialPeriod",
    "assemble",
    "combine_trials",
    "compute_model",
    "merged_readings",
    "period_fit",
    "required_period_keys",
    "rider_by_name",
    "state_space_at",
]

FloatArray = NDArray[np.float64]

#: Riders the live model knows by name ("" is no rider).
RIDERS: Mapping[str, Rider | None] = {"": None, "paper": PAPER_RIDER}


class AssemblyError(BikeRigError):
    """A period estimate that cannot be used (unknown measurement key or flag code)."""


# --------------------------------------------------------------------------------------------
# Period estimates and their combination
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrialPeriod:
    """The fitted period of one trial (the fields of a ``PeriodEstimate`` message).

    Attributes:
        trial_id: Unique id of the trial within the session.
        measurement_key: The period it measures, e.g. ``"TtB2"``.
        period: T, s (NaN when invalid).
        period_sigma: σ of T, s.
        valid: A period was obtained.
        flags: Quality flag codes (:class:`bike_rig.core.period.FlagCode` values); a flagged
            trial is not combined.
        flag_reasons: One human reason per flag.
        zeta: Damping ratio, 1.
        omega: Natural angular frequency, rad/s.
        r2: Coefficient of determination, 1.
        residual_rms: Residual RMS, rad/s.
        n_samples: Samples received for the trial.
        n_expected: Samples announced by the driver.
        window: The fit window ``(start, stop)`` as sample indices, stop exclusive.
        fit_options_json: The fit options used, as a JSON object.
        stamp_ns: Time the fit finished (message header stamp), ns since the epoch.
    """

    trial_id: str
    measurement_key: str
    period: float
    period_sigma: float
    valid: bool
    flags: tuple[str, ...] = ()
    flag_reasons: tuple[str, ...] = ()
    zeta: float = math.nan
    omega: float = math.nan
    r2: float = math.nan
    residual_rms: float = math.nan
    n_samples: int = 0
    n_expected: int = 0
    window: tuple[int, int] = (0, 0)
    fit_options_json: str = ""
    stamp_ns: int = 0

    @property
    def usable(self) -> bool:
        """Valid, unflagged, with a finite positive period and σ: it enters the combination."""
        return (
            self.valid
            and not self.flags
            and math.isfinite(self.period)
            and self.period > 0.0
            and math.isfinite(self.period_sigma)
            and self.period_sigma > 0.0
        )


def _flag(trial: TrialPeriod, code: str, reason: str) -> Flag:
    try:
        return Flag(FlagCode(code), reason)
    except ValueError:
        known = ", ".join(c.value for c in FlagCode)
        raise AssemblyError(
            f"trial '{trial.trial_id}': unknown quality flag code '{code}' (known: {known})"
        ) from None


def period_fit(trial: TrialPeriod) -> PeriodFit:
    """The :class:`PeriodFit` that :func:`combine_periods` needs, from a trial's published fields.

    Fields a period estimate does not carry (A, B, C, cycles) are NaN. A trial marked valid
    without a finite positive period is treated as invalid.

    Raises:
        AssemblyError: a flag code is not a :class:`FlagCode`.
    """
    reasons = list(trial.flag_reasons) + [""] * max(0, len(trial.flags) - len(trial.flag_reasons))
    flags = tuple(_flag(trial, code, reason) for code, reason in zip(trial.flags, reasons))
    valid = trial.valid and math.isfinite(trial.period) and trial.period > 0.0
    nan = math.nan
    return PeriodFit(
        period=trial.period, period_sigma=trial.period_sigma, zeta=trial.zeta, omega=trial.omega,
        A=nan, B=nan, C=nan, r2=trial.r2, residual_rms=trial.residual_rms, n_cycles=nan,
        n_samples=int(trial.n_samples), window=(int(trial.window[0]), int(trial.window[1])),
        valid=valid, flags=flags,
    )  # fmt: skip


def combine_trials(trials: Iterable[TrialPeriod]) -> tuple[CombinedPeriod, tuple[str, ...]]:
    """Combine the trials of one measurement key, in trial-id order, with :func:`combine_periods`.

    Valid, unflagged trials are averaged (weights 1/σ², σ inflated by the Birge ratio when
    they scatter); flagged and invalid ones are left out. When exactly one trial is usable its
    own period and σ are returned bit for bit (the weighted mean of one value, without the
    rounding of ``w T / w``), so a file's ``value ± σ`` given as one trial reproduces the file.

    Returns:
        The combination and the ids of the trials used (sorted).

    Raises:
        AssemblyError: a flag code is unknown.
    """
    ordered = sorted(trials, key=lambda t: t.trial_id)
    combined = combine_periods([period_fit(t) for t in ordered])
    used = tuple(t.trial_id for t in ordered if t.usable)
    return combined, used


# --------------------------------------------------------------------------------------------
# Readings: static + periods, in one canonical order
# --------------------------------------------------------------------------------------------


def _anchors(static: Mapping[str, Reading]) -> dict[str, list[str]]:
    """Period keys placed after each static key (the order of a measurement file)."""
    anchors: dict[str, list[str]] = {"dP": ["TtP1"], "lR": ["TcR1", "TtR1"], "lF": ["TcF1", "TtF1"]}
    anchors["mB"] = ["TcB1"]
    anchors["mH"] = ["TcH1"]
    for part in "BH":
        for i in _orientations(static, part):
            anchors.setdefault(f"a{part}{i}", []).append(f"Tt{part}{i}")
    return anchors


def _orientations(static: Mapping[str, Reading], part: str) -> list[int]:
    found = set()
    for key in static:
        for prefix in ("alpha", "a"):
            rest = key[len(prefix) + 1 :]
            if key.startswith(f"{prefix}{part}") and rest.isdigit():
                found.add(int(rest))
    return sorted(found)


def required_period_keys(static: Measurements) -> tuple[str, ...]:
    """Every ``Tc*``/``Tt*`` key the static readings imply, in canonical order.

    The wheels' compound and torsional periods, the frame's and fork's compound periods, one
    torsional period per hanging orientation (``alpha<part><i>``/``a<part><i>``) and the
    calibration rod's torsional period.
    """
    anchors = _anchors(static.readings)
    order = [k for key in static.readings for k in anchors.get(key, [])]
    rest = [k for keys in anchors.values() for k in keys if k not in order]
    return tuple(order + rest)


def merged_readings(static: Measurements, periods: Mapping[str, tuple[float, float]], origin: str) -> Measurements:
    """Static readings plus periods, each period right after the reading it belongs with.

    The order is that of :func:`bike_rig.core.loader.load_measurements` for a bike_rig YAML
    file, so that the parameters (their covariance too) are bit-identical to the file's.

    Args:
        static: The static readings.
        periods: ``{key: (value, sigma)}`` in s.
        origin: Where the periods came from (for error messages).
    """
    anchors = _anchors(static.readings)
    readings: dict[str, Reading] = {}
    for key, reading in static.readings.items():
        if is_period_key(key):
            continue
        readings[key] = reading
        for pkey in anchors.get(key, []):
            if pkey in periods:
                readings[pkey] = _period_reading(pkey, periods[pkey], origin)
    for pkey, vs in periods.items():
        readings.setdefault(pkey, _period_reading(pkey, vs, origin))
    return Measurements(static.bicycle, readings, static.path, static.extras)


def _period_reading(key: str, vs: tuple[float, float], origin: str) -> Reading:
    return Reading(float(vs[0]), float(vs[1]), Origin(origin, key))


# --------------------------------------------------------------------------------------------
# The session
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class KeyPeriod:
    """One measurement key's combined period and where it came from.

    Attributes:
        key: The measurement key, e.g. ``"TtB2"``.
        value: Combined period, s.
        sigma: Its σ, s.
        trial_ids: The trials combined (sorted).
    """

    key: str
    value: float
    sigma: float
    trial_ids: tuple[str, ...]


@dataclass(frozen=True)
class SessionParameters:
    """The state of a session: the parameter set when complete, what is missing otherwise.

    Attributes:
        bicycle: The bicycle's name.
        com_method: Mass-centre method used.
        periods: Every key that has a combined period, in canonical order.
        missing: Keys without a usable trial yet, in canonical order.
        parameters: The parameter set, None while incomplete.
    """

    bicycle: str
    com_method: ComMethod
    periods: tuple[KeyPeriod, ...]
    missing: tuple[str, ...]
    parameters: ParameterSet | None = None

    @property
    def complete(self) -> bool:
        """Every period is there and the parameters are computed."""
        return self.parameters is not None


@dataclass
class SessionAssembly:
    """Static readings plus the period estimates received so far.

    Args:
        static: The static readings (:func:`bike_rig.core.loader.load_static_readings`);
            period readings in it are ignored. They are checked here, with every period
            still to come.
        com_method: Mass-centre method for :func:`compute_parameters`.
        origin: Named as the source of the periods in error messages.

    Raises:
        MeasurementError: a static reading is missing or impossible.
        GeometryError: hanging orientations are degenerate.
    """

    static: Measurements
    com_method: ComMethod = ComMethod.CENTROID
    origin: str = "period estimates"
    _trials: dict[str, TrialPeriod] = field(default_factory=dict, init=False, repr=False)
    _keys: tuple[str, ...] = field(default=(), init=False, repr=False)

    def __post_init__(self) -> None:
        self.com_method = ComMethod(self.com_method)
        readings = {k: r for k, r in self.static.readings.items() if not is_period_key(k)}
        self.static = Measurements(self.static.bicycle, readings, self.static.path, self.static.extras)
        self._keys = required_period_keys(self.static)
        # check the static part now: placeholder periods stand in for those still to come
        probe = merged_readings(self.static, {k: (1.0, 0.0) for k in self._keys}, self.origin)
        validate(probe)
        check_orientations(probe)

    @property
    def required_keys(self) -> tuple[str, ...]:
        """Every period key this bicycle needs, canonical order."""
        return self._keys

    @property
    def trials(self) -> tuple[TrialPeriod, ...]:
        """The trials held (one per trial id), sorted by trial id."""
        return tuple(self._trials[k] for k in sorted(self._trials))

    def add(self, trial: TrialPeriod) -> bool:
        """Take one period estimate; one with a trial id seen before replaces the earlier one,
        unless it was fitted from fewer samples (then the earlier one is kept).

        Returns:
            Whether anything changed (False for an identical re-publication).

        Raises:
            AssemblyError: the measurement key is not one of this bicycle's period keys, or a
                flag code is unknown; the estimate is then not kept.
        """
        if trial.measurement_key not in self._keys:
            raise AssemblyError(
                f"trial '{trial.trial_id}': measurement key '{trial.measurement_key}' is not a period "
                f"of {self.static.bicycle} (expected one of {', '.join(self._keys)})"
            )
        period_fit(trial)  # reject unknown flag codes now
        earlier = self._trials.get(trial.trial_id)
        if earlier == trial:
            return False
        if earlier is not None and trial.n_samples < earlier.n_samples:
            # a trial's samples are fixed, so a re-fit can only differ by missing data (e.g. a
            # restarted fitter that no longer has the whole trial): never trade down
            return False
        self._trials[trial.trial_id] = trial
        return True

    def add_all(self, trials: Iterable[TrialPeriod]) -> None:
        """:meth:`add` each trial in turn."""
        for t in trials:
            self.add(t)

    def combined(self, key: str) -> tuple[CombinedPeriod, tuple[str, ...]]:
        """The combination of ``key``'s trials (:func:`combine_trials`)."""
        return combine_trials(t for t in self._trials.values() if t.measurement_key == key)

    def periods(self) -> tuple[KeyPeriod, ...]:
        """Every key with a usable combined period, in canonical order."""
        out = []
        for key in self._keys:
            comb, used = self.combined(key)
            if comb.n_used > 0:
                out.append(KeyPeriod(key, comb.value, comb.sigma, used))
        return tuple(out)

    def missing(self) -> tuple[str, ...]:
        """Keys without a usable trial, in canonical order."""
        have = {p.key for p in self.periods()}
        return tuple(k for k in self._keys if k not in have)

    def result(self) -> SessionParameters:
        """The parameter set if every period is there, else what is missing.

        Raises:
            MeasurementError: a combined reading is impossible (cannot happen for usable
                trials: their periods and σ are finite and positive).
        """
        periods = self.periods()
        have = {p.key for p in periods}
        missing = tuple(k for k in self._keys if k not in have)
        parameters = None
        if not missing:
            merged = merged_readings(self.static, {p.key: (p.value, p.sigma) for p in periods}, self.origin)
            parameters = compute_parameters(merged, self.com_method)
        return SessionParameters(self.static.bicycle, self.com_method, periods, missing, parameters)


def assemble(
    static: Measurements,
    trials: Iterable[TrialPeriod],
    com_method: ComMethod | str = ComMethod.CENTROID,
    origin: str = "period estimates",
) -> SessionParameters:
    """One-shot :class:`SessionAssembly` (offline replay): add every trial, return the result.

    Raises:
        AssemblyError: a trial's key or flag code cannot be used (as :meth:`SessionAssembly.add`).
    """
    session = SessionAssembly(static, ComMethod(com_method), origin)
    session.add_all(trials)
    return session.result()


# --------------------------------------------------------------------------------------------
# Model products
# --------------------------------------------------------------------------------------------


def rider_by_name(name: str) -> Rider | None:
    """The rider called ``name`` ("" or "none": no rider; "paper": Table 1).

    Raises:
        ModelError: an unknown name.
    """
    key = "" if name == "none" else name
    if key not in RIDERS:
        raise ModelError(f"unknown rider '{name}': expected '', 'none' or 'paper'")
    return RIDERS[key]


@dataclass(frozen=True)
class ModelMatrices:
    """Canonical matrices with σ of one bicycle (the fields of a ``CanonicalMatrices`` message).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        g: Gravity, m/s².
        matrices: M (kg m²), C1 (kg m), K0 (kg m), K2 (kg).
        sigma: σ of every entry, same layout.
        convention: How σ were computed.
    """

    bicycle: str
    rider: str
    g: float
    matrices: WhippleMatrices
    sigma: WhippleMatrices
    convention: SigmaConvention


@dataclass(frozen=True)
class StabilitySweep:
    """Eigenvalues over speeds and the critical speeds (the fields of an ``EigenSweep`` message).

    Attributes:
        bicycle: The bicycle's name (without the rider).
        rider: "" or "paper".
        sweep: Speeds (m/s), eigenvalues (1/s, shape (N, 4)) and mode labels.
        weave: Weave speed with σ (m/s), None when absent.
        capsize: Capsize speed with σ (m/s), None when absent.
    """

    bicycle: str
    rider: str
    sweep: EigenvalueSweep
    weave: SpeedWithSigma | None
    capsize: SpeedWithSigma | None


def _with_rider(ps: ParameterSet, rider: str) -> ParameterSet:
    r = rider_by_name(rider)
    return ps if r is None else add_rider(ps, r)


def compute_model(
    ps: ParameterSet,
    speeds: ArrayLike,
    rider: str = "",
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
) -> tuple[ModelMatrices, StabilitySweep]:
    """The model products of a parameter set.

    Args:
        ps: The bicycle's parameter set (without rider).
        speeds: Speeds of the eigenvalue sweep, m/s.
        rider: "" (none) or "paper" (lumped into the rear frame, σ carried through).
        convention: σ convention of the matrices and the critical speeds.

    Raises:
        ModelError: unknown rider, bad speeds or a singular mass matrix.
    """
    convention = SigmaConvention(convention)
    name = "" if rider == "none" else rider
    full = _with_rider(ps, name)
    ms = canonical_with_sigma(full, convention)
    sweep = eigenvalues(ms.matrices, ms.g, speeds)
    cs = critical_speeds_with_sigma(full, convention, ms)
    return (
        ModelMatrices(ps.bicycle, name, ms.g, ms.matrices, ms.sigma, convention),
        StabilitySweep(ps.bicycle, name, sweep, cs.weave, cs.capsize),
    )


#: Speeds above the asked one over which :func:`state_space_at` tracks the modes to label them, m/s.
LABEL_SWEEP_SPAN = 10.0
#: Speeds in that sweep.
LABEL_SWEEP_COUNT = 201


@dataclass(frozen=True)
class StateSpaceAt:
    """``ẋ = A x + B u`` at one speed (the fields of a ``StateSpace`` response).

    Attributes:
        speed: m/s.
        a: A, shape (4, 4) (1/s, 1/s²).
        b: B, shape (4, 2) (1/(kg m²)).
        eigenvalues: Shape (4,), 1/s, columns as ``labels``.
        labels: Mode of each eigenvalue.
    """

    speed: float
    a: FloatArray
    b: FloatArray
    eigenvalues: NDArray[np.complex128]
    labels: tuple[str, ...] = MODE_LABELS


def state_space_at(model: ModelMatrices, speed: float) -> StateSpaceAt:
    """A, B and the labelled eigenvalues of ``model`` at ``speed``.

    Raises:
        ModelError: the speed is not a finite number ≥ 0 m/s.
    """
    v = float(speed)
    if not (math.isfinite(v) and v >= 0.0):
        raise ModelError(f"speed must be a finite number >= 0 m/s, got {speed}")
    a, b = state_space(model.matrices, v, model.g)
    # Labels come from the structure at the highest speed of a sweep and are carried back along
    # the tracks; one speed alone would name the low-speed capsize–caster pair "weave".
    sweep = eigenvalues(model.matrices, model.g, np.linspace(v, v + LABEL_SWEEP_SPAN, LABEL_SWEEP_COUNT))
    return StateSpaceAt(v, np.asarray(a, dtype=float), np.asarray(b, dtype=float), sweep.eigenvalues[0], sweep.labels)

