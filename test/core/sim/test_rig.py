"""The rig description file: the shipped rig, and every bad rig file's one-line error."""

from __future__ import annotations

import math
import tracemalloc
from pathlib import Path

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.errors import InputFileError
from bike_rig.core.sim.errors import RigFileError
from bike_rig.core.sim.rig import RigConfig, load_rig, torsion_rod_stiffness

SHIPPED = config_file("rig.yaml")


def test_shipped_rig_is_the_papers(rig: RigConfig) -> None:
    assert rig.stiffness == 5.62
    assert (rig.calibration_rod.mass, rig.calibration_rod.length, rig.calibration_rod.diameter) == (5.56, 1.05, 0.03)
    assert rig.adc.bits == 12 and rig.adc.sample_rate == 1000.0
    assert rig.adc.lsb == pytest.approx(10.0 / 4096)
    assert rig.trials.per_measurement == 3 and rig.trials.durations == (30.0,)
    assert rig.frame_orientations_deg == (3.4, 138.7, 229.8)
    assert rig.coupled_swing is not None and rig.coupled_swing.probability == 0.05
    assert rig.sigma.hanging_angle_deg == 0.2 and rig.sigma.string_distance == 0.003
    assert rig.gyro.noise_sigma(1000.0) == pytest.approx(1e-4 * math.sqrt(500.0))
    assert rig.trials.dry_friction == (0.0, 0.0) and rig.trials.finite_swing is False


def _write(tmp_path: Path, old: str, new: str) -> tuple[Path, int]:
    """The shipped rig with ``old`` replaced by ``new``; returns the file and the changed line."""
    text = SHIPPED.read_text(encoding="utf-8")
    assert text.count(old) == 1, old
    line = text[: text.index(old)].count("\n") + 1
    path = tmp_path / "rig.yaml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path, line


def test_torsion_rod_from_its_geometry(tmp_path: Path) -> None:
    path, _ = _write(tmp_path, "stiffness: 5.62", "{diameter: 0.005, length: 1.0, shear_modulus: 7.93e+10}\n  #")
    rig = load_rig(path)
    assert rig.stiffness == pytest.approx(7.93e10 * math.pi * 0.005**4 / 32.0)
    assert rig.stiffness == torsion_rod_stiffness(0.005, 1.0, 7.93e10)


def test_numbers_may_be_numeric_strings(tmp_path: Path) -> None:
    path, _ = _write(tmp_path, "bias_drift: 1.0e-4", "bias_drift: 1e-4")  # YAML 1.1 reads a string
    assert load_rig(path).gyro.bias_drift == 1e-4


def test_durations_may_be_a_list_of_choices(tmp_path: Path) -> None:
    path, _ = _write(tmp_path, "duration: 30 ", "duration: [15, 30] ")
    assert load_rig(path).trials.durations == (15.0, 30.0)


def test_dry_friction_and_finite_swing_are_optional_and_off_by_default(tmp_path: Path, rig: RigConfig) -> None:
    text = SHIPPED.read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    kept = [line for line in lines if "dry_friction" not in line and "finite_swing" not in line]
    kept = [line for line in kept if not (line.startswith(" ") and line.lstrip().startswith("#"))]  # their comments
    path = tmp_path / "rig.yaml"
    path.write_text("".join(kept), encoding="utf-8")
    assert "dry_friction" not in path.read_text(encoding="utf-8")
    absent = load_rig(path)
    assert absent.trials == rig.trials
    assert absent.trials.dry_friction == (0.0, 0.0) and absent.trials.finite_swing is False


@pytest.mark.parametrize(
    ("friction", "swing", "want"),
    [
        ("[0.01, 0.03]", "true", ((0.01, 0.03), True)),
        ("0.02", "false", ((0.02, 0.02), False)),  # one number: that fraction in every trial
        ("['1e-3', 0.5]", "yes", ((1e-3, 0.5), True)),  # numeric strings; YAML 1.1's yes
        ("[0, 0.999]", "false", ((0.0, 0.999), False)),
    ],
)
def test_dry_friction_and_finite_swing(
    tmp_path: Path, friction: str, swing: str, want: tuple[tuple[float, float], bool]
) -> None:
    path, _ = _write(tmp_path, "dry_friction: [0.0, 0.0]", f"dry_friction: {friction}")
    path.write_text(path.read_text(encoding="utf-8").replace("finite_swing: false", f"finite_swing: {swing}"))
    plan = load_rig(path).trials
    assert (plan.dry_friction, plan.finite_swing) == want


def test_coupled_swing_is_optional(tmp_path: Path) -> None:
    path, _ = _write(tmp_path, "coupled_swing:  ", "coupled_swing_unused:  ")
    text = path.read_text(encoding="utf-8")
    start = text.index("coupled_swing_unused")
    end = text.index("reading_sigma:")
    path.write_text(text[:start] + text[end:], encoding="utf-8")
    assert load_rig(path).coupled_swing is None


BAD = [
    # (replace, by: the key and the reason the error must name, on the replaced line)
    ("format: bike_rig-rig/1", "format: bike_rig-rig/9", "format", "expected 'bike_rig-rig/1'"),
    ("stiffness: 5.62", "stiffness: -1", "torsion_rod.stiffness", "must be > 0"),
    ("stiffness: 5.62", "stiffness: stiff", "torsion_rod.stiffness", "expected a number"),
    ("frame: [3.4, 138.7, 229.8]", "frame: [3.4, 138.7]", "orientations_deg.frame", "at least 3"),
    ("frame: [3.4, 138.7, 229.8]", "frame: [3.4, 138.7, 318.8]", "orientations_deg.frame[2]", "parallel"),
    ("bits: 12", "bits: twelve", "adc.bits", "whole number"),
    ("range: [-5.0, 5.0]", "range: [5.0, -5.0]", "adc.range", "low < high"),
    ("zero_rate_output: 2.5", "zero_rate_output: 7.5", "gyro.zero_rate_output", "outside the ADC range"),
    ("damping_ratio: 0.001", "damping_ratio: 1.5", "trials.damping_ratio", "below 1"),
    ("amplitude_deg: [0.2, 0.9]", "amplitude_deg: [0.9, 0.2]", "trials.amplitude_deg", "low <= high"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: [0.03, 0.01]", "trials.dry_friction", "low <= high"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: [0.0, 1.0]", "trials.dry_friction", "must stay below 1, got 1"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: 1.5", "trials.dry_friction", "must stay below 1, got 1.5"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: -0.1", "trials.dry_friction", "must be >= 0, got -0.1"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: [-0.1, 0.1]", "trials.dry_friction[0]", "must be >= 0, got -0.1"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: [0.0, 0.1, 0.2]", "trials.dry_friction", "[low, high]"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: lots", "trials.dry_friction", "expected a number"),
    ("dry_friction: [0.0, 0.0]", "dry_friction: []", "trials.dry_friction", "non-empty list"),
    ("finite_swing: false", "finite_swing: 1", "trials.finite_swing", "expected true or false, got 1"),
    ("finite_swing: false", "finite_swing: 'true'", "trials.finite_swing", "expected true or false"),
    ("finite_swing: false", "finite_swingy: false", "trials.finite_swingy", "unknown key"),
    ("probability: 0.05", "probability: 1.5", "coupled_swing.probability", "at most 1"),
    ("trials: []", "trials: [frame_torsional_o4_t1]", "coupled_swing.trials[0]", "no such trial"),
    ("noise_density: 1.0e-4", "noise_density: 1.0e-4\n  colour: red", "gyro.colour", "unknown key"),
    ("rear: {rotations: 13,", "rear: {rotations: 13.5,", "wheels.rear.rotations", "whole number"),
    ("pendulum_arm: 0.293}", "pendulum_arm: [0.293]}", "wheels.front.pendulum_arm", "expected a number"),
]


@pytest.mark.parametrize(("old", "new", "key", "reason"), BAD, ids=[b[2] + ":" + b[3] for b in BAD])
def test_bad_rig_file_names_file_line_key_and_reason(tmp_path: Path, old: str, new: str, key: str, reason: str) -> None:
    path, line = _write(tmp_path, old, new)
    if key == "gyro.colour":
        line += 1
    with pytest.raises(RigFileError) as err:
        load_rig(path)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"{path}:{line}: key '{key}': "), message
    assert reason in message


def test_missing_key_points_at_its_section(tmp_path: Path) -> None:
    path, _ = _write(tmp_path, "  mass: 0.02                    # kg (Molen scale, 7)\n", "")
    section = next(
        i for i, t in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if t.startswith("reading_")
    )
    with pytest.raises(RigFileError, match=r":(\d+): key 'reading_sigma': missing key 'mass'$") as err:
        load_rig(path)
    # the section's line, or its first entry's (where the YAML node of the section starts)
    assert err.value.line in (section, section + 1)


def test_unreadable_rig_files(tmp_path: Path) -> None:
    with pytest.raises(RigFileError, match="no such file"):
        load_rig(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-rig/1\ngyro: [1, 2\n", encoding="utf-8")
    with pytest.raises(InputFileError, match=r"bad\.yaml:\d+: invalid YAML"):
        load_rig(bad)
    bad.write_text("- 1\n- 2\n", encoding="utf-8")
    with pytest.raises(RigFileError, match="mapping"):
        load_rig(bad)


def test_absurd_magnitudes_are_refused(tmp_path: Path) -> None:
    """A calibration rod of 1e300 kg was simulated without a word (exit 0)."""
    text = config_file("rig.yaml").read_text()
    assert "mass: 5.56" in text
    path = tmp_path / "rig.yaml"
    path.write_text(text.replace("mass: 5.56", "mass: 1.0e+300"))
    with pytest.raises(RigFileError, match=r"calibration_rod.mass': 1e\+300 is beyond any rig"):
        load_rig(path)


def test_an_integer_too_long_to_write_is_refused_in_one_line(tmp_path: Path) -> None:
    """A 4,000-hex-digit count made the error message itself raise ValueError (repr of the integer)."""
    text = config_file("rig.yaml").read_text()
    assert "per_measurement: 3" in text
    path = tmp_path / "rig.yaml"
    path.write_text(text.replace("per_measurement: 3", "per_measurement: -0x" + "f" * 4000))
    with pytest.raises(RigFileError, match="got an integer of about 4817 digits"):
        load_rig(path)


def test_an_absurd_count_is_refused_at_once(tmp_path: Path) -> None:
    """per_measurement: 99999999999999999999999 held the reader 14 s and 394 MB (fuzzing, seed 7, rig#126)."""
    text = config_file("rig.yaml").read_text()
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    tracemalloc.start()
    try:
        load_rig(path)
        shipped = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        path.write_text(text.replace("per_measurement: 3", "per_measurement: 99999999999999999999999"))
        with pytest.raises(RigFileError, match="trials.per_measurement': at most 10000, got 9999999999999999999"):
            load_rig(path)
        refused = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Refused before anything is built per trial: about the memory of reading the shipped file (3 trials a period,
    # about 1 MB; the refusal's traceback adds a few kB). The trial names of 10,000 trials a period alone take
    # 13 MB, so twice the shipped file's peak is far below anything built for the absurd count.
    assert refused < 2 * shipped, f"refusing took {refused} bytes at its peak, reading the shipped file {shipped}"
