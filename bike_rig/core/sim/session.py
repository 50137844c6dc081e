"""A whole simulated measurement session, as the paper performs it (sections 6–9).

:func:`simulate_session` turns a bicycle's true parameters and a rig into what the operator
would have: every static reading with noise and σ, every pendulum trial as sampled gyro rate,
and the truth. One seed gives the same session bit for bit: each kind of draw (readings, gyro,
each trial's motion and noise) has its own stream spawned from ``SeedSequence(seed)``, so adding
a trial leaves the others unchanged. Motion is analytic (:mod:`.gyro`) unless the rig adds dry
friction or a finite swing (integrated, :mod:`.pendulum`); a beating trial stays analytic.
:class:`TrialSimulator` simulates any planned trial on request, with the same streams.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..benchmark import SPLIT_PART_NAMES, compute_parameters
from ..loader import load_input
from ..measurements import Measurements, Origin, Reading
from ..symbols import PARAMETER_NAMES
from ..units import DEGREE
from .errors import SimulationError
from .gyro import Mode, adc_quantise, angular_rate, gyro_volts, rate_from_volts
from .pendulum import PendulumMotion, pendulum_rate, small_swing_factor
from .physics import TrueReadings, true_readings
from .plan import PlannedMeasurement
from .refined import refined_truth
from .rig import ReadingSigma, RigConfig, TrialPlan

__all__ = [
    "SessionTruth",
    "SimulatedSession",
    "SimulatedTrial",
    "TrialSimulator",
    "load_true_parameters",
    "motion_rate",
    "reading_sigma",
    "simulate_session",
]

FloatArray = NDArray[np.float64]


def reading_sigma(key: str, sigma: ReadingSigma) -> float:
    """The rig's standard deviation of the static reading ``key`` (flat key), in its unit."""
    if key.startswith("alpha"):
        return sigma.hanging_angle_deg
    if key[0] == "a" and key[1:2] in ("B", "H", "S", "G"):
        return sigma.string_distance
    if re.fullmatch(r"h[1-7]", key):
        return sigma.plate_height
    if re.fullmatch(r"d[1-6]", key):
        return sigma.plate_diameter
    if key in ("d", "l"):
        return sigma.plate_distance
    if key in ("nR", "nF"):
        return 0.0  # exact counts
    table = {
        "g": sigma.gravity,
        "w": sigma.wheelbase,
        "gamma": sigma.head_tube_angle_deg,
        "f": sigma.fork_offset,
        "dR": sigma.distance_rolled,
        "dF": sigma.distance_rolled,
        "lR": sigma.pendulum_arm,
        "lF": sigma.pendulum_arm,
        "lP": sigma.rod_length,
        "dP": sigma.rod_diameter,
    }
    if key in table:
        return table[key]
    if key[0] == "m":
        return sigma.mass
    raise KeyError(key)


@dataclass(frozen=True, eq=False)
class SimulatedTrial:
    """One pendulum trial: the gyro signal and what produced it.

    Attributes:
        name: File stem, e.g. ``frame_torsional_o2_t3``.
        key: Flat key of the period it measures, e.g. ``TtB2``.
        trial: 1-based trial number.
        sample_rate: Hz; sample i is at t = i / sample_rate.
        volts: Raw ADC readings, V.
        rate: The readings converted back by the nominal scale factor, rad/s.
        modes: The true motion: one mode, or two when the trial beats. With dry friction or a
            finite swing, the one analytic mode that they alter: the motion starts from its
            turning point before t = 0 (see :func:`motion_rate`).
        dry_friction: Dry friction torque over the inertia μ, rad/s²; 0 for none (always 0
            for a beating trial).
        dry_friction_fraction: The same friction as the swing lost per cycle over the mode's
            amplitude θ₀ (μ = fraction · θ₀ · ω₀² / 4, ω₀ = 2π / period), 1.
        finite_swing: The restoring torque is ∝ sin θ (a compound pendulum's finite swing):
            the period is T · :func:`~bike_rig.core.sim.pendulum.small_swing_factor` of the
            swing, and shortens as the swing decays.
    """

    name: str
    key: str
    trial: int
    sample_rate: float
    volts: FloatArray
    rate: FloatArray
    modes: tuple[Mode, ...]
    dry_friction: float = 0.0
    dry_friction_fraction: float = 0.0
    finite_swing: bool = False

    @property
    def beating(self) -> bool:
        """Whether a coupled swing mode beats with the pendulum's own mode."""
        return len(self.modes) > 1

    @property
    def true_period(self) -> float:
        """The pendulum's undamped period, s (what the paper's equations call T)."""
        return self.modes[0].period

    @property
    def time(self) -> FloatArray:
        """Sample times, s."""
        return np.arange(self.rate.shape[0], dtype=np.float64) / self.sample_rate

    def true_rate(self) -> FloatArray:
        """The pendulum's true rate θ'(t) at the sample times, before the gyro and the ADC, rad/s."""
        return motion_rate(self.time, self.modes, self.dry_friction, self.finite_swing)

    def samples(self) -> FloatArray:
        """The trial as stored: shape (N, 2), columns time s and rate rad/s, float64."""
        return np.column_stack((self.time, self.rate))


@dataclass(frozen=True)
class SessionTruth:
    """The truth behind a session, for validation only.

    Attributes:
        parameters: The 25 benchmark parameters and g.
        static: True value of every static reading by flat key (degrees for angles).
        periods: True undamped period of every measurement by flat key, s.
        damped_periods: The observed periods T / √(1 − ζ²), s (paper Eq 25).
        stiffness: Torsion-rod stiffness k, N m/rad.
        rod_inertia: Calibration rod inertia, kg m².
        scale_factor: The gyro's true scale factor in this session, V / (rad/s).
        parts: The per-part truth of a fork and handlebar hung apart (``mG``, ... ``ISzz``),
            else empty.
    """

    parameters: Mapping[str, float]
    static: Mapping[str, float]
    periods: Mapping[str, float]
    damped_periods: Mapping[str, float]
    stiffness: float
    rod_inertia: float
    scale_factor: float
    parts: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class SimulatedSession:
    """A measurement session in memory.

    Attributes:
        bicycle: The bicycle's name.
        seed: The seed it was generated from.
        rig: The rig it was measured on.
        readings: The static readings by flat key, noisy, with the rig's σ.
        plan: The period measurements, in order.
        trials: Every trial, in plan order, trials 1…n of each measurement together.
        truth: What the readings and trials should give.
    """

    bicycle: str
    seed: int
    rig: RigConfig
    readings: Mapping[str, Reading]
    plan: tuple[PlannedMeasurement, ...]
    trials: tuple[SimulatedTrial, ...]
    truth: SessionTruth

    @cached_property
    def _by_key(self) -> dict[str, tuple[SimulatedTrial, ...]]:
        out: dict[str, list[SimulatedTrial]] = {}
        for t in self.trials:
            out.setdefault(t.key, []).append(t)
        return {k: tuple(v) for k, v in out.items()}

    def trials_of(self, key: str) -> tuple[SimulatedTrial, ...]:
        """The trials of the period reading ``key`` (e.g. ``TtB2``), in trial order."""
        return self._by_key[key]

    @property
    def label(self) -> str:
        """How readings of this session name their origin."""
        return f"<simulated {self.bicycle}, seed {self.seed}>"

    def measurements(self, periods: Mapping[str, tuple[float, float]]) -> Measurements:
        """The session's measurement set, once its periods are known.

        Args:
            periods: ``{flat key: (period s, σ s)}`` for every planned measurement, e.g. the
                combined fits of each measurement's trials.

        Returns:
            The static readings and these periods, ready for
            :func:`~bike_rig.core.benchmark.compute_parameters`.
        """
        readings = dict(self.readings)
        for m in self.plan:
            value, sigma = periods[m.key]
            readings[m.key] = Reading(float(value), float(sigma), Origin(self.label, m.key))
        return Measurements(self.bicycle, readings, self.label, {"simulated": True, "seed": self.seed})


def load_true_parameters(path: str | Path) -> tuple[str, dict[str, float]]:
    """The bicycle's name and true parameters from any accepted input file.

    A parameter file gives them directly; a measurement file gives the parameters it
    computes to (:func:`~bike_rig.core.benchmark.compute_parameters`), and for the refined
    method what its simulation needs beyond them (:func:`.refined.refined_truth`): its
    simulated sessions then read a surface plate and/or hang the fork and handlebar apart.

    Raises:
        InputFileError: the file cannot be read (see :func:`~bike_rig.core.loader.load_input`).
    """
    got = load_input(path)
    if not isinstance(got, Measurements):
        return got.bicycle, got.values()
    ps = compute_parameters(got)
    computed = {**ps.values(), **(ps.parts.as_dict() if ps.parts is not None else {})}
    return ps.bicycle, {**ps.values(), **refined_truth(got, computed)}


def _static_readings(truth: TrueReadings, rig: RigConfig, rng: np.random.Generator, label: str) -> dict[str, Reading]:
    keys = list(truth.static)
    draws = rng.standard_normal(len(keys))
    out = {}
    for key, z in zip(keys, draws):
        s = reading_sigma(key, rig.sigma)
        out[key] = Reading(truth.static[key] + s * float(z), s, Origin(label, key))
    return out


def _beats(m: PlannedMeasurement, name: str, rig: RigConfig, rng: np.random.Generator) -> bool:
    swing = rig.coupled_swing
    if swing is None:
        return False
    eligible = m.pendulum == "torsional" and m.part in ("frame", "fork")
    drawn = eligible and swing.probability > 0 and bool(rng.random() < swing.probability)
    return drawn or name in swing.trials


def _modes(
    m: PlannedMeasurement, name: str, period: float, rig: RigConfig, rng: np.random.Generator
) -> tuple[Mode, ...]:
    zeta = rig.trials.damping_ratio
    lo, hi = rig.trials.amplitude_deg
    amplitude = float(rng.uniform(lo, hi)) * DEGREE
    phase = float(rng.uniform(0.0, 2.0 * np.pi))
    if not _beats(m, name, rig, rng):
        return (Mode(period, zeta, amplitude, phase),)
    swing = rig.coupled_swing
    assert swing is not None
    detuning = float(rng.uniform(*swing.detuning)) * (1.0 if rng.random() < 0.5 else -1.0)
    ratio = float(rng.uniform(*swing.amplitude_ratio))
    second_phase = float(rng.uniform(0.0, 2.0 * np.pi))
    return (
        Mode(period, zeta, amplitude / (1.0 + ratio), phase),
        Mode(period / (1.0 + detuning), zeta, amplitude * ratio / (1.0 + ratio), second_phase),
    )


def _dry_friction_fraction(plan: TrialPlan, rng: np.random.Generator) -> float:
    """The trial's dry friction as the swing lost per cycle over the initial swing, 1.

    Drawn from ``rng`` only when the rig has dry friction at all, so that a rig without it
    consumes its motion stream exactly as before dry friction existed.
    """
    lo, hi = plan.dry_friction
    return float(rng.uniform(lo, hi)) if hi > 0 else 0.0


def motion_rate(t: FloatArray, modes: tuple[Mode, ...], dry_friction: float, finite_swing: bool) -> FloatArray:
    """The rate of a trial's pendulum, rad/s: analytic, or integrated with friction or a finite swing.

    Without dry friction and finite swing, :func:`~bike_rig.core.sim.gyro.angular_rate` of
    the modes. Otherwise the one mode's pendulum is integrated
    (:func:`~bike_rig.core.sim.pendulum.pendulum_rate`) from the turning point of the analytic
    motion θ₀ e^(−ζωₙt) cos(ω_d t + φ) last before t = 0: at t = −(φ + δ) / ω_d with
    sin δ = ζ, where θ = θ₀ √(1 − ζ²) e^(ζωₙ(φ + δ)/ω_d). So as the friction goes to 0 the
    integrated motion is the analytic one; with a finite swing, the time back to that turning
    point is stretched by :func:`~bike_rig.core.sim.pendulum.small_swing_factor` of its swing
    (the phase is the same fraction of the longer first cycle).

    Args:
        t: Sample times, s.
        modes: The trial's modes.
        dry_friction: Friction torque over the inertia μ, rad/s².
        finite_swing: Restoring torque ∝ sin θ rather than ∝ θ.

    Returns:
        θ'(t), rad/s.

    Raises:
        SimulationError: Dry friction or a finite swing with two modes (a beating trial), or a
            compound swing that would reach π rad at its turning point.
    """
    if dry_friction == 0.0 and not finite_swing:
        return angular_rate(t, modes)
    if len(modes) != 1:
        raise SimulationError("dry friction and a finite swing are simulated for one mode only, not a beating trial")
    (mode,) = modes
    zeta = mode.damping_ratio
    wn = 2.0 * np.pi / mode.period
    wd = wn * float(np.sqrt(1.0 - zeta**2))
    back = (mode.phase + float(np.arcsin(zeta))) / wd  # s, to the turning point before t = 0
    swing = mode.amplitude * float(np.sqrt(1.0 - zeta**2) * np.exp(zeta * wn * back))
    phase_time = back * (small_swing_factor(swing) if finite_swing else 1.0)
    motion = PendulumMotion(mode.period, swing, zeta, dry_friction, compound=finite_swing)
    return pendulum_rate(t, motion, phase_time)


def _check_seed(seed: object) -> int:
    """``seed`` as a non-negative integer.

    Raises:
        SimulationError: It is not one.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SimulationError(f"a seed is a non-negative integer, got {seed!r}")
    return int(seed)


def _scale_factor(rig: RigConfig, gyro_ss: np.random.SeedSequence) -> float:
    """The session's true gyro scale factor, V / (rad/s): the nominal one within its tolerance."""
    gyro = rig.gyro
    return float(
        gyro.scale_factor * (1.0 + gyro.scale_factor_tolerance * np.random.default_rng(gyro_ss).standard_normal())
    )


def _simulate_trial(
    m: PlannedMeasurement,
    repeat: int,
    name: str,
    period: float,
    rig: RigConfig,
    scale: float,
    trial_ss: np.random.SeedSequence,
    duration_s: float | None = None,
) -> SimulatedTrial:
    """One trial of ``m``: its motion (amplitude, phase, beating, friction, swing), the gyro and the ADC.

    A beating trial (two modes) stays analytic: the rig's dry friction and finite swing apply
    to single-mode trials only (its friction is still drawn, and recorded as 0).

    Args:
        m: The measurement.
        repeat: Its 1-based trial number.
        name: The trial's name (the rig's ``coupled_swing.trials`` are matched against it).
        period: The true undamped period of ``m``, s.
        rig: The rig.
        scale: The session's true gyro scale factor, V / (rad/s).
        trial_ss: The trial's own seed sequence (motion and sensor streams are spawned from it).
        duration_s: Rig seconds to record; None for the rig's (drawn from its list, if a list).

    Returns:
        The trial (raw volts, rate, true modes, dry friction and finite swing).
    """
    motion_ss, sensor_ss = trial_ss.spawn(2)
    motion = np.random.default_rng(motion_ss)
    gyro, adc, plan_t = rig.gyro, rig.adc, rig.trials
    # always drawn (when the rig lists several durations), so that the motion stream is the same
    drawn = plan_t.durations[0] if len(plan_t.durations) == 1 else float(motion.choice(plan_t.durations))
    duration = drawn if duration_s is None else duration_s
    modes = _modes(m, name, period, rig, motion)
    fraction = _dry_friction_fraction(plan_t, motion)  # the last draw of the motion stream
    single = len(modes) == 1
    fraction = fraction if single else 0.0
    finite = single and plan_t.finite_swing and m.pendulum == "compound"
    mu = fraction * modes[0].amplitude * (2.0 * np.pi / modes[0].period) ** 2 / 4.0
    t = np.arange(int(round(duration * adc.sample_rate)), dtype=np.float64) / adc.sample_rate
    rate = motion_rate(t, modes, mu, finite)
    volts = adc_quantise(gyro_volts(rate, gyro, adc.sample_rate, scale, np.random.default_rng(sensor_ss)), adc)
    return SimulatedTrial(
        name,
        m.key,
        repeat,
        adc.sample_rate,
        volts,
        rate_from_volts(volts, gyro),
        modes,
        dry_friction=mu,
        dry_friction_fraction=fraction,
        finite_swing=finite,
    )


def simulate_session(
    true_params: Mapping[str, float], rig: RigConfig, seed: int, bicycle: str = "simulated"
) -> SimulatedSession:
    """Simulate a whole measurement session of one bicycle on one rig.

    Args:
        true_params: The 25 benchmark parameters and g (SI, ``lam`` in rad).
        rig: The rig (see :mod:`bike_rig.core.sim.rig`).
        seed: Any non-negative integer; the same seed gives the same session.
        bicycle: The bicycle's name.

    Returns:
        The session: static readings, trials and truth.

    Raises:
        SimulationError: the seed is not a non-negative integer, the parameters are impossible
            or the rig cannot measure them.
    """
    seed = _check_seed(seed)
    truth = true_readings(true_params, rig)
    label = f"<simulated {bicycle}, seed {seed}>"
    static_ss, gyro_ss, trials_ss = np.random.SeedSequence(seed).spawn(3)
    readings = _static_readings(truth, rig, np.random.default_rng(static_ss), label)
    plan_t = rig.trials
    scale = _scale_factor(rig, gyro_ss)
    n_trials = len(truth.plan) * plan_t.per_measurement
    trial_seeds = iter(trials_ss.spawn(n_trials))
    trials = []
    for m in truth.plan:
        for i in range(1, plan_t.per_measurement + 1):
            period = truth.periods[m.key]
            trials.append(_simulate_trial(m, i, m.trial_name(i), period, rig, scale, next(trial_seeds)))
    zeta = plan_t.damping_ratio
    st = SessionTruth(
        parameters={k: float(true_params[k]) for k in PARAMETER_NAMES},
        parts={k: float(true_params[k]) for k in SPLIT_PART_NAMES if k in true_params},
        static=truth.static,
        periods=truth.periods,
        damped_periods={k: T / float(np.sqrt(1.0 - zeta**2)) for k, T in truth.periods.items()},
        stiffness=truth.stiffness,
        rod_inertia=truth.rod_inertia,
        scale_factor=scale,
    )
    return SimulatedSession(bicycle, seed, rig, readings, truth.plan, tuple(trials), st)


@dataclass(frozen=True, eq=False)
class TrialSimulator:
    """One bicycle on one rig, ready to simulate any planned trial on request (the operator's rig).

    The same physics and sensor model as :func:`simulate_session`: true periods from
    :func:`~bike_rig.core.sim.physics.true_readings`, the session's one gyro scale factor (the
    same draw as the session of this seed), and per trial an amplitude and phase drawn from
    the rig's range, a coupled swing mode as the rig says, the gyro's bias, drift and noise and
    the ADC. Trial number ``counter`` (0-based, counting every trial simulated, in request
    order) draws from the random streams of the session's trial ``counter``: requesting the
    plan's trials in plan order with the rig's durations gives :func:`simulate_session`'s
    trials bit for bit, and one (seed, counter) always gives the same trial.

    Attributes:
        bicycle: The bicycle's name.
        seed: The seed.
        rig: The rig.
        truth: The true readings and periods (and the plan).
        scale_factor: The gyro's true scale factor in this session, V / (rad/s).
    """

    bicycle: str
    seed: int
    rig: RigConfig
    truth: TrueReadings
    scale_factor: float
    _trials_ss: np.random.SeedSequence

    @classmethod
    def create(
        cls, true_params: Mapping[str, float], rig: RigConfig, seed: int, bicycle: str = "simulated"
    ) -> TrialSimulator:
        """The simulator of ``bicycle`` (its true parameters) on ``rig`` with ``seed``.

        Raises:
            SimulationError: As :func:`simulate_session`.
        """
        seed = _check_seed(seed)
        truth = true_readings(true_params, rig)
        _, gyro_ss, trials_ss = np.random.SeedSequence(seed).spawn(3)
        return cls(bicycle, seed, rig, truth, _scale_factor(rig, gyro_ss), trials_ss)

    @property
    def plan(self) -> tuple[PlannedMeasurement, ...]:
        """The rig's planned measurements, in order."""
        return self.truth.plan

    def damped_period(self, key: str) -> float:
        """The observed period of measurement ``key``, T / √(1 − ζ²), s (paper Eq 25)."""
        zeta = self.rig.trials.damping_ratio
        return self.truth.periods[key] / float(np.sqrt(1.0 - zeta**2))

    def simulate(
        self, m: PlannedMeasurement, counter: int, repeat: int, name: str = "", duration_s: float | None = None
    ) -> SimulatedTrial:
        """Simulate one trial of the planned measurement ``m``.

        Args:
            m: One of :attr:`plan`.
            counter: 0-based number of the trial in the session (its random streams).
            repeat: Its 1-based trial number of ``m``.
            name: The trial's name (default ``m.trial_name(repeat)``); the rig's
                ``coupled_swing.trials`` are matched against it.
            duration_s: Rig seconds to record, > 0; None for the rig's duration.

        Raises:
            SimulationError: ``m`` is not planned on this rig, or a bad counter or duration.
        """
        if m.key not in self.truth.periods or m not in self.truth.plan:
            raise SimulationError(f"{m.stem} ({m.key}) is not a measurement of this rig's plan")
        if isinstance(counter, bool) or not isinstance(counter, int) or counter < 0:
            raise SimulationError(f"a trial counter is a non-negative integer, got {counter!r}")
        if duration_s is not None and not (np.isfinite(duration_s) and duration_s > 0):
            raise SimulationError(f"a trial lasts > 0 s, got {duration_s!r}")
        ss = self._trials_ss
        trial_ss = np.random.SeedSequence(ss.entropy, spawn_key=(*ss.spawn_key, counter), pool_size=ss.pool_size)
        name = name or m.trial_name(repeat)
        period = self.truth.periods[m.key]
        return _simulate_trial(m, repeat, name, period, self.rig, self.scale_factor, trial_ss, duration_s)
