"""A Yeadon rider (issue 13, section 2): BicycleParameters' combined parameters, the pose, σ, errors.

Every ``riders/<Rider>/Parameters/<Rider><Bike>Benchmark.txt`` under the shared data (what
BicycleParameters 1.5.2 computes for ``Bicycle(<Bike>).add_rider(<Rider>)``, BSD-2-Clause,
(c) 2011-2025 BicycleParameters Authors) is checked: values to 1e-6 relative, and σ to 1e-3 with
the rider's own σ set to zero and the pose exact (``pose_sigma: false``): BicycleParameters
carries neither.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from bike_rig.core import rider_yeadon
from bike_rig.core.benchmark import PARAMETER_NAMES, ParameterSet, compute_parameters
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from bike_rig.core.rider import Rider, RiderError, add_rider, resolve_rider
from bike_rig.core.rider_pose import RiderPoseError
from bike_rig.core.rider_yeadon import RIDER_GEOMETRY_KEYS, YeadonRider, seat_rider, seated_pose
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.core.uncertainty.uncertain import UncertainVector
from test.support.paper import shared_dir

BP = shared_dir() / "data" / "bicycleparameters"
REAR_FRAME = ("mB", "xB", "zB", "IBxx", "IByy", "IBzz", "IBxz")
#: A rider file's lines that make the rider exact, as BicycleParameters takes it.
EXACT = "measurement_sigma: 0\nmass_sigma: 0\npose_sigma: false\n"


def _cases() -> list[tuple[str, str]]:
    """(rider, bicycle) of every combined parameter file that has its raw inputs."""
    out = []
    for f in sorted(BP.glob("riders/*/Parameters/*Benchmark.txt")):
        rider = f.parent.parent.name
        bike = f.name[len(rider) : -len("Benchmark.txt")]
        if (BP / bike / "RawData" / f"{bike}Measured.txt").is_file():
            out.append((rider, bike))
    return out


CASES = _cases()


def _write_rider(tmp_path: Path, rider: str, bike: str, extra: str = "", cfg: Path | None = None) -> Path:
    raw = BP / "riders" / rider / "RawData"
    path = tmp_path / f"{rider}{bike}.yaml"
    cfg = cfg or raw / f"{rider}{bike}YeadonCFG.txt"
    path.write_text(
        f"name: {rider}\nyeadon_measurements: {raw / f'{rider}YeadonMeas.txt'}\nyeadon_configuration: {cfg}\n{extra}",
        encoding="utf-8",
    )
    return path


def _bike(bike: str) -> ParameterSet:
    return compute_parameters(read_bp_measured(BP / bike / "RawData" / f"{bike}Measured.txt"))


def _yeadon(path: Path) -> YeadonRider:
    r = resolve_rider(path)
    assert isinstance(r, YeadonRider)
    return r


def test_there_is_a_case() -> None:
    assert ("Jason", "Browser") in CASES


@pytest.mark.parametrize(("rider", "bike"), CASES)
def test_combined_parameters_equal_bicycleparameters(tmp_path: Path, rider: str, bike: str) -> None:
    r = _yeadon(_write_rider(tmp_path, rider, bike, EXACT))
    ours = add_rider(_bike(bike), r).parameters
    ref = read_bp_parameters(BP / "riders" / rider / "Parameters" / f"{rider}{bike}Benchmark.txt").parameters
    for name in PARAMETER_NAMES:
        assert ours.value(name) == pytest.approx(ref.value(name), rel=1e-6, abs=1e-12), name
        assert ours.sigma(name) == pytest.approx(ref.sigma(name), rel=1e-3, abs=1e-15), name


def _seatable() -> list[str]:
    """Every shared bicycle whose raw file has the rider-geometry keys."""
    out = []
    for f in sorted(BP.glob("*/RawData/*Measured.txt")):
        extras = read_bp_measured(f).extras
        if all(k in extras for k in RIDER_GEOMETRY_KEYS) and "w" in read_bp_measured(f).readings:
            out.append(f.parent.parent.name)
    return out


@pytest.mark.parametrize("bike", _seatable())
def test_on_every_bicycle_hands_on_the_grips_or_a_clear_error(tmp_path: Path, bike: str) -> None:
    """Jason in his Browser pose on every bicycle: seated with hands and heels in place, or refused by name."""
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser"))
    error: RiderPoseError | None = None
    try:
        seated_pose(r, _bike(bike))
    except RiderPoseError as exc:
        error = exc
    if error is None:
        _check_hands_and_feet(r, bike)
    else:
        assert re.search(r"cannot reach the (grip|bottom bracket): it is \d\.\d+ m from the", str(error)), str(error)
        assert f"{bike}Measured.txt" in str(error)


@pytest.mark.parametrize(("rider", "bike"), CASES)
def test_hands_on_the_grips_and_feet_on_the_bottom_bracket(tmp_path: Path, rider: str, bike: str) -> None:
    _check_hands_and_feet(_yeadon(_write_rider(tmp_path, rider, bike)), bike)


def _check_hands_and_feet(r: YeadonRider, bike: str) -> None:
    """Checked against the raw keys' own definitions, not against the solver's targets."""
    ps = _bike(bike)
    pose = seated_pose(r, ps)
    raw = read_bp_measured(BP / bike / "RawData" / f"{bike}Measured.txt").extras
    g = {k: float(str(raw[k])) for k in RIDER_GEOMETRY_KEYS}
    p = ps.values()
    rear, front = np.array([0.0, 0.0, -p["rR"]]), np.array([p["w"], 0.0, -p["rF"]])
    for side, y in (("left", -g["whb"] / 2), ("right", g["whb"] / 2)):
        hand = pose.end_point(f"{side} arm")
        assert hand[1] == pytest.approx(y, abs=1e-8)
        assert np.linalg.norm(hand - rear) == pytest.approx(g["LhbR"], abs=1e-8)
        assert np.linalg.norm(hand - front) == pytest.approx(g["LhbF"], abs=1e-8)
        assert hand[2] < -p["rR"]  # above the axles
        heel = pose.end_point(f"{side} leg")
        assert heel[2] == pytest.approx(-g["hbb"], abs=1e-8)
        assert math.hypot(heel[0], heel[2] + p["rR"]) == pytest.approx(g["lcs"], abs=1e-8)
        assert heel[0] > 0
    # The pose is the natural one: knees and elbows bend forward.
    assert pose.angles["J1J2flexion"] > 0 and pose.angles["A1A2extension"] < 0


def _browser_copy(tmp_path: Path, **keys: float) -> ParameterSet:
    lines = (BP / "Browser" / "RawData" / "BrowserMeasured.txt").read_text(encoding="utf-8").splitlines()
    out = [
        f"{ln.split('=')[0].strip()} = {keys[ln.split('=')[0].strip()]}" if ln.split("=")[0].strip() in keys else ln
        for ln in lines
    ]
    path = tmp_path / "BrowserMeasured.txt"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return compute_parameters(read_bp_measured(path))


def test_handlebar_out_of_reach_is_a_clear_error(tmp_path: Path) -> None:
    ps = _browser_copy(tmp_path, LhbR=1.30, LhbF=0.70)
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser"))
    with pytest.raises(RiderPoseError, match=r"left arm cannot reach the grip.*LhbF.*LhbR = 1\.3\b"):
        add_rider(ps, r)


def test_bicycleparameters_issue_19_lean_is_a_clear_error(tmp_path: Path) -> None:
    """The measured lean (somersault 0.1239 rad) of Jason on the Browser leaves his hands short of the grips."""
    cfg = tmp_path / "cfg.txt"
    src = BP / "riders" / "Jason" / "RawData" / "JasonBrowserYeadonCFG.txt"
    cfg.write_text(src.read_text(encoding="utf-8").replace("somersault: 0.175", "somersault: 0.123918377"))
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser", cfg=cfg))
    with pytest.raises(RiderPoseError, match=r"cannot reach the grip: it is 0\.6\d\d m from the shoulder") as info:
        add_rider(_bike("Browser"), r)
    # the message names the least lean at which straight arms reach; seated at it, the hands are on the grips
    found = re.search(r"reach it from a lean of somersault = (0\.\d+) rad \(the file's: 0\.123918\)", str(info.value))
    assert found is not None
    lean = float(found.group(1))
    assert 0.124 < lean < 0.175  # more than the measured lean, less than the shipped configuration's
    leaned = YeadonRider(r.name, r.measurements, {**r.configuration, "somersault": lean + 1e-4})
    pose = seated_pose(leaned, _bike("Browser"))
    assert pose.angles["A1A2extension"] > -0.1  # the elbows nearly straight
    too_upright = YeadonRider(r.name, r.measurements, {**r.configuration, "somersault": lean - 1e-3})
    with pytest.raises(RiderPoseError, match="cannot reach the grip"):
        seated_pose(too_upright, _bike("Browser"))


def test_grips_that_cannot_exist_are_a_clear_error(tmp_path: Path) -> None:
    ps = _browser_copy(tmp_path, LhbR=0.4, LhbF=0.4)
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser"))
    with pytest.raises(RiderPoseError, match="no grip position"):
        add_rider(ps, r)


def test_parameter_file_needs_the_rider_geometry(tmp_path: Path) -> None:
    ps = read_bp_parameters(BP / "Browser" / "Parameters" / "BrowserBenchmark.txt")
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser", "mass_sigma: 0\nmeasurement_sigma: 0\n"))
    with pytest.raises(
        RiderError, match="needs the bicycle's rider-geometry keys lst, lsp, lamst, hbb, lcs, whb, LhbR"
    ):
        add_rider(ps, r)
    # The rider file may give them.
    raw = read_bp_measured(BP / "Browser" / "RawData" / "BrowserMeasured.txt").extras
    geometry = "bicycle_geometry:\n" + "".join(f"  {k}: {raw[k]}\n" for k in RIDER_GEOMETRY_KEYS)
    r2 = _yeadon(_write_rider(tmp_path, "Jason", "Browser", "mass_sigma: 0\nmeasurement_sigma: 0\n" + geometry))
    want = add_rider(_bike("Browser"), r2).parameters
    got = add_rider(ps, r2).parameters
    for name in REAR_FRAME:
        assert got.value(name) == pytest.approx(want.value(name), rel=1e-9), name


@pytest.fixture(scope="module")
def jason_default(tmp_path_factory: pytest.TempPathFactory) -> tuple[YeadonRider, Rider]:
    r = _yeadon(_write_rider(tmp_path_factory.mktemp("jason"), "Jason", "Browser"))
    return r, seat_rider(r, _bike("Browser"))


def test_rider_sigma_widens_only_the_rear_frame_and_the_speeds(tmp_path: Path, jason_default: tuple) -> None:
    r, seated = jason_default
    assert r.measurement_sigma == 0.005 and r.mass_sigma == 0.5
    ps = _bike("Browser")
    exact = add_rider(ps, _yeadon(_write_rider(tmp_path, "Jason", "Browser", "measurement_sigma: 0\nmass_sigma: 0\n")))
    # (both follow the pose's dependence on w, rR, rF: only the body measurements differ)
    with_sigma = add_rider(ps, seated)
    for name in PARAMETER_NAMES:
        a, b = with_sigma.parameters.sigma(name), exact.parameters.sigma(name)
        if name in REAR_FRAME:
            assert a > b, name
        else:
            assert a == pytest.approx(b, rel=1e-12, abs=1e-15), name
    assert with_sigma.parameters.sigma("mB") == pytest.approx(math.hypot(0.02, 0.5), rel=1e-9)
    # The link to the raw readings carries the rider's measurements too (the budget sees them).
    assert (
        with_sigma.raw is not None
        and "rider Ls1L" in with_sigma.raw.names
        and "rider totalmass" in with_sigma.raw.names
    )
    j = with_sigma.raw.jacobian
    assert np.allclose(j @ with_sigma.raw.covariance @ j.T, with_sigma.parameters.covariance, rtol=1e-9, atol=1e-18)
    wide, narrow = critical_speeds_with_sigma(with_sigma), critical_speeds_with_sigma(exact)
    assert wide.weave is not None and narrow.weave is not None
    assert wide.weave.speed == narrow.weave.speed and wide.weave.sigma > narrow.weave.sigma > 0


def test_pose_follows_the_bicycle(tmp_path: Path) -> None:
    """The rider's dependence on w, rR, rF equals re-seating on a changed bicycle, and widens the rear frame's σ."""
    ps = _bike("Browser")
    follows = _yeadon(_write_rider(tmp_path, "Jason", "Browser", "measurement_sigma: 0\nmass_sigma: 0\n"))
    seated = seat_rider(follows, ps)
    sens = seated.sensitivity
    assert sens is not None and sens.names == () and sens.bicycle == ("rR", "rF", "w")
    exact = _yeadon(_write_rider(tmp_path, "Jason", "Browser", EXACT))
    h = 1e-5
    for k, name in enumerate(sens.bicycle):
        moved = []
        for sign in (1, -1):
            values = ps.parameters.values.copy()
            values[PARAMETER_NAMES.index(name)] += sign * h
            changed = dataclasses.replace(
                ps, parameters=UncertainVector(PARAMETER_NAMES, values, ps.parameters.covariance)
            )
            s = seat_rider(exact, changed)
            moved.append(np.array([s.mass, s.x, s.z, s.Ixx, s.Iyy, s.Izz, s.Ixz]))
        assert np.allclose(sens.bicycle_jacobian[:, k], (moved[0] - moved[1]) / (2 * h), rtol=1e-4, atol=1e-6), name
    wide, narrow = add_rider(ps, seated), add_rider(ps, exact)
    assert np.array_equal(wide.parameters.values, narrow.parameters.values)
    for name in PARAMETER_NAMES:
        a, b = wide.parameters.sigma(name), narrow.parameters.sigma(name)
        assert (a > b * 1.01) if name in ("xB", "zB", "IBxx", "IByy", "IBzz", "IBxz") else a == pytest.approx(b), name


def test_a_rider_is_seated_once_for_parameter_sets_that_differ_beyond_w_rr_rf(jason_default: tuple) -> None:
    """A live session's parameter sets change the inertia, not the pose: the seated rider is reused, and is exact."""
    r, seated = jason_default
    ps = _bike("Browser")
    values = ps.parameters.values.copy()
    values[PARAMETER_NAMES.index("IBxx")] *= 1.01
    values[PARAMETER_NAMES.index("mF")] += 0.1
    heavier = dataclasses.replace(ps, parameters=UncertainVector(PARAMETER_NAMES, values, ps.parameters.covariance))
    assert seat_rider(r, heavier) is seated
    saved = dict(rider_yeadon._SEATED)
    rider_yeadon._SEATED.clear()
    try:
        fresh = seat_rider(r, heavier)
    finally:
        rider_yeadon._SEATED.update(saved)
    numbers = ("mass", "x", "z", "Ixx", "Iyy", "Izz", "Ixz")
    assert fresh is not seated and [getattr(fresh, k) for k in numbers] == [getattr(seated, k) for k in numbers]
    assert fresh.sensitivity is not None and seated.sensitivity is not None
    assert np.array_equal(fresh.sensitivity.jacobian, seated.sensitivity.jacobian)
    assert np.array_equal(fresh.sensitivity.bicycle_jacobian, seated.sensitivity.bicycle_jacobian)
    values[PARAMETER_NAMES.index("w")] -= 0.005
    longer = dataclasses.replace(ps, parameters=UncertainVector(PARAMETER_NAMES, values, ps.parameters.covariance))
    assert seat_rider(r, longer).x != seated.x


@pytest.mark.parametrize("key", ["La4L", "Ls4L", "Lj5L"])
def test_rider_jacobian_follows_the_re_solved_pose(tmp_path: Path, jason_default: tuple, key: str) -> None:
    """The implicit-function Jacobian equals a central difference of two fully re-seated riders."""
    r, seated = jason_default
    ps = _bike("Browser")
    sens = seated.sensitivity
    column = sens.jacobian[:, sens.names.index(f"rider {key}")]
    h = 1e-5
    moved = []
    for sign in (1, -1):
        lengths = dict(r.measurements.lengths)
        lengths[key] += sign * h
        meas = type(r.measurements)(lengths, r.measurements.mass, r.measurements.path)
        other = YeadonRider(r.name, meas, r.configuration, measurement_sigma=0, mass_sigma=0)
        s = seat_rider(other, ps)
        moved.append(np.array([s.mass, s.x, s.z, s.Ixx, s.Iyy, s.Izz, s.Ixz]))
    central = (moved[0] - moved[1]) / (2 * h)
    assert np.allclose(column, central, rtol=1e-4, atol=1e-6)
    assert np.max(np.abs(central)) > 0.01  # the measurement matters


def test_point_mass_rider_leaves_out_the_inertia(tmp_path: Path, jason_default: tuple) -> None:
    _, seated = jason_default
    ps = _bike("Browser")
    r = _yeadon(_write_rider(tmp_path, "Jason", "Browser", "inertia: false\nmeasurement_sigma: 0\nmass_sigma: 0\n"))
    point = seat_rider(r, ps)
    assert (point.mass, point.x, point.z) == pytest.approx((seated.mass, seated.x, seated.z), rel=1e-12)
    assert (point.Ixx, point.Iyy, point.Izz, point.Ixz) == (0.0, 0.0, 0.0, 0.0)
    full, bare = add_rider(ps, seated).values(), add_rider(ps, point).values()
    for name, own in (("IBxx", seated.Ixx), ("IByy", seated.Iyy), ("IBzz", seated.Izz), ("IBxz", seated.Ixz)):
        assert full[name] - bare[name] == pytest.approx(own, rel=1e-9), name


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("inertai: false\n", "key 'inertai': not a key of a Yeadon rider file"),
        ("inertia: 3\n", "key 'inertia': needs true or false"),
        ("measurement_sigma: -1\n", "key 'measurement_sigma': needs a number from 0"),
        ("bicycle_geometry:\n  lxx: 1\n", "key 'lxx': not a rider-geometry key"),
    ],
)
def test_bad_rider_file_names_file_and_key(tmp_path: Path, text: str, match: str) -> None:
    path = _write_rider(tmp_path, "Jason", "Browser", text)
    with pytest.raises(RiderError, match=match):
        resolve_rider(path)


def test_bad_measurement_file_names_file_key_and_line(tmp_path: Path) -> None:
    src = (BP / "riders" / "Jason" / "RawData" / "JasonYeadonMeas.txt").read_text(encoding="utf-8")
    meas = tmp_path / "meas.txt"
    meas.write_text(src.replace("Ls1L: 17.6", "Ls1L: -17.6"), encoding="utf-8")
    path = tmp_path / "r.yaml"
    cfg = BP / "riders" / "Jason" / "RawData" / "JasonBrowserYeadonCFG.txt"
    path.write_text(f"yeadon_measurements: meas.txt\nyeadon_configuration: {cfg}\n", encoding="utf-8")
    with pytest.raises(RiderError, match=r"meas\.txt:\d+: key 'Ls1L': needs a positive length"):
        resolve_rider(path)
    meas.write_text(src.replace("Ls1L: 17.6\n", ""), encoding="utf-8")
    with pytest.raises(RiderError, match="missing 1 of yeadon's 95 measurements: Ls1L"):
        resolve_rider(path)
    path.write_text(f"yeadon_measurements: nowhere.txt\nyeadon_configuration: {cfg}\n", encoding="utf-8")
    with pytest.raises(RiderError, match="nowhere.txt"):
        resolve_rider(path)


def test_a_name_that_is_no_rider_and_no_yaml_file() -> None:
    with pytest.raises(RiderError, match=r"^unknown rider 'tall': expected '', 'none', 'paper' or a rider YAML file$"):
        resolve_rider("tall")
