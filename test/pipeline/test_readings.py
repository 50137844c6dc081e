"""pipeline/readings: entered static readings (checks, the newest wins, canonical order) and the partial assembly."""

from __future__ import annotations

import math
import random
from types import SimpleNamespace

import numpy as np
import pytest

from bike_rig.bag.typestore import new_message
from bike_rig.config.paths import config_file
from bike_rig.config.topics import READINGS
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.errors import GeometryError, MeasurementError
from bike_rig.core.io_yaml import dump_measurements_yaml, load_yaml_document, measurements_from_document
from bike_rig.core.loader import load_measurements, load_static_readings
from bike_rig.core.measurements import Measurements
from bike_rig.messages import fill_reading_entry, reading_entry_from_msg
from bike_rig.pipeline.assemble import SessionAssembly, required_readings
from bike_rig.pipeline.errors import AssemblyError
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.readings import (
    ImpossibleReadingError,
    NegativeSigmaError,
    NonFiniteReadingError,
    ReadingEntry,
    ReadingEntryError,
    UnknownReadingKeyError,
    apply_entries,
    check_entry,
)
from test.support.nodes import BROWSER_KEYS, STATIC_KEYS

BROWSER = config_file("bicycles/browser.yaml")


def entries_of(static: Measurements, stamp0: int = 1_000) -> list[ReadingEntry]:
    """One entry per reading, stamped one after the other."""
    return [ReadingEntry(k, r.value, r.sigma, stamp0 + i) for i, (k, r) in enumerate(static.readings.items())]


def none_of(bicycle: str = "Browser") -> Measurements:
    return Measurements(bicycle, {}, "")


def file_trials(keys: tuple[str, ...]) -> list[TrialFit]:
    full = load_measurements(BROWSER)
    return [TrialFit.from_period(f"{k}-t1", k, full.value(k), full.readings[k].sigma, True) for k in keys]


# ------------------------------------------------------------------------------------ checks


@pytest.mark.parametrize(
    ("key", "value", "sigma", "error", "reason"),
    [
        ("mX", 1.0, 0.1, UnknownReadingKeyError, "unknown key 'mX'"),
        ("alphaB0", 10.0, 0.2, UnknownReadingKeyError, "unknown key 'alphaB0'"),
        ("alphaB01", 10.0, 0.2, UnknownReadingKeyError, "unknown key 'alphaB01'"),
        ("alphaP1", 10.0, 0.2, UnknownReadingKeyError, "unknown key 'alphaP1'"),
        ("TtB1", 2.1, 1e-5, UnknownReadingKeyError, "'TtB1' is a pendulum period: periods come from trials"),
        ("mR", math.nan, 0.02, NonFiniteReadingError, "must be finite"),
        ("mR", 3.1, math.inf, NonFiniteReadingError, "must be finite"),
        ("mR", 3.1, -0.02, NegativeSigmaError, "sigma must be >= 0, got -0.02"),
        ("mR", -3.1, 0.02, ImpossibleReadingError, "must be positive, got -3.1"),
        ("gamma", 112.0, 0.2, ImpossibleReadingError, "head-tube angle must be in (0, 90]"),
        ("nR", 13.5, 0.0, ImpossibleReadingError, "exact whole count"),
        ("alphaH2", 400.0, 0.2, ImpossibleReadingError, "hanging angle must be in [-360, 360]"),
    ],
)
def test_a_bad_entry_is_refused_with_its_own_error(
    key: str, value: float, sigma: float, error: type[ReadingEntryError], reason: str
) -> None:
    entry = ReadingEntry(key, value, sigma, 5)
    with pytest.raises(error) as info:
        check_entry(entry)
    assert reason in str(info.value) and str(info.value).startswith(f"reading entry {key} = ")
    assert info.value.entry == entry
    # applying it fails the same way, whatever came before
    with pytest.raises(error):
        apply_entries(load_static_readings(BROWSER), [ReadingEntry("mR", 3.0, 0.02, 1), entry])


@pytest.mark.parametrize("key", [*STATIC_KEYS, "alphaB4", "aH12"])
def test_every_static_key_is_accepted(key: str) -> None:
    value = 13.0 if key.startswith("n") else 1.0
    check_entry(ReadingEntry(key, value, 0.0 if key.startswith("n") else 0.1))


# ------------------------------------------------------------------------------------ applying


def test_no_entries_is_the_file_itself() -> None:
    static = load_static_readings(BROWSER)
    assert apply_entries(static, []) is static


def test_entries_in_any_order_give_the_file_order_and_its_parameters_bit_for_bit() -> None:
    static = load_static_readings(BROWSER)
    entries = entries_of(static)
    shuffled = entries[:]
    random.Random(3).shuffle(shuffled)
    merged = apply_entries(none_of(), shuffled)
    assert list(merged.readings) == list(static.readings) == list(STATIC_KEYS)
    pairs = [(r.value, r.sigma) for r in static.readings.values()]
    assert [(r.value, r.sigma) for r in merged.readings.values()] == pairs
    assert merged.path == "29 reading entries" and merged.bicycle == "Browser"
    session = SessionAssembly(merged)
    session.add_all(file_trials(session.required_keys))
    ours = session.result().complete_parameters().parameters
    core = compute_parameters(load_measurements(BROWSER)).parameters
    assert np.array_equal(ours.values, core.values) and np.array_equal(ours.covariance, core.covariance)


def test_the_newest_entry_of_a_key_wins_by_stamp_then_arrival() -> None:
    static = load_static_readings(BROWSER)
    first = ReadingEntry("mR", 3110.0, 20.0, 100, "grams by mistake")
    correction = ReadingEntry("mR", 3.11, 0.02, 200, "correction")
    late_old = ReadingEntry("mR", 9.0, 0.5, 50)  # arrives last, but was taken first
    merged = apply_entries(static, [first, correction, late_old])
    assert (merged.value("mR"), merged.readings["mR"].sigma) == (3.11, 0.02)
    assert merged.path == f"{static.path} + 3 reading entries"
    # the same stamp: the later arrival wins
    same = apply_entries(static, [ReadingEntry("mF", 2.0, 0.1, 7), ReadingEntry("mF", 2.5, 0.1, 7)])
    assert same.value("mF") == 2.5
    # everything else stays the file's, in the file's order
    assert list(merged.readings) == list(static.readings)
    assert all(merged.readings[k] == r for k, r in static.readings.items() if k != "mR")
    assert merged.readings["mR"].origin is not None and merged.readings["mR"].origin.key == "mR"


def test_a_new_orientation_is_placed_after_its_part() -> None:
    static = load_static_readings(BROWSER)
    merged = apply_entries(static, [ReadingEntry("aB4", 0.05, 0.003, 2), ReadingEntry("alphaB4", 70.0, 0.2, 1)])
    keys = list(merged.readings)
    assert keys[keys.index("aB3") + 1 : keys.index("aB3") + 3] == ["alphaB4", "aB4"]
    assert keys.index("aB4") < keys.index("mH")


def test_merged_readings_dump_and_load_back() -> None:
    """The parameter node's StaticReadings document: a measurement file of the merged readings."""
    static = load_static_readings(BROWSER)
    merged = apply_entries(static, [ReadingEntry("gamma", 68.0, 0.3, 1)])
    text = dump_measurements_yaml(merged)
    data, lines = load_yaml_document_text(text)
    back = measurements_from_document("doc", data, lines, static_only=True)
    assert [(k, r.value, r.sigma) for k, r in back.readings.items()] == [
        (k, r.value, r.sigma) for k, r in merged.readings.items()
    ]
    # a partial set dumps too (orientations without their periods)
    partial = apply_entries(none_of(), [ReadingEntry("alphaB1", 10.0, 0.2, 1), ReadingEntry("mR", 3.0, 0.02, 2)])
    assert "angle_deg: [10.0, 0.2]" in dump_measurements_yaml(partial)


def load_yaml_document_text(text: str) -> tuple[object, dict[tuple[object, ...], int]]:
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "doc.yaml"
        path.write_text(text)
        return load_yaml_document(path)


def test_converters_round_trip_rosbags_and_stand_in_messages() -> None:
    entry = ReadingEntry("alphaH2", -12.5, 0.25, 1_800_000_000_123_456_789, "correction")
    msg = fill_reading_entry(new_message(READINGS.type), entry)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_800_000_000, 123_456_789)
    assert reading_entry_from_msg(msg) == entry
    stand_in = SimpleNamespace(
        header=SimpleNamespace(stamp=SimpleNamespace(sec=0, nanosec=0), frame_id=""),
        key="",
        value=0.0,
        sigma=0.0,
        note="",
    )
    assert reading_entry_from_msg(fill_reading_entry(stand_in, entry)) == entry  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------ partial assembly


def test_required_readings_start_from_three_orientations() -> None:
    assert required_readings(none_of()) == STATIC_KEYS
    # orientations known from readings and periods; the lowest unused indices fill up to three
    some = Measurements("X", {"alphaB5": load_static_readings(BROWSER).readings["alphaB1"]}, "")
    needed = required_readings(some, ["TtH4", "TcR1"])
    frame = [k for k in needed if k.startswith(("alphaB", "aB"))]
    assert frame == ["alphaB1", "aB1", "alphaB2", "aB2", "alphaB5", "aB5"]
    fork = [k for k in needed if k.startswith(("alphaH", "aH"))]
    assert fork == ["alphaH1", "aH1", "alphaH2", "aH2", "alphaH4", "aH4"]


def test_a_partial_session_lists_missing_readings_then_periods() -> None:
    session = SessionAssembly(none_of(), partial=True)
    result = session.result()
    assert result.missing == STATIC_KEYS + BROWSER_KEYS and not result.complete
    assert result.missing_readings == STATIC_KEYS and result.missing_periods == BROWSER_KEYS
    assert session.required_keys == BROWSER_KEYS

    static = load_static_readings(BROWSER)
    entries = [e for e in entries_of(static) if e.key not in ("mF", "aH3")]
    session.set_static(apply_entries(none_of(), entries))
    session.add_all(file_trials(BROWSER_KEYS))
    result = session.result()
    assert result.missing == ("mF", "aH3") and result.parameters is None
    assert [p.key for p in result.periods] == list(BROWSER_KEYS)

    session.set_static(apply_entries(none_of(), entries_of(static)))
    result = session.result()
    assert result.complete and result.missing == ()
    core = compute_parameters(load_measurements(BROWSER)).parameters
    assert result.parameters is not None
    assert np.array_equal(result.parameters.parameters.values, core.values)
    assert np.array_equal(result.parameters.parameters.covariance, core.covariance)


def test_a_period_of_an_orientation_not_entered_yet_is_kept_and_asks_for_its_readings() -> None:
    static = load_static_readings(BROWSER)
    session = SessionAssembly(static, partial=True)
    session.add_all(file_trials(BROWSER_KEYS))
    assert session.result().complete
    extra = TrialFit.from_period("TtB4-t1", "TtB4", 2.2, 1e-4, True)
    assert session.add(extra)
    result = session.result()
    assert result.missing == ("alphaB4", "aB4") and not result.complete
    assert "TtB4" in session.required_keys and any(p.key == "TtB4" for p in result.periods)
    with pytest.raises(AssemblyError, match="'TcX1' is not a period key"):
        session.add(TrialFit.from_period("x", "TcX1", 2.0, 1e-4, True))
    # without partial readings it is refused, as before
    with pytest.raises(AssemblyError, match="'TtB4' is not a period of Browser"):
        SessionAssembly(static).add(extra)


def test_bad_static_readings_leave_the_partial_session_unchanged() -> None:
    static = load_static_readings(BROWSER)
    some = apply_entries(none_of(), [e for e in entries_of(static) if e.key.startswith("alphaB")])
    session = SessionAssembly(some, partial=True)
    before = (session.static, session.required_keys, session.missing_readings)
    parallel = apply_entries(some, [ReadingEntry("alphaB2", some.value("alphaB1") + 180.0, 0.2, 10**6)])
    with pytest.raises(GeometryError, match="parallel"):
        session.set_static(parallel)
    assert (session.static, session.required_keys, session.missing_readings) == before
    # a reading a file would refuse is refused too (here: not from an entry, so not checked before)
    bad = Measurements("Browser", {**some.readings, "nR": static.readings["dR"]}, "")
    with pytest.raises(MeasurementError, match="whole count"):
        session.set_static(bad)
    assert session.static is before[0]
    # without partial readings an incomplete set fails at the start, as before
    with pytest.raises(MeasurementError, match="missing"):
        SessionAssembly(some)
