"""A whole simulated measurement session, as the paper performs it (sections 6–9).

:func:`simulate_session` takes a bicycle's true parameters and a rig and returns, in memory,
what the rig's operator would have: every static reading with its noise and σ, and every
pendulum trial (each part as compound and torsional pendulum, at each orientation, three
trials each) as the sampled gyro rate, plus the truth for validation. One seed gives the
same session, bit for bit: every random draw comes from a :class:`numpy.random.Generator`
spawned from ``SeedSequence(seed)`` (static readings, the gyro, and each trial's motion and
sensor noise each get their own stream, so adding a trial leaves the others unchanged).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..benchmark import compute_parameters
from ..loader import load_input
from ..measurements import Measurements, Origin, Reading
from ..symbols import PARAMETER_NAMES
from ..units import DEGREE
from .errors import SimulationError
from .gyro import Mode, adc_quantise, angular_rate, gyro_volts, rate_from_volts
from .physics import TrueReadings, true_readings
from .plan import PlannedMeasurement
from .rig import ReadingSigma, RigConfig

__all__ = [
    "SessionTruth",
    "SimulatedSession",
    "SimulatedTrial",
    "load_true_parameters",
    "reading_sigma",
    "simulate_session",
]

FloatArray = NDArray[np.float64]


def reading_sigma(key: str, sigma: ReadingSigma) -> float:
    """The rig's standard deviation of the static reading ``key`` (flat key), in its unit."""
    if key.startswith("alpha"):
        return sigma.hanging_angle_deg
    if key[0] == "a" and key[1:2] in ("B", "H"):
        return sigma.string_distance
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
        modes: The true motion: one mode, or two when the trial beats.
    """

    name: str
    key: str
    trial: int
    sample_rate: float
    volts: FloatArray
    rate: FloatArray
    modes: tuple[Mode, ...]

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
    """

    parameters: Mapping[str, float]
    static: Mapping[str, float]
    periods: Mapping[str, float]
    damped_periods: Mapping[str, float]
    stiffness: float
    rod_inertia: float
    scale_factor: float


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
    computes to (:func:`~bike_rig.core.benchmark.compute_parameters`).

    Raises:
        InputFileError: the file cannot be read (see :func:`~bike_rig.core.loader.load_input`).
    """
    got = load_input(path)
    ps = compute_parameters(got) if isinstance(got, Measurements) else got
    return ps.bicycle, ps.values()


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
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SimulationError(f"a seed is a non-negative integer, got {seed!r}")
    truth = true_readings(true_params, rig)
    label = f"<simulated {bicycle}, seed {seed}>"
    static_ss, gyro_ss, trials_ss = np.random.SeedSequence(seed).spawn(3)
    readings = _static_readings(truth, rig, np.random.default_rng(static_ss), label)
    gyro, adc, plan_t = rig.gyro, rig.adc, rig.trials
    scale = gyro.scale_factor * (1.0 + gyro.scale_factor_tolerance * np.random.default_rng(gyro_ss).standard_normal())
    n_trials = len(truth.plan) * plan_t.per_measurement
    trial_seeds = iter(trials_ss.spawn(n_trials))
    trials = []
    for m in truth.plan:
        for i in range(1, plan_t.per_measurement + 1):
            motion_ss, sensor_ss = next(trial_seeds).spawn(2)
            motion = np.random.default_rng(motion_ss)
            name = m.trial_name(i)
            duration = plan_t.durations[0] if len(plan_t.durations) == 1 else float(motion.choice(plan_t.durations))
            modes = _modes(m, name, truth.periods[m.key], rig, motion)
            t = np.arange(int(round(duration * adc.sample_rate)), dtype=np.float64) / adc.sample_rate
            volts = adc_quantise(
                gyro_volts(angular_rate(t, modes), gyro, adc.sample_rate, scale, np.random.default_rng(sensor_ss)), adc
            )
            trials.append(SimulatedTrial(name, m.key, i, adc.sample_rate, volts, rate_from_volts(volts, gyro), modes))
    zeta = plan_t.damping_ratio
    st = SessionTruth(
        parameters={k: float(true_params[k]) for k in PARAMETER_NAMES},
        static=truth.static,
        periods=truth.periods,
        damped_periods={k: T / float(np.sqrt(1.0 - zeta**2)) for k, T in truth.periods.items()},
        stiffness=truth.stiffness,
        rod_inertia=truth.rod_inertia,
        scale_factor=float(scale),
    )
    return SimulatedSession(bicycle, seed, rig, readings, truth.plan, tuple(trials), st)
