"""A simulated raw ride log: riding off and on, manoeuvres, lateral pushes; roll rate and wheel speed.

What an instrumented balance-assist bicycle records over a whole ride, with no steer-torque
channel: the rider starts from standstill, rides, turns, stops and starts again, and is pushed
sideways at the seat post a few times while riding straight. The linear Whipple model
(:func:`bike_rig.core.whipple.state_space`, ``x = [φ, δ, φ̇, δ̇]``, ``u = [T_φ, T_δ]``) runs at
the speed of each sample (exact zero-order-hold discretisation, cached per 0.05 m/s) with

* the steer torque ``−K(v) x`` of the balance assist and the rider's arms (``K`` from
  :attr:`RideLog.gains`; the assist's share clipped at ``saturation`` N m; the assist samples
  the state and holds its torque for one period of ``controller_hz``, by default the log's
  rate; a faster assist steps the model in sub-steps), plus the rider's
  steering noise (Ornstein–Uhlenbeck: σ ``rider_torque`` N m, correlation time ``rider_tau`` s),
  plus each turn's steer torque (a half-sine in, held, a half-sine out);
* the roll torque of each push (``push_torque`` N m for ``push_s`` s), of the rider's pedalling
  (at the cadence, strong while starting up), and of the rider's feet below ``feet_speed`` m/s
  (a roll spring and damper, 3000 N m/rad and 600 N m s/rad at standstill, fading linearly to
  none at ``feet_speed``; the rider's hands hold the handlebar alike, 20 N m/rad and
  2 N m s/rad: standing and the first metres are not steered).

The speed follows the plan: start-ups ramp it from 0 to ``cruise`` over ``startup_s`` s with a
pedalling surge at twice the cadence (0.06 m/s, a fifth of it at speed), stops ramp it to 0
over ``stop_s`` s, each turn slows the rider by ``turn_slowing`` of the speed. The wheel-speed
sensor reads the speed plus white noise ``noise_speed`` (0 at standstill) plus, at each push, the wheel's jolt: a pulse
``a (s/τ) e^{1 − s/τ}`` (``s`` from the push's start, ``τ = push_jolt_s``; ``a`` uniform in
±``push_jolt`` m/s, at least half its size). The roll-rate gyro adds white noise
``noise_roll_rate``. The truth of each push's free decay is the push's own response (the log
less the same log without that push): it starts when the push ends and ends where that response's
envelope (the analytic signal's magnitude) last exceeds ``decay_level`` times the RMS of the
roll rate without any push over the 4 s before the push. Units: SI, times s.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..whipple import WhippleMatrices, state_space
from ..whipple.sampled import zero_order_hold
from .errors import SimulationError

__all__ = [
    "LOG_COLUMNS",
    "PushTruth",
    "RideLog",
    "SimulatedLog",
    "assist_gains",
    "ride_plan",
    "simulate_raw_log",
    "write_log_csv",
]

FloatArray = NDArray[np.float64]

#: Speeds of the cached discretisations are rounded to this [m/s].
SPEED_STEP = 0.05
#: A roll rate beyond this means the simulated bicycle fell over [rad/s].
MAX_ROLL_RATE = 10.0
#: A push's own response is followed this long [s].
TRUTH_SPAN_S = 10.0
#: The most model sub-steps per log sample (an assist this many times faster than the log at most).
MAX_SUBSTEPS = 50
#: The columns of a simulated raw log's CSV file, in order (no steer torque).
LOG_COLUMNS = ("time", "roll_rate", "wheel_speed")


def assist_gains(speed: float) -> FloatArray:
    """Steer-torque gains ``[kφ, kδ, kφ̇, kδ̇]`` of the simulated assist and rider's arms at ``speed`` [m/s].

    A roll-rate gain of −50 N m s/rad up to 2 m/s easing to −20 at 5 m/s and beyond, and a
    steer-rate damping of 1 N m s/rad: Browser with the paper's rider weaves at about
    −1.4 + 9.6i 1/s at 5 m/s, −0.6 + 7.3i at 1.67 m/s.
    """
    k_phidot = float(np.interp(speed, (2.0, 10.0 / 3.0, 5.0), (-50.0, -25.0, -20.0)))
    return np.array([0.0, 0.0, k_phidot, 1.0])


@dataclass(frozen=True)
class RideLog:
    """What the rider does (module docstring).

    Attributes:
        duration: Length of the log [s].
        cruise: Riding speed [m/s].
        starts: Times the rider starts from standstill [s] (the log begins standing).
        stops: Times the rider starts to brake to a stop [s].
        turns: Start times of turns [s].
        pushes: Start times of lateral pushes [s].
        rate_hz: Sample rate [Hz].
        noise_roll_rate: σ of the roll-rate gyro [rad/s].
        noise_speed: σ of the wheel-speed sensor [m/s].
        rider_torque: σ of the rider's steering noise [N m].
        rider_tau: Its correlation time [s].
        saturation: The assist motor's largest torque [N m].
        push_torque: The push's roll torque [N m] (its sign random).
        push_s: The push's length [s].
        push_jolt: The largest wheel-speed jolt of a push [m/s].
        push_jolt_s: The jolt's time constant [s].
        turn_torque: The turn's steer torque [N m] (its sign random).
        turn_s: A turn's length [s].
        turn_slowing: A turn's speed loss, relative [-].
        startup_s: A start-up's length [s].
        stop_s: A stop's length [s].
        cadence_hz: The pedalling cadence at speed [Hz].
        pedal_torque: The roll torque of pedalling while starting [N m] (a tenth of it at speed).
        feet_speed: Below this the rider's feet hold the roll [m/s].
        decay_level: The free decay's end, in RMS of the riding's roll rate [-].
        gains: The steer-torque gains at a speed (:func:`assist_gains`).
        controller_hz: The assist's rate [Hz]: it samples the state and holds its torque this
            long; a simple ratio (at most :data:`MAX_SUBSTEPS`) of ``rate_hz``. None: ``rate_hz``.
    """

    duration: float
    cruise: float
    starts: tuple[float, ...] = (1.0,)
    stops: tuple[float, ...] = ()
    turns: tuple[float, ...] = ()
    pushes: tuple[float, ...] = ()
    rate_hz: float = 100.0
    noise_roll_rate: float = 0.01
    noise_speed: float = 0.03
    rider_torque: float = 0.3
    rider_tau: float = 0.3
    saturation: float = 8.0
    push_torque: float = 150.0
    push_s: float = 0.15
    push_jolt: float = 0.4
    push_jolt_s: float = 0.06
    turn_torque: float = 3.0
    turn_s: float = 3.0
    turn_slowing: float = 0.2
    startup_s: float = 6.0
    stop_s: float = 3.0
    cadence_hz: float = 1.2
    pedal_torque: float = 15.0
    feet_speed: float = 1.5
    decay_level: float = 2.0
    gains: Callable[[float], FloatArray] = field(default=assist_gains, repr=False)
    controller_hz: float | None = None


def _steps(log: RideLog) -> tuple[int, int]:
    """``(p, q)``: the model steps ``p`` times per log sample and the assist acts every ``q`` steps.

    Raises:
        SimulationError: The assist's rate is not finite and > 0, or not a simple ratio of the log's.
    """
    if log.controller_hz is None:
        return 1, 1
    rate = log.controller_hz
    if not (math.isfinite(rate) and rate > 0):
        raise SimulationError(f"the assist's rate must be a finite number > 0 Hz, got {rate}")
    ratio = Fraction(rate / log.rate_hz).limit_denominator(1000)
    if ratio.numerator > MAX_SUBSTEPS or abs(float(ratio) - rate / log.rate_hz) > 1e-9 * rate / log.rate_hz:
        raise SimulationError(
            f"the assist's rate {rate:g} Hz must be a simple ratio p/q of the log's {log.rate_hz:g} Hz "
            f"(p <= {MAX_SUBSTEPS}, q <= 1000)"
        )
    return ratio.numerator, ratio.denominator


@dataclass(frozen=True)
class PushTruth:
    """One push and its free decay (module docstring).

    Attributes:
        time: The push's start [s].
        start: The free decay's start: the push's end [s].
        stop: The free decay's end [s].
        speed: The speed at the push [m/s].
        level: The level its envelope falls to at ``stop`` [rad/s].
        response: The push's own roll rate from ``time`` on, at the log's samples [rad/s].
    """

    time: float
    start: float
    stop: float
    speed: float
    level: float = math.nan
    response: FloatArray = field(default_factory=lambda: np.empty(0), repr=False, compare=False)


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated raw log and its truth.

    Attributes:
        times: Sample times [s].
        roll_rate: Measured φ̇ [rad/s].
        wheel_speed: Measured wheel speed [m/s].
        speed: The true speed [m/s].
        pushes: Each push's truth.
    """

    times: FloatArray
    roll_rate: FloatArray
    wheel_speed: FloatArray
    speed: FloatArray
    pushes: tuple[PushTruth, ...]


def ride_plan(duration: float, cruise: float, pushes: int, rng: np.random.Generator) -> RideLog:
    """A ride off and on: starts, stops and turns at random, ``pushes`` pushes while riding straight.

    Start at 1 s; ride 25–45 s, stop, stand 3–6 s, start again; a turn every 12–25 s of riding.
    A push comes at least 6 s after a start-up's end, 4 s after any turn, stop or other push
    ends and 8 s before one begins (a plan is drawn again until the pushes fit).

    Raises:
        SimulationError: The pushes do not fit the log (after 100 plans).
    """
    for _ in range(100):
        plan = _plan(duration, cruise, pushes, rng)
        if plan is not None:
            return plan
    raise SimulationError(f"{pushes} pushes do not fit a {duration:g} s ride with its turns and stops")


def _plan(duration: float, cruise: float, pushes: int, rng: np.random.Generator) -> RideLog | None:
    """One draw of :func:`ride_plan`, or None (the pushes do not fit)."""
    probe = RideLog(duration, cruise)
    starts, stops, turns = [1.0], [], []
    t = 1.0
    while True:
        stop = t + rng.uniform(25.0, 45.0)
        if stop + probe.stop_s + 3.0 >= duration:
            break
        stops.append(stop)
        t = stop + probe.stop_s + rng.uniform(3.0, 6.0)
        starts.append(t)
    riding = [(s + probe.startup_s, e) for s, e in zip(starts, [*stops, duration], strict=False)]
    for a, b in riding:
        u = a + rng.uniform(6.0, 12.0)
        while u + probe.turn_s < b - 2.0:
            turns.append(u)
            u += probe.turn_s + rng.uniform(12.0, 25.0)
    busy = [(s, s + probe.turn_s) for s in turns] + [(s, s + probe.stop_s) for s in stops]
    times: list[float] = []
    for _ in range(50 * max(pushes, 1)):
        if len(times) == pushes:
            break
        a, b = riding[int(rng.integers(len(riding)))]
        p = rng.uniform(a + 6.0, b - 8.0) if b - 8.0 > a + 6.0 else math.nan
        if math.isfinite(p) and all(p + 8.0 <= s or p >= e + 4.0 for s, e in busy):
            times.append(float(p))
            busy.append((p, p + probe.push_s))
    if len(times) < pushes:
        return None
    return RideLog(duration, cruise, tuple(starts), tuple(stops), tuple(turns), tuple(sorted(times)))


def _bump(t: FloatArray, t0: float, length: float) -> FloatArray:
    """A half-sine of height 1 from ``t0`` lasting ``length`` [s], 0 elsewhere."""
    s = (t - t0) / length
    return np.where((s >= 0) & (s <= 1), np.sin(np.pi * np.clip(s, 0.0, 1.0)), 0.0)


def _ramp(s: FloatArray) -> FloatArray:
    """0 → 1 smoothly over s in [0, 1]."""
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(s, 0.0, 1.0))


def _speed(t: FloatArray, log: RideLog) -> FloatArray:
    """The true speed [m/s] of the plan (module docstring)."""
    events = sorted([(s, "start") for s in log.starts] + [(s, "stop") for s in log.stops])
    v = np.zeros_like(t)
    for when, kind in events:
        if kind == "start":
            on = t >= when
            v[on] = log.cruise * _ramp((t[on] - when) / log.startup_s)
        else:
            on = t >= when
            v[on] = log.cruise * (1.0 - _ramp((t[on] - when) / log.stop_s))
    for s in log.turns:
        v *= 1.0 - log.turn_slowing * _bump(t, s, log.turn_s)
    # the pedalling surge while starting (twice the cadence), small at speed
    share = np.clip(v / log.cruise, 0.0, 1.0) if log.cruise > 0 else np.zeros_like(t)
    surge = 0.06 * (1.0 - 0.8 * share) * np.sin(4.0 * np.pi * log.cadence_hz * t) * (v > 0)
    return np.maximum(v + surge, 0.0)


def simulate_raw_log(matrices: WhippleMatrices, g: float, log: RideLog, rng: np.random.Generator) -> SimulatedLog:
    """Simulate a raw ride log (module docstring).

    Args:
        matrices: The canonical matrices of the bicycle with its rider [SI].
        g: Gravity [m/s²].
        log: What the rider does, the sensors, the pushes.
        rng: The random generator (noise, signs, the rider).

    Raises:
        SimulationError: A non-positive duration or rate, a negative speed, an assist's rate
            that is not a simple ratio of the log's, or a ride that falls over (the gains do not
            stabilise this bicycle).
    """
    from scipy.signal import hilbert

    if not (log.duration > 0 and log.rate_hz > 0 and log.cruise >= 0):
        raise SimulationError(
            f"a ride log needs duration > 0 s, rate > 0 Hz and speed >= 0 m/s, "
            f"got {log.duration} s, {log.rate_hz} Hz, {log.cruise} m/s"
        )
    hold = _steps(log)[1]  # the assist acts every `hold` log samples (1 when it is as fast or faster)
    n = int(round(log.duration * log.rate_hz))
    dt = 1.0 / log.rate_hz
    t = np.arange(n, dtype=np.float64) * dt
    v = _speed(t, log)
    decay = math.exp(-dt / log.rider_tau) if log.rider_tau > 0 else 0.0
    rider = np.empty(n)
    rider[0] = rng.normal(0.0, log.rider_torque)
    kicks = rng.normal(0.0, log.rider_torque * math.sqrt(1.0 - decay**2), n)
    for i in range(1, n):
        rider[i] = decay * rider[i - 1] + kicks[i]
    turn = np.zeros(n)
    for s in log.turns:
        sign = rng.choice((-1.0, 1.0))
        turn += sign * log.turn_torque * (_bump(t, s, 0.6) - _bump(t, s + log.turn_s - 0.6, 0.6))
    share = np.clip(v / log.cruise, 0.0, 1.0) if log.cruise > 0 else np.zeros(n)
    pedal = log.pedal_torque * (1.0 - 0.9 * share) * np.sin(2.0 * np.pi * log.cadence_hz * t) * (v > 0)
    signs = rng.choice((-1.0, 1.0), len(log.pushes))
    pushes = [(p, s * log.push_torque) for p, s in zip(log.pushes, signs, strict=True)]
    steer = rider + turn
    with np.errstate(all="ignore"):  # (a ride that falls over is refused below)
        base_states = _run(matrices, g, log, t, v, pedal, steer, [])
        rates = _run(matrices, g, log, t, v, pedal, steer, pushes)[:, 2]
    base = base_states[:, 2]
    if not np.all(np.isfinite(rates)) or np.max(np.abs(rates)) > MAX_ROLL_RATE:
        raise SimulationError(
            f"the simulated ride falls over: roll rate beyond {MAX_ROLL_RATE:g} rad/s (the assist's gains "
            f"do not keep this bicycle upright at 0–{log.cruise:g} m/s)"
        )
    measured = rates + rng.normal(0.0, log.noise_roll_rate, n)
    wheel = v + rng.normal(0.0, log.noise_speed, n)
    truths = []
    background = base + (measured - rates)
    for p, s in pushes:
        size = log.push_jolt * rng.uniform(0.5, 1.0) * rng.choice((-1.0, 1.0))
        u = np.clip((t - p) / log.push_jolt_s, 0.0, None)
        wheel += size * u * np.exp(1.0 - u)
        first = int(np.searchsorted(t, p))
        w = slice(first - first % hold, int(np.searchsorted(t, p + TRUTH_SPAN_S)))  # from a tick of the assist
        parts = (t[w], v[w], pedal[w], steer[w])
        alone = (_run(matrices, g, log, *parts, [(p, s)], base_states[w.start])[:, 2] - base[w])[first - w.start :]
        w = slice(first, w.stop)
        before = (t >= p - 4.0) & (t < p)
        level = log.decay_level * float(np.sqrt(np.mean(background[before] ** 2)))
        after = np.flatnonzero(np.abs(hilbert(np.r_[alone, np.zeros(alone.size)]))[: alone.size] > level)
        stop = float(t[w][after[-1]]) if after.size else p + log.push_s
        truths.append(PushTruth(p, p + log.push_s, stop, float(np.interp(p, t, v)), level, alone))
    wheel = np.where(v > 0, np.maximum(wheel, 0.0), 0.0)  # (a standing wheel reads 0)
    return SimulatedLog(t, measured, wheel, v, tuple(truths))


def _run(
    matrices: WhippleMatrices,
    g: float,
    log: RideLog,
    t: FloatArray,
    v: FloatArray,
    pedal: FloatArray,
    steer: FloatArray,
    pushes: list[tuple[float, float]],
    x0: FloatArray | None = None,
) -> FloatArray:
    """The true states ``[φ, δ, φ̇, δ̇]`` (shape (n, 4)) over ``t`` from ``x0`` with the given pushes (start [s], N m)."""
    p, q = _steps(log)
    h = 1.0 / (log.rate_hz * p)
    keys = np.rint(v / SPEED_STEP).astype(int)
    unique = np.unique(keys)
    ads, bds = zero_order_hold(*state_space(matrices, unique * SPEED_STEP, g), h)
    cache = {int(key): (ads[j], bds[j], log.gains(key * SPEED_STEP)) for j, key in enumerate(unique)}
    feet = np.clip(1.0 - v / log.feet_speed, 0.0, 1.0) if log.feet_speed > 0 else np.zeros(t.size)
    roll = pedal.copy()
    for start, s in pushes:
        roll[(t >= start) & (t < start + log.push_s)] += s
    x = np.zeros(4) if x0 is None else np.asarray(x0, dtype=float).copy()
    states = np.empty((t.size, 4))
    first = int(round(t[0] * log.rate_hz)) * p if t.size else 0  # the assist's ticks are at absolute steps
    assist = 0.0
    for i in range(t.size):
        ad, bd, k = cache[int(keys[i])]
        states[i] = x
        for j in range(p):
            if (first + i * p + j) % q == 0 or (i == 0 and j == 0):
                assist = min(log.saturation, max(-log.saturation, -float(k @ x)))
            u0 = roll[i] - feet[i] * (3000.0 * x[0] + 600.0 * x[2])
            u1 = assist + steer[i] - feet[i] * (20.0 * x[1] + 2.0 * x[3])
            x = ad @ x + bd[:, 0] * u0 + bd[:, 1] * u1
    return states


def write_log_csv(log: SimulatedLog, path: str | Path) -> None:
    """Write the log's sensor signals as CSV (columns :data:`LOG_COLUMNS`; s, rad/s, m/s)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(LOG_COLUMNS)
        for t, y, v in zip(log.times, log.roll_rate, log.wheel_speed, strict=True):
            w.writerow([f"{t:.4f}", f"{y:.6g}", f"{v:.6g}"])
