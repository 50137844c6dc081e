"""The description of a (simulated) measurement rig, and its file ``config/rig.yaml``.

A rig is everything about the measurement that is not the bicycle: torsion and calibration
rods, wheel fixtures, hanging orientations, rate gyro, data acquisition, trial plan and the σ
of every static reading. ``format: bike_rig-rig/1``, SI units, degrees only in keys ending in
``_deg``; ``config/rig.yaml`` is the commented example, the keys are listed in
``docs/simulated-rig.md``, and each record below gives its fields' units. Numbers may also be
numeric strings (``1e-4``, which YAML 1.1 reads as a string).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..benchmark import MIN_ORIENTATION_SPREAD_DEG
from ..errors import short_repr
from ..io_yaml import load_yaml_document
from ..measurements import MIN_ORIENTATIONS
from .errors import RigFileError
from .plan import measurement_plan

__all__ = [
    "RIG_FORMAT",
    "Adc",
    "CalibrationRod",
    "CoupledSwing",
    "Gyro",
    "ReadingSigma",
    "RigConfig",
    "TrialPlan",
    "WheelFixture",
    "load_rig",
    "rig_from_document",
    "torsion_rod_stiffness",
]

RIG_FORMAT = "bike_rig-rig/1"


@dataclass(frozen=True)
class CalibrationRod:
    """The steel calibration rod of known inertia (paper Fig 9); true dimensions.

    Attributes:
        mass: kg.
        length: m.
        diameter: m.
    """

    mass: float
    length: float
    diameter: float


@dataclass(frozen=True)
class WheelFixture:
    """How a wheel is measured.

    Attributes:
        rotations: Whole rotations rolled for the radius (Eq 6).
        pendulum_arm: Rod/rim contact to the wheel centre when hung as a compound pendulum, m.
    """

    rotations: int
    pendulum_arm: float


@dataclass(frozen=True)
class Gyro:
    """The rate gyro (the paper's Silicon Sensing CRS03).

    Attributes:
        scale_factor: Nominal output per rate, V / (rad/s); used to convert back.
        scale_factor_tolerance: Relative 1σ of the true scale factor about the nominal one,
            drawn once per session (one gyro per session).
        zero_rate_output: Nominal output at zero rate, V.
        bias: 1σ of the turn-on rate bias, rad/s, drawn per trial.
        bias_drift: Random-walk density of the bias, (rad/s)/√s.
        noise_density: One-sided density of the white rate noise, (rad/s)/√Hz.
    """

    scale_factor: float
    scale_factor_tolerance: float
    zero_rate_output: float
    bias: float
    bias_drift: float
    noise_density: float

    def noise_sigma(self, sample_rate: float) -> float:
        """Standard deviation of the white noise per sample, rad/s: density × √(f_s / 2)."""
        return self.noise_density * math.sqrt(sample_rate / 2.0)


@dataclass(frozen=True)
class Adc:
    """The data acquisition (the paper's NI USB-6008, 12 bit, 1 kHz).

    Attributes:
        bits: Resolution, bit.
        low: Lower rail of the input range, V.
        high: Upper rail, V.
        sample_rate: Samples per second, Hz.
    """

    bits: int
    low: float
    high: float
    sample_rate: float

    @property
    def lsb(self) -> float:
        """One code step, V: (high − low) / 2^bits."""
        return (self.high - self.low) / 2**self.bits


@dataclass(frozen=True)
class TrialPlan:
    """How each period measurement is run.

    Attributes:
        per_measurement: Trials per period (the paper: three).
        durations: Trial duration, s; one value, or choices drawn uniformly per trial.
        amplitude_deg: Range (low, high) of the initial amplitude, degree, drawn uniformly.
        damping_ratio: ζ of every oscillation.
        dry_friction: Range (low, high) of the dry (Coulomb) friction at the pivot, as the
            swing lost per cycle over the initial swing, 1, drawn uniformly per trial; (0, 0)
            for none. A linear oscillator loses 4 μ / ω₀² per cycle, so the friction torque
            over the inertia is μ = fraction · θ₀ · ω₀² / 4, rad/s².
        finite_swing: Compound pendulums swing with a restoring torque ∝ sin θ (their period
            lengthens with the swing) rather than ∝ θ; torsional pendulums stay linear.
    """

    per_measurement: int
    durations: tuple[float, ...]
    amplitude_deg: tuple[float, float]
    damping_ratio: float
    dry_friction: tuple[float, float] = (0.0, 0.0)
    finite_swing: bool = False


@dataclass(frozen=True)
class CoupledSwing:
    """A second pendulum mode at a close frequency that exchanges energy (beating, Fig 7).

    Attributes:
        probability: Chance that a frame or fork torsional trial beats.
        trials: Trials that beat whatever the draw, by name (``frame_torsional_o2_t3``).
        detuning: Range of |f₂ / f₁ − 1|, drawn uniformly with a random sign.
        amplitude_ratio: Range of the second mode's initial amplitude over the first's (< 1,
            so that neither motion ever dies out completely).
    """

    probability: float
    trials: tuple[str, ...]
    detuning: tuple[float, float]
    amplitude_ratio: tuple[float, float]


@dataclass(frozen=True)
class ReadingSigma:
    """Standard deviation of each static reading; the noise drawn and the σ written.

    Attributes:
        gravity: m/s².
        wheelbase: m.
        head_tube_angle_deg: degree.
        fork_offset: m.
        distance_rolled: m.
        pendulum_arm: m.
        mass: kg (every part and the calibration rod).
        hanging_angle_deg: degree.
        string_distance: m.
        rod_length: m.
        rod_diameter: m.
        plate_height: m, the surface plate's heights h1…h7 (refined method; optional in the file).
        plate_diameter: m, its diameters d1…d6 (optional in the file).
        plate_distance: m, its distances d and l (optional in the file).
    """

    gravity: float
    wheelbase: float
    head_tube_angle_deg: float
    fork_offset: float
    distance_rolled: float
    pendulum_arm: float
    mass: float
    hanging_angle_deg: float
    string_distance: float
    rod_length: float
    rod_diameter: float
    plate_height: float = 8e-5
    plate_diameter: float = 4e-5
    plate_distance: float = 8e-5


#: Reading σ a rig file may leave out (the refined method's; defaults as RigidMeasured.txt's).
OPTIONAL_SIGMAS = ("plate_height", "plate_diameter", "plate_distance")


@dataclass(frozen=True)
class RigConfig:
    """A whole rig description (the file: ``config/rig.yaml``, ``docs/simulated-rig.md``).

    Attributes:
        name: Free text.
        stiffness: True torsion-rod stiffness k, N m/rad.
        calibration_rod: The calibration rod's true dimensions.
        rear_wheel: Rear wheel fixture.
        front_wheel: Front wheel fixture.
        frame_orientations_deg: True hanging angles of the frame's head tube, degree.
        fork_orientations_deg: True hanging angles of the fork's steer tube, degree.
        gyro: The rate gyro.
        adc: The data acquisition.
        trials: How the trials are run.
        coupled_swing: The beating mode, or None for none.
        sigma: Standard deviation of every static reading.
        source: The file it was read from.
    """

    name: str
    stiffness: float
    calibration_rod: CalibrationRod
    rear_wheel: WheelFixture
    front_wheel: WheelFixture
    frame_orientations_deg: tuple[float, ...]
    fork_orientations_deg: tuple[float, ...]
    gyro: Gyro
    adc: Adc
    trials: TrialPlan
    coupled_swing: CoupledSwing | None
    sigma: ReadingSigma
    source: str = "<memory>"


def torsion_rod_stiffness(diameter: float, length: float, shear_modulus: float) -> float:
    """Torsional stiffness of a solid round rod.

    Args:
        diameter: m.
        length: m.
        shear_modulus: G, Pa (mild steel ≈ 79 GPa).

    Returns:
        k = G J_p / L with J_p = π d⁴ / 32, N m/rad.
    """
    return shear_modulus * math.pi * diameter**4 / (32.0 * length)


Where = tuple[object, ...]

#: The largest magnitude of a number in a rig file (SI): above the largest a rig has (a shear
#: modulus, some 8e10 Pa), small enough that the simulation's products of a few cannot overflow.
MAX_RIG_MAGNITUDE = 1e12
#: The largest count in a rig file (trials per measurement, wheel rotations): a session of
#: 10,000 trials per measurement is already days of swinging; 1e23 held the reader 14 s and 394 MB.
MAX_RIG_COUNT = 10_000


def _label(where: Where) -> str:
    out = ""
    for part in where:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


class _Reader:
    """Line-aware accessors of a loaded rig document, raising :class:`RigFileError`."""

    def __init__(self, path: str, lines: Mapping[tuple[object, ...], int]):
        self.path, self.lines = path, lines

    def error(self, where: Where, reason: str) -> RigFileError:
        line = self.lines.get(where)
        probe = where
        while line is None and probe:
            probe = probe[:-1]
            line = self.lines.get(probe)
        return RigFileError(self.path, reason, key=_label(where) or None, line=line)

    def section(self, value: Any, where: Where, keys: Sequence[str], optional: Sequence[str] = ()) -> Mapping[str, Any]:
        """A mapping with exactly ``keys`` (and possibly ``optional``)."""
        if not isinstance(value, Mapping):
            raise self.error(where, f"expected a mapping of {', '.join(keys)}, got {short_repr(value)}")
        for key in value:
            if key not in keys and key not in optional:
                raise self.error(where + (key,), f"unknown key; expected one of {', '.join([*keys, *optional])}")
        for key in keys:
            if key not in value:
                raise self.error(where, f"missing key '{key}'")
        return value

    def number(self, value: Any, where: Where, *, low: float | None = None, strict: bool = True) -> float:
        """A finite number (YAML number or numeric string), optionally > low (or >= low)."""
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise self.error(where, f"expected a number, got {short_repr(value)}")
        try:
            x = float(value)
        except (ValueError, OverflowError):  # OverflowError: an integer beyond any float
            raise self.error(where, f"expected a number, got {short_repr(value)}") from None
        if not math.isfinite(x):
            raise self.error(where, f"must be finite, got {short_repr(value)}")
        if abs(x) > MAX_RIG_MAGNITUDE:
            raise self.error(where, f"{x:g} is beyond any rig (magnitude above {MAX_RIG_MAGNITUDE:g})")
        if low is not None and (x <= low if strict else x < low):
            raise self.error(where, f"must be {'>' if strict else '>='} {low:g}, got {x:g}")
        return x

    def flag(self, value: Any, where: Where) -> bool:
        """A YAML boolean (``true`` or ``false``)."""
        if not isinstance(value, bool):
            raise self.error(where, f"expected true or false, got {short_repr(value)}")
        return value

    def count(self, value: Any, where: Where, low: int = 1, high: int = MAX_RIG_COUNT) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.error(where, f"expected a whole number >= {low}, got {short_repr(value)}")
        if value > high:
            raise self.error(where, f"at most {high}, got {short_repr(value)}")
        return value

    def numbers(self, value: Any, where: Where, *, low: float | None = None, strict: bool = True) -> list[float]:
        if not isinstance(value, list) or not value:
            raise self.error(where, f"expected a non-empty list of numbers, got {short_repr(value)}")
        return [self.number(v, where + (i,), low=low, strict=strict) for i, v in enumerate(value)]

    def interval(
        self, value: Any, where: Where, *, low: float, high: float | None = None, strict: bool = True
    ) -> tuple[float, float]:
        """A range [a, b] with low < a <= b (low <= a when not strict), and b < high."""
        got = self.numbers(value, where, low=low, strict=strict)
        if len(got) != 2 or got[0] > got[1]:
            raise self.error(where, f"expected a range [low, high] with low <= high, got {short_repr(value)}")
        if high is not None and got[1] >= high:
            raise self.error(where, f"must stay below {high:g}, got {got[1]:g}")
        return got[0], got[1]


def _orientations(r: _Reader, value: Any, where: Where, name: str) -> tuple[float, ...]:
    angles = r.numbers(value, where)
    if len(angles) < MIN_ORIENTATIONS:
        raise r.error(where, f"{name}: {len(angles)} orientation(s), at least {MIN_ORIENTATIONS} are needed (Eq 35)")
    for i, a in enumerate(angles):
        for j in range(i):
            d = (a - angles[j]) % 180.0
            if min(d, 180.0 - d) < MIN_ORIENTATION_SPREAD_DEG:
                raise r.error(
                    where + (i,),
                    f"{name} orientations {j + 1} and {i + 1} hang along parallel lines ({min(d, 180.0 - d):.3g}° "
                    "apart modulo 180°); they cannot locate the mass centre (Eq 17) or the tensor (Eq 35)",
                )
    return tuple(angles)


def _stiffness(r: _Reader, rod: Any) -> float:
    """The torsion rod's stiffness [N m/rad]: given, or from its diameter, length and shear modulus."""
    if isinstance(rod, Mapping) and "stiffness" in rod:
        r.section(rod, ("torsion_rod",), ("stiffness",))
        return r.number(rod["stiffness"], ("torsion_rod", "stiffness"), low=0.0)
    geo = r.section(rod, ("torsion_rod",), ("diameter", "length", "shear_modulus"))
    return torsion_rod_stiffness(
        r.number(geo["diameter"], ("torsion_rod", "diameter"), low=0.0),
        r.number(geo["length"], ("torsion_rod", "length"), low=0.0),
        r.number(geo["shear_modulus"], ("torsion_rod", "shear_modulus"), low=0.0),
    )


def _calibration_rod(r: _Reader, value: Any) -> CalibrationRod:
    """The ``calibration_rod`` section: mass [kg], length [m], diameter [m]."""
    cal = r.section(value, ("calibration_rod",), ("mass", "length", "diameter"))
    return CalibrationRod(
        mass=r.number(cal["mass"], ("calibration_rod", "mass"), low=0.0),
        length=r.number(cal["length"], ("calibration_rod", "length"), low=0.0),
        diameter=r.number(cal["diameter"], ("calibration_rod", "diameter"), low=0.0),
    )


def _wheel_fixtures(r: _Reader, value: Any) -> list[WheelFixture]:
    """The ``wheels`` section: the rear, then the front wheel's fixture (rotations, pendulum arm [m])."""
    wheels = r.section(value, ("wheels",), ("rear", "front"))
    fixtures = []
    for name in ("rear", "front"):
        sec = r.section(wheels[name], ("wheels", name), ("rotations", "pendulum_arm"))
        rotations = r.count(sec["rotations"], ("wheels", name, "rotations"))
        arm = r.number(sec["pendulum_arm"], ("wheels", name, "pendulum_arm"), low=0.0)
        fixtures.append(WheelFixture(rotations, arm))
    return fixtures


def _gyro(r: _Reader, value: Any) -> Gyro:
    """The ``gyro`` section (:class:`Gyro`'s fields, in its units)."""
    gkeys = ("scale_factor", "scale_factor_tolerance", "zero_rate_output", "bias", "bias_drift", "noise_density")
    g = r.section(value, ("gyro",), gkeys)
    return Gyro(
        scale_factor=r.number(g["scale_factor"], ("gyro", "scale_factor"), low=0.0),
        zero_rate_output=r.number(g["zero_rate_output"], ("gyro", "zero_rate_output")),
        **{
            k: r.number(g[k], ("gyro", k), low=0.0, strict=False)
            for k in gkeys
            if k not in ("scale_factor", "zero_rate_output")
        },
    )


def _adc(r: _Reader, value: Any, gyro: Gyro) -> Adc:
    """The ``adc`` section: bits (at most 32), range [V], sample rate [Hz]; the gyro's zero must lie inside."""
    a = r.section(value, ("adc",), ("bits", "range", "sample_rate"))
    bits = r.count(a["bits"], ("adc", "bits"))
    if bits > 32:
        raise r.error(("adc", "bits"), f"at most 32 bits, got {bits}")
    rails = r.numbers(a["range"], ("adc", "range"))
    if len(rails) != 2 or rails[0] >= rails[1]:
        raise r.error(("adc", "range"), f"expected [low, high] volts with low < high, got {short_repr(a['range'])}")
    adc = Adc(bits, rails[0], rails[1], r.number(a["sample_rate"], ("adc", "sample_rate"), low=0.0))
    if not adc.low < gyro.zero_rate_output < adc.high:
        raise r.error(
            ("gyro", "zero_rate_output"),
            f"{gyro.zero_rate_output:g} V lies outside the ADC range [{adc.low:g}, {adc.high:g}] V: "
            "every sample would clip",
        )
    return adc


def _trial_plan(r: _Reader, value: Any) -> TrialPlan:
    """The ``trials`` section.

    Trials per measurement, duration(s) [s], amplitude [deg], damping ratio (< 1), and the
    optional dry friction (a range, or one number, of the swing lost per cycle over the initial
    swing, in [0, 1)) and finite swing (a bool).
    """
    t = r.section(
        value,
        ("trials",),
        ("per_measurement", "duration", "amplitude_deg", "damping_ratio"),
        ("dry_friction", "finite_swing"),
    )
    dur = t["duration"]
    durations = r.numbers(dur if isinstance(dur, list) else [dur], ("trials", "duration"), low=0.0)
    damping = r.number(t["damping_ratio"], ("trials", "damping_ratio"), low=0.0, strict=False)
    if damping >= 1.0:
        raise r.error(("trials", "damping_ratio"), f"an oscillation needs a damping ratio below 1, got {damping:g}")
    return TrialPlan(
        per_measurement=r.count(t["per_measurement"], ("trials", "per_measurement")),
        durations=tuple(durations),
        amplitude_deg=r.interval(t["amplitude_deg"], ("trials", "amplitude_deg"), low=0.0, high=90.0),
        damping_ratio=damping,
        dry_friction=_dry_friction(r, t.get("dry_friction", [0.0, 0.0])),
        finite_swing=r.flag(t.get("finite_swing", False), ("trials", "finite_swing")),
    )


def _dry_friction(r: _Reader, value: Any) -> tuple[float, float]:
    """``trials.dry_friction``: a range [low, high] (or one number) of fractions in [0, 1)."""
    where = ("trials", "dry_friction")
    if not isinstance(value, list):
        x = r.number(value, where, low=0.0, strict=False)  # named without an index
        value = [x, x]
    return r.interval(value, where, low=0.0, high=1.0, strict=False)


def _coupled_swing(
    r: _Reader, value: Any, frame: tuple[float, ...], fork: tuple[float, ...], per_measurement: int
) -> CoupledSwing:
    """The ``coupled_swing`` section; the trials it names must be trials of this rig's session."""
    w = ("coupled_swing",)
    c = r.section(value, w, ("detuning", "amplitude_ratio"), ("probability", "trials"))
    p = r.number(c.get("probability", 0.0), w + ("probability",), low=0.0, strict=False)
    if p > 1.0:
        raise r.error(w + ("probability",), f"a probability is at most 1, got {p:g}")
    names = c.get("trials", []) or []
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise r.error(w + ("trials",), "expected a list of trial names, e.g. [frame_torsional_o2_t3]")
    plan = measurement_plan(len(frame), len(fork))
    known = {m.trial_name(i + 1) for m in plan for i in range(per_measurement)}
    for i, n in enumerate(names):
        if n not in known:
            example = plan[-1].trial_name(1)
            raise r.error(w + ("trials", i), f"no such trial '{n}' in this rig's session (e.g. {example})")
    return CoupledSwing(
        probability=p,
        trials=tuple(names),
        detuning=r.interval(c["detuning"], w + ("detuning",), low=0.0, high=1.0),
        amplitude_ratio=r.interval(c["amplitude_ratio"], w + ("amplitude_ratio",), low=0.0, high=1.0),
    )


def rig_from_document(path: str, data: Any, lines: Mapping[tuple[object, ...], int]) -> RigConfig:
    """Build a :class:`RigConfig` from a loaded ``bike_rig-rig/1`` document.

    Raises:
        RigFileError: a key is missing, unknown, malformed or impossible (with its line).
    """
    r = _Reader(path, lines)
    sections = (
        "format",
        "torsion_rod",
        "calibration_rod",
        "wheels",
        "orientations_deg",
        "gyro",
        "adc",
        "trials",
        "reading_sigma",
    )
    if not isinstance(data, Mapping):
        raise r.error((), "expected a YAML mapping at the top level")
    top = r.section(data, (), sections, ("name", "coupled_swing"))
    if top["format"] != RIG_FORMAT:
        raise r.error(("format",), f"expected '{RIG_FORMAT}', got {short_repr(top['format'])}")

    stiffness = _stiffness(r, top["torsion_rod"])
    calibration = _calibration_rod(r, top["calibration_rod"])
    fixtures = _wheel_fixtures(r, top["wheels"])

    ori = r.section(top["orientations_deg"], ("orientations_deg",), ("frame", "fork"))
    frame = _orientations(r, ori["frame"], ("orientations_deg", "frame"), "frame")
    fork = _orientations(r, ori["fork"], ("orientations_deg", "fork"), "fork")

    gyro = _gyro(r, top["gyro"])
    adc = _adc(r, top["adc"], gyro)
    trials = _trial_plan(r, top["trials"])

    swing = None
    if top.get("coupled_swing") is not None:
        swing = _coupled_swing(r, top["coupled_swing"], frame, fork, trials.per_measurement)

    skeys = tuple(k for k in ReadingSigma.__dataclass_fields__ if k not in OPTIONAL_SIGMAS)
    s = r.section(top["reading_sigma"], ("reading_sigma",), skeys, OPTIONAL_SIGMAS)
    sigma = ReadingSigma(**{k: r.number(s[k], ("reading_sigma", k), low=0.0, strict=False) for k in s})

    name = top.get("name", Path(path).stem)
    return RigConfig(
        name=str(name),
        stiffness=stiffness,
        calibration_rod=calibration,
        rear_wheel=fixtures[0],
        front_wheel=fixtures[1],
        frame_orientations_deg=frame,
        fork_orientations_deg=fork,
        gyro=gyro,
        adc=adc,
        trials=trials,
        coupled_swing=swing,
        sigma=sigma,
        source=path,
    )


def load_rig(path: str | Path) -> RigConfig:
    """Read a rig description (``format: bike_rig-rig/1``).

    Raises:
        RigFileError: the file is missing or invalid, naming the key and line.
    """
    p = str(path)
    if not Path(path).is_file():
        raise RigFileError(p, "no such file" if not Path(path).exists() else "not a regular file")
    data, lines = load_yaml_document(path)
    return rig_from_document(p, data, lines)
