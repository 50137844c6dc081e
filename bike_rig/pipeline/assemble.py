"""Parameter assembly, the third stage: static readings + trial results → the 25 parameters.

:class:`SessionAssembly` holds the static readings (from a file or entered,
:mod:`bike_rig.pipeline.readings`), takes trial results one by one (a trial republished under
its id replaces the earlier) and joins each one's fit details (:class:`FitDetails`, which
arrive apart, before or after it), combines each key's usable trials (:func:`combine_trials`),
says what is missing, and computes the parameters with
:func:`~bike_rig.core.benchmark.compute_parameters`. The parameter node, the offline runner and
the replay share it, and it is deterministic (trials combined in id order, readings in one canonical
order), so a replay gives bit-identical results. SI (periods s); degrees only in ``gamma`` and
``alpha*``.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from ..core.benchmark import ComMethod, ParameterSet, check_orientations
from ..core.measurements import (
    MIN_ORIENTATIONS,
    Measurements,
    Origin,
    Reading,
    check_reading,
    has_flywheel,
    hung_parts,
    is_period_key,
    orientation_indices,
    required_keys,
    validate,
)
from ..core.parameter_checks import compute_checked
from ..core.period import CombinedPeriod, PeriodFit, combine_periods
from .errors import AssemblyError
from .fit import TrialFit
from .fit_details import FitDetails, join_details
from .readings import canonical_order

__all__ = [
    "PLAUSIBLE_PERIOD_S",
    "KeyPeriod",
    "SessionAssembly",
    "SessionParameters",
    "assemble",
    "combine_trials",
    "merged_readings",
    "required_period_keys",
    "required_readings",
]


def combine_trials(trials: Iterable[TrialFit]) -> tuple[CombinedPeriod, tuple[str, ...]]:
    """Combine the trials of one measurement key, in trial-id order, with :func:`combine_periods`.

    Valid, unflagged trials are averaged (weights 1/σ², σ inflated by the Birge ratio when
    they scatter); flagged and invalid ones are left out. When exactly one trial is usable its
    own period and σ are returned bit for bit (the weighted mean of one value, without the
    rounding of ``w T / w``), so a file's ``value ± σ`` given as one trial reproduces the file.
    A trial marked valid without a finite positive period counts as invalid.

    Returns:
        The combination and the ids of the trials used (sorted).
    """
    ordered = sorted(trials, key=lambda t: t.trial_id)
    combined = combine_periods([_combinable(t) for t in ordered])
    used = tuple(t.trial_id for t in ordered if t.usable)
    return combined, used


def _combinable(trial: TrialFit) -> PeriodFit:
    """The trial's fit as :func:`combine_periods` takes it: every flag on it, valid only with a period."""
    f = trial.fit
    valid = f.valid and math.isfinite(f.period) and f.period > 0.0
    if valid == f.valid and not trial.trial_flags:
        return f
    return dataclasses.replace(f, valid=valid, flags=trial.flags)


# --------------------------------------------------------------------------------------------
# Readings: static + periods, in one canonical order
# --------------------------------------------------------------------------------------------


def _anchors(static: Mapping[str, Reading]) -> dict[str, list[str]]:
    """Period keys placed after each static key (the order of a measurement file)."""
    anchors: dict[str, list[str]] = {"dP": ["TtP1"], "lR": ["TcR1", "TtR1"], "lF": ["TcF1", "TtF1"]}
    parts = hung_parts(static)
    for part in parts:
        anchors[f"m{part}"] = [f"Tc{part}1"]
    if has_flywheel(static):
        anchors["mD"] = ["TcD1", "TtD1"]
    for part in parts:
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


def required_readings(static: Measurements, period_keys: Iterable[str] = ()) -> tuple[str, ...]:
    """Every static reading key the parameters need, given the readings and periods so far.

    The fixed keys of the method the readings so far use (``g``, ``w``, ``gamma``, ... ``dP``;
    or the surface plate's ``h1``... instead of ``w, gamma, f``, and ``mS, mG`` and the handlebar
    reference instead of ``mH`` once a split-fork reading or trial arrives) and, for each hung
    part (frame ``B`` and fork ``H``, or ``B``, ``S`` and ``G``), ``alpha<part><i>`` and
    ``a<part><i>`` for every hanging orientation ``i``
    known so far: from the readings given (``alpha``/``a`` keys) and from the periods measured
    (``Tt<part><i>``). While fewer than ``MIN_ORIENTATIONS`` (3) are known, the lowest unused
    indices make up the number, so a bicycle with no readings yet needs orientations 1, 2 and
    3. Canonical order (:func:`bike_rig.pipeline.readings.canonical_order`).

    Args:
        static: The static readings so far.
        period_keys: The measurement keys of the trials received.
    """
    so_far: dict[str, object] = {**static.readings, **{k: None for k in period_keys}}
    keys = [k for k in required_keys(so_far) if not is_period_key(k)]
    for part in hung_parts(so_far):
        known = set(orientation_indices(static.readings, part))
        known |= set(orientation_indices({k: None for k in period_keys if k.startswith("Tt")}, part))
        i = 1
        while len(known) < MIN_ORIENTATIONS:
            known.add(i)
            i += 1
        keys += [f"{prefix}{part}{i}" for i in sorted(known) for prefix in ("alpha", "a")]
    return tuple(sorted(keys, key=canonical_order))


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
        missing: What is still to measure: the static readings still to enter (only while an
            assembly with ``partial`` readings lacks some), then the period keys without a
            usable trial, each in canonical order.
        parameters: The parameter set, None while incomplete.
    """

    bicycle: str
    com_method: ComMethod
    periods: tuple[KeyPeriod, ...]
    missing: tuple[str, ...]
    parameters: ParameterSet | None = None

    @property
    def complete(self) -> bool:
        """Every reading and period is there and the parameters are computed."""
        return self.parameters is not None

    @property
    def missing_readings(self) -> tuple[str, ...]:
        """The static readings in :attr:`missing`."""
        return tuple(k for k in self.missing if not is_period_key(k))

    @property
    def missing_periods(self) -> tuple[str, ...]:
        """The period keys in :attr:`missing`."""
        return tuple(k for k in self.missing if is_period_key(k))

    def complete_parameters(self) -> ParameterSet:
        """The parameter set.

        Raises:
            AssemblyError: the session is incomplete (the message names the missing keys).
        """
        if self.parameters is None:
            raise AssemblyError(f"the parameter set is incomplete (missing: {', '.join(self.missing)})")
        return self.parameters


#: The periods a rig pendulum can have, s: far outside any bicycle part's (0.3-5 s in the paper)
#: and the fitter's reach (a few cycles within a record of at most ``max_trial_samples``), but
#: bounded, so that one absurd estimate (a rogue publisher's 1e308 s) cannot overflow the
#: propagation and block the set.
PLAUSIBLE_PERIOD_S = (1e-3, 1e3)

_PERIOD_KEY = re.compile(r"^(Tc[RFBH]1|Tt[RFP]1|Tt[BH][1-9]\d*)$")
#: Stands in for a reading or period still to come, when the static readings are checked.
_PLACEHOLDER = Reading(1.0, 0.0)


@dataclass
class SessionAssembly:
    """Static readings plus the period estimates (and their fit details) received so far.

    Args:
        static: The static readings (:func:`bike_rig.core.loader.load_static_readings`, or
            :func:`bike_rig.pipeline.readings.apply_entries`); period readings in it are
            ignored. They are checked here, with every period still to come.
        com_method: Mass-centre method for :func:`~bike_rig.core.benchmark.compute_parameters`.
        origin: Named as the source of the periods in error messages.
        partial: The static readings may be incomplete: more are still to be entered (the
            live parameter node). The readings still missing (:func:`required_readings`) are
            then listed in :attr:`SessionParameters.missing` instead of raising, and a period
            of any well-formed key is kept, even one of a hanging orientation without readings
            yet (whose readings are then missing). Without ``partial`` the readings must be
            complete and a period key they do not imply is refused.

    Raises:
        MeasurementError: a static reading is impossible, or (without ``partial``) missing.
        GeometryError: hanging orientations are degenerate.
    """

    static: Measurements
    com_method: ComMethod = ComMethod.CENTROID
    origin: str = "period estimates"
    partial: bool = False
    _trials: dict[str, TrialFit] = field(default_factory=dict, init=False, repr=False)
    _details: dict[str, FitDetails] = field(default_factory=dict, init=False, repr=False)
    _keys: tuple[str, ...] = field(default=(), init=False, repr=False)
    _missing_readings: tuple[str, ...] = field(default=(), init=False, repr=False)

    def __post_init__(self) -> None:
        """Keep the static readings only and check them, with placeholders for the periods to come.

        Raises:
            MeasurementError: A static reading is impossible, or (without ``partial``) missing.
            GeometryError: Hanging orientations are degenerate.
        """
        self.com_method = ComMethod(self.com_method)
        self.set_static(self.static)

    def set_static(self, static: Measurements) -> None:
        """Use other static readings (e.g. with a newly entered one), keeping the trials received.

        They are checked as at the start; when they fail nothing changes.

        Raises:
            MeasurementError: A static reading is impossible, or (without ``partial``) missing.
            GeometryError: Hanging orientations are degenerate.
        """
        readings = {k: r for k, r in static.readings.items() if not is_period_key(k)}
        static = Measurements(static.bicycle, readings, static.path, static.extras)
        missing, keys = self._requirements(static)
        if missing:
            for key, reading in readings.items():
                check_reading(key, reading)
            alphas = {k: r for k, r in readings.items() if k.startswith("alpha")}
            check_orientations(Measurements(static.bicycle, alphas, static.path))
        else:
            # placeholder periods stand in for those still to come
            probe = merged_readings(static, {k: (1.0, 0.0) for k in keys}, self.origin)
            validate(probe)
            check_orientations(probe)
        self.static, self._keys, self._missing_readings = static, keys, missing

    def _requirements(self, static: Measurements) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The static readings missing and the period keys required, with these readings."""
        if not self.partial:
            return (), required_period_keys(static)
        needed = required_readings(static, {t.measurement_key for t in self._trials.values()})
        missing = tuple(k for k in needed if k not in static.readings)
        if not missing:
            return (), required_period_keys(static)
        # the periods the readings so far imply, with placeholders for the readings to come
        probe = {**static.readings, **{k: _PLACEHOLDER for k in missing}}
        ordered = {k: probe[k] for k in sorted(probe, key=canonical_order)}
        return missing, required_period_keys(Measurements(static.bicycle, ordered, static.path))

    @property
    def required_keys(self) -> tuple[str, ...]:
        """Every period key this bicycle needs (with ``partial`` readings: so far), canonical order."""
        return self._keys

    @property
    def missing_readings(self) -> tuple[str, ...]:
        """The static readings still to enter (only with ``partial`` readings), canonical order."""
        return self._missing_readings

    @property
    def trials(self) -> tuple[TrialFit, ...]:
        """The trials held (one per trial id), sorted by trial id."""
        return tuple(self._trials[k] for k in sorted(self._trials))

    def add(self, trial: TrialFit) -> bool:
        """Take one period estimate, with its trial's fit details joined when they arrived (:meth:`joined`).

        One with a trial id seen before replaces the earlier one, unless it was fitted from fewer
        samples (then the earlier one is kept).

        Returns:
            Whether anything changed (False for an identical re-publication).

        Raises:
            AssemblyError: the measurement key is not one of this bicycle's period keys (with
                ``partial`` readings: not a period key at all), or a usable estimate's period or
                σ is not one a rig pendulum can give (:data:`PLAUSIBLE_PERIOD_S`, σ below the
                period); the estimate is then not kept, and nothing is blocked by it.
        """
        trial = self.joined(trial)
        key = trial.measurement_key
        if trial.usable and not (
            PLAUSIBLE_PERIOD_S[0] <= trial.period <= PLAUSIBLE_PERIOD_S[1] and 0 <= trial.period_sigma < trial.period
        ):
            raise AssemblyError(
                f"trial '{trial.trial_id}': period {trial.period:g} ± {trial.period_sigma:g} s is not a rig "
                f"pendulum's ({PLAUSIBLE_PERIOD_S[0]:g} to {PLAUSIBLE_PERIOD_S[1]:g} s, σ below the period)"
            )
        if self.partial and key not in self._keys and not _PERIOD_KEY.match(key):
            raise AssemblyError(
                f"trial '{trial.trial_id}': measurement key '{key}' is not a period key "
                f"(expected one of {', '.join(self._keys)}, or Tt<part><i> of another hanging orientation)"
            )
        if not self.partial and key not in self._keys:
            raise AssemblyError(
                f"trial '{trial.trial_id}': measurement key '{key}' is not a period "
                f"of {self.static.bicycle} (expected one of {', '.join(self._keys)})"
            )
        earlier = self._trials.get(trial.trial_id)
        if earlier == trial:
            return False
        if earlier is not None and trial.n_samples < earlier.n_samples:
            # a trial's samples are fixed, so a re-fit can only differ by missing data (e.g. a
            # restarted fitter that no longer has the whole trial): never trade down
            return False
        self._trials[trial.trial_id] = trial
        if key not in self._keys:  # a new hanging orientation (partial readings only)
            self._missing_readings, self._keys = self._requirements(self.static)
        return True

    def add_details(self, details: FitDetails) -> bool:
        """Take one trial's fit details, which may come before or after its estimate.

        They are kept by trial id (later details of a trial replace the earlier) and joined to
        the trial's estimate: to the one held now, and to every one that arrives later.

        Returns:
            Whether a held estimate changed (False when its estimate has not arrived yet).
        """
        self._details[details.trial_id] = details
        held = self._trials.get(details.trial_id)
        if held is None:
            return False
        joined = details.apply(held)
        if joined == held:
            return False
        self._trials[details.trial_id] = joined
        return True

    def joined(self, trial: TrialFit) -> TrialFit:
        """``trial`` with the fit details received for its trial id (as is when none arrived).

        :meth:`add` joins them so; also for an estimate the assembly refuses (the replay's
        record of what the live graph published).
        """
        return join_details(trial, self._details)

    def add_all(self, trials: Iterable[TrialFit]) -> None:
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
        """The static readings still to enter, then the keys without a usable trial, canonical order."""
        have = {p.key for p in self.periods()}
        return self._missing_readings + tuple(k for k in self._keys if k not in have)

    def result(self) -> SessionParameters:
        """The parameter set if every reading and period is there, else what is missing.

        Raises:
            MeasurementError: a combined reading is impossible (cannot happen for usable
                trials: their periods and σ are finite and positive).
            ImplausibleParametersError: the parameters are not physically possible (named with
                the readings they came from: :func:`~bike_rig.core.parameter_checks.compute_checked`).
        """
        periods = self.periods()
        have = {p.key for p in periods}
        missing = self._missing_readings + tuple(k for k in self._keys if k not in have)
        parameters = None
        if not missing:
            merged = merged_readings(self.static, {p.key: (p.value, p.sigma) for p in periods}, self.origin)
            parameters = compute_checked(merged, self.com_method)  # refused when impossible
        return SessionParameters(self.static.bicycle, self.com_method, periods, missing, parameters)


def assemble(
    static: Measurements,
    trials: Iterable[TrialFit],
    com_method: ComMethod | str = ComMethod.CENTROID,
    origin: str = "period estimates",
) -> SessionParameters:
    """One-shot :class:`SessionAssembly` (offline replay): add every trial, return the result.

    Raises:
        AssemblyError: a trial's key cannot be used (as :meth:`SessionAssembly.add`).
    """
    session = SessionAssembly(static, ComMethod(com_method), origin)
    session.add_all(trials)
    return session.result()
