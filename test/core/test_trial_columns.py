"""Trial tables: which columns are time and signal, and in which unit the times are (issue 11)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from bike_rig.core.errors import InputFileError
from bike_rig.core.period import fit_period
from bike_rig.core.trial_columns import ColumnChoice, header_time_unit, is_time_name
from bike_rig.core.trials import key_from_name, read_trial
from test.support.signals import gyro_trial

PERIOD = 1.6


def write_csv(path: Path, header: str | None, *columns: np.ndarray) -> Path:
    """A CSV of the columns, every value written exactly (repr)."""
    lines = [header] if header is not None else []
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*columns)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def swing() -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and rates of one clean 30 s trial at 1 kHz with a 1.6 s period."""
    t = gyro_trial(7, period=PERIOD)
    assert t.times is not None
    return t.times, t.samples


def fitted_period(path: Path, **kwargs: object) -> float:
    trial = read_trial(path, **kwargs)  # type: ignore[arg-type]
    fit = fit_period(trial.samples, **trial.timing)
    assert fit.clean, fit.flags
    return fit.period


@pytest.mark.parametrize(
    ("name", "is_time", "unit"),
    [
        ("t", True, None),
        ("time", True, None),
        ("Time (s)", True, "s"),
        ("time_s", True, "s"),
        ("time_ms", True, "ms"),
        ("t[ms]", True, "ms"),
        ("timestamp", True, None),
        ("timestamp_ns", True, "ns"),
        ("elapsed_us", True, "us"),
        ("ms", True, "ms"),
        ("rate", False, None),
        ("rate_rad_s", False, "s"),
        ("volts", False, None),
        ("gyro_z", False, None),
    ],
)
def test_header_names(name: str, is_time: bool, unit: str | None) -> None:
    assert is_time_name(name) is is_time
    if is_time:
        assert header_time_unit(name) == unit


@pytest.mark.parametrize("header", ["time_ms,rate", "t [ms],gyro", "Time (ms);rate"])
def test_a_millisecond_header_is_read_in_seconds(
    tmp_path: Path, swing: tuple[np.ndarray, np.ndarray], header: str
) -> None:
    times, rates = swing
    f = write_csv(tmp_path / "trial.csv", header.replace(";", ","), times * 1000.0, rates)
    trial = read_trial(f)
    assert trial.time_unit == "ms" and trial.remarks == ()
    assert trial.times is not None and trial.times[-1] == pytest.approx(times[-1], rel=1e-12)
    assert trial.duration == pytest.approx(30.0, abs=0.01)
    assert fitted_period(f) == pytest.approx(PERIOD, rel=1e-3)  # not 1000 × the period


@pytest.mark.parametrize(("header", "label"), [("time,rate", "time column 'time'"), (None, "time column 0")])
def test_milliseconds_without_a_unit_are_told_by_their_spacing(
    tmp_path: Path, swing: tuple[np.ndarray, np.ndarray], header: str | None, label: str
) -> None:
    times, rates = swing
    f = write_csv(tmp_path / "trial.csv", header, times * 1000.0, rates)
    trial = read_trial(f)
    assert trial.time_unit == "ms"
    assert len(trial.remarks) == 1 and trial.remarks[0].startswith(f"{label} read in ms")
    assert "1000 Hz in ms but 1 Hz in s" in trial.remarks[0]
    assert fitted_period(f) == pytest.approx(PERIOD, rel=1e-3)


def test_epoch_stamps_in_seconds_milliseconds_and_nanoseconds(
    tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]
) -> None:
    times, rates = swing
    epoch = 1.7e9  # s
    for unit, scale in (("s", 1.0), ("ms", 1e3), ("ns", 1e9)):
        f = write_csv(tmp_path / f"{unit}.csv", "timestamp,rate", (epoch + times) * scale, rates)
        trial = read_trial(f)
        assert trial.time_unit == unit
        assert trial.duration == pytest.approx(30.0, abs=0.01)


def test_seconds_stay_seconds_silently(tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]) -> None:
    times, rates = swing
    for header in ("time,rate", "t,rate", "time_s,rate", None):
        trial = read_trial(write_csv(tmp_path / "s.csv", header, times, rates))
        assert trial.time_unit == "s" and trial.remarks == ()
        assert trial.times is not None and trial.times.tolist() == times.tolist()


def test_a_wrong_unit_in_the_header_is_refused_naming_the_likely_one(
    tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]
) -> None:
    times, rates = swing
    f = write_csv(tmp_path / "trial.csv", "time_s,rate", times * 1000.0, rates)
    with pytest.raises(InputFileError) as exc:
        read_trial(f)
    reason = exc.value.reason
    assert "time column 'time_s' says s" in reason and "(1 Hz)" in reason
    assert "they look like ms" in reason and "--time-unit" in reason
    # --time-unit is taken as given
    assert read_trial(f, columns=ColumnChoice(time_unit="ms")).duration == pytest.approx(30.0, abs=0.01)


def test_times_of_no_plausible_unit_are_refused(tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]) -> None:
    times, rates = swing
    # 1 Hz if seconds, 1 kHz if ms but only 0.03 s long, 1 MHz if µs: no unit fits
    f = write_csv(tmp_path / "odd.csv", "time,rate", times[:300] * 1000.0, rates[:300])
    with pytest.raises(InputFileError) as exc:
        read_trial(f)
    assert "1 Hz if in seconds" in exc.value.reason and "cannot be told" in exc.value.reason
    assert "time_ms" in exc.value.reason


def test_npy_and_mat_times_follow_the_same_rule(tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]) -> None:
    times, rates = swing
    np.save(tmp_path / "ms.npy", np.column_stack([times * 1000.0, rates]))
    savemat(tmp_path / "ms.mat", {"data": rates, "time": times * 1000.0})
    for name in ("ms.npy", "ms.mat"):
        trial = read_trial(tmp_path / name)
        assert trial.time_unit == "ms" and len(trial.remarks) == 1
        assert trial.duration == pytest.approx(30.0, abs=0.01)


def test_time_rate_volts_reads_the_rate(tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]) -> None:
    times, rates = swing
    volts = 2.5 + 0.4 * rates
    f = write_csv(tmp_path / "three.csv", "time,rate,volts", times, rates, volts)
    trial = read_trial(f)
    assert trial.samples.tolist() == rates.tolist()
    assert trial.remarks == ("signal: column 'rate' of time, rate, volts (choose another with --signal)",)
    by_name = read_trial(f, columns=ColumnChoice.from_text("time", "volts", None))
    by_index = read_trial(f, columns=ColumnChoice.from_text("0", "2", None))
    assert by_name.samples.tolist() == by_index.samples.tolist() == volts.tolist()
    assert by_name.remarks == ()
    assert fitted_period(f, columns=ColumnChoice(signal="volts")) == pytest.approx(PERIOD, rel=1e-3)


def test_columns_in_any_order_and_without_time(tmp_path: Path, swing: tuple[np.ndarray, np.ndarray]) -> None:
    times, rates = swing
    f = write_csv(tmp_path / "swapped.csv", "rate,time_ms", rates, times * 1000.0)
    assert read_trial(f).samples.tolist() == rates.tolist()
    g = write_csv(tmp_path / "notime.csv", "rate,volts", rates, rates)
    with pytest.raises(InputFileError, match=r"missing sample rate: the file \(rate, volts\) has no time column"):
        read_trial(g)
    assert read_trial(g, 1000.0).sample_rate_hz == 1000.0
    np.save(tmp_path / "wide.npy", np.column_stack([rates, times, rates]))
    wide = read_trial(tmp_path / "wide.npy", columns=ColumnChoice(time=1, signal=0))
    assert wide.times is not None and wide.times.tolist() == times.tolist()


@pytest.mark.parametrize(
    ("header", "choice", "message"),
    [
        ("time,rate,volts", ColumnChoice(time="clock"), "(time, rate, volts): --time 'clock': no such column"),
        ("time,rate,volts", ColumnChoice(signal=3), "--signal 3: no such column (0-based: 0 to 2)"),
        ("time,rate,volts", ColumnChoice(signal="time"), "--signal 'time' is the time column"),
        ("time,volts,current", ColumnChoice(), "(time, volts, current): cannot tell the time and the signal"),
        ("t,time_ms,rate", ColumnChoice(), "several time columns (t, time_ms): choose one with --time"),
        (None, ColumnChoice(), "3 columns: expected 1 (rate) or 2 (time, rate); choose them with --time"),
        (None, ColumnChoice(time="time"), "no header line to name its columns; give a 0-based index"),
    ],
)
def test_column_errors_name_the_columns(tmp_path: Path, header: str | None, choice: ColumnChoice, message: str) -> None:
    f = write_csv(tmp_path / "bad.csv", header, np.arange(3) * 0.001, np.ones(3), np.zeros(3))
    with pytest.raises(InputFileError) as exc:
        read_trial(f, columns=choice)
    assert message in exc.value.reason
    assert exc.value.line == 1


def test_mat_files_have_no_columns_to_choose(tmp_path: Path) -> None:
    savemat(tmp_path / "t.mat", {"data": np.ones(10), "sampleRate": 100.0})
    with pytest.raises(InputFileError, match="--time and --signal choose columns of CSV and .npy files"):
        read_trial(tmp_path / "t.mat", columns=ColumnChoice(signal=0))
    with pytest.raises(ValueError, match="time unit must be one of s, ms, us, ns"):
        ColumnChoice.from_text(None, None, "min")


@pytest.mark.parametrize(
    ("stem", "key"),
    [
        ("frame_torsional_o2_t3", "TtB2"),
        ("rear_wheel_compound_t1", "TcR1"),
        ("calibration_rod_torsional_t2", "TtP1"),
        ("BrowserForkCompoundFirst1", "TcH1"),
        ("BrowserFrameTorsionalThird2", "TtB3"),
        ("TtB2_t1", "TtB2"),
        ("fork-TcH1-2", "TcH1"),
        ("t1", None),
        ("TtB2t1", None),  # the key must be a word of the name
        ("TtB1_vs_TtB2", None),
    ],
)
def test_measurement_key_from_the_file_name(stem: str, key: str | None) -> None:
    assert key_from_name(stem) == key
