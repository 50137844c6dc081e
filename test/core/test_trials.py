"""Trial files: CSV, .npy and BicycleParameters' pendulum .mat, and every bad file's message."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from bike_rig.core.errors import InputFileError
from bike_rig.core.period import fit_period
from bike_rig.core.trials import Trial, read_trial
from test.support.signals import gyro_trial


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# ---------------------------------------------------------------- CSV


def test_csv_time_and_rate_with_header_and_comments(tmp_path: Path) -> None:
    text = "# rig 2, trial 1\ntime,rate\n\n0.000,0.5\n0.001,0.25\n# note\n0.0021,-0.125\n"
    f = _write(tmp_path / "frame_t1.csv", text)
    trial = read_trial(f)
    assert isinstance(trial, Trial)
    assert trial.samples.tolist() == [0.5, 0.25, -0.125]
    assert trial.times is not None and trial.times.tolist() == [0.0, 0.001, 0.0021]
    assert trial.sample_rate_hz is None and trial.timing == {"times": trial.times}
    assert trial.name == "frame_t1" and trial.path == str(f)
    assert trial.samples.dtype == np.float64


def test_csv_one_column_needs_a_rate(tmp_path: Path) -> None:
    f = _write(tmp_path / "rates.csv", "rate\n1.0\n2.0\n3.5\n")
    trial = read_trial(f, sample_rate_hz=500.0)
    assert trial.samples.tolist() == [1.0, 2.0, 3.5] and trial.times is None
    assert trial.timing == {"sample_rate_hz": 500.0} and trial.duration == pytest.approx(3 / 500)
    with pytest.raises(InputFileError, match="missing sample rate.*--rate") as exc:
        read_trial(f)
    assert exc.value.path == str(f)


@pytest.mark.parametrize("sep", [";", "\t", " ", ", "])
def test_csv_separators(tmp_path: Path, sep: str) -> None:
    f = _write(tmp_path / "t.txt", f"0{sep}1.5\n0.01{sep}nan\n0.02{sep}-2e-3\n")
    trial = read_trial(f)
    assert trial.times is not None and trial.times.tolist() == [0.0, 0.01, 0.02]
    assert np.isnan(trial.samples[1]) and trial.samples[2] == -2e-3  # bad values are the fitter's business


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("t,rate\n0,1\n0.1,abc\n", 3, "non-numeric value 'abc' in column 2"),
        ("0,1\n0.1,\n", 2, "an empty cell in column 2"),
        ("0,1\n0.1,2,3\n", 2, "3 columns where the file has 2"),
        ("0,1,2\n", 1, "3 columns: expected 1 (rate) or 2 (time, rate)"),
        ("a,b,c\n0,1,2\n", 1, "header with 3 columns"),
        ("time,rate\n0,1\n\nx,y\n", 4, "non-numeric value 'x' in column 1"),
    ],
)
def test_csv_errors_name_the_line(tmp_path: Path, text: str, line: int, message: str) -> None:
    f = _write(tmp_path / "bad.csv", text)
    with pytest.raises(InputFileError) as exc:
        read_trial(f)
    assert exc.value.line == line
    assert message in exc.value.reason
    assert str(exc.value).startswith(f"{f}:{line}: ")


def test_csv_without_samples_and_not_text(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="no samples"):
        read_trial(_write(tmp_path / "empty.csv", "# nothing\ntime,rate\n"))
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"\xff\xfe\x00\x81garbage")
    with pytest.raises(InputFileError, match="not a text file"):
        read_trial(binary)


# ---------------------------------------------------------------- NumPy


def test_npy_shapes(tmp_path: Path) -> None:
    np.save(tmp_path / "rates.npy", np.arange(5.0))
    np.save(tmp_path / "column.npy", np.arange(5.0).reshape(5, 1))
    np.save(tmp_path / "pairs.npy", np.column_stack([np.arange(4) * 0.01, [1, 2, 3, 4]]))
    np.save(tmp_path / "ints.npy", np.arange(6, dtype=np.int16))
    assert read_trial(tmp_path / "rates.npy", 100.0).samples.tolist() == [0, 1, 2, 3, 4]
    assert read_trial(tmp_path / "column.npy", 100.0).sample_rate_hz == 100.0
    pairs = read_trial(tmp_path / "pairs.npy", 100.0)  # the file's times win
    assert pairs.times is not None and pairs.times.tolist() == [0, 0.01, 0.02, 0.03]
    assert pairs.samples.tolist() == [1, 2, 3, 4] and pairs.sample_rate_hz is None
    assert read_trial(tmp_path / "ints.npy", 10.0).samples.dtype == np.float64
    with pytest.raises(InputFileError, match="missing sample rate: a 1-D array"):
        read_trial(tmp_path / "rates.npy")


@pytest.mark.parametrize(
    ("array", "message"),
    [
        (np.zeros((3, 7)), r"wrong shape \(3, 7\)"),
        (np.zeros((2, 2, 2)), r"wrong shape \(2, 2, 2\)"),
        (np.array(["a", "b"]), "<U1 values, not numbers"),
        (np.zeros(0), "no samples"),
    ],
)
def test_npy_errors(tmp_path: Path, array: np.ndarray, message: str) -> None:
    np.save(tmp_path / "bad.npy", array)
    with pytest.raises(InputFileError, match=message):
        read_trial(tmp_path / "bad.npy", 100.0)


def test_npy_pickles_and_garbage_are_refused(tmp_path: Path) -> None:
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InputFileError, match="not a readable NumPy"):
        read_trial(tmp_path / "objects.npy", 100.0)
    (tmp_path / "garbage.npy").write_bytes(b"not numpy at all")
    with pytest.raises(InputFileError, match="not a readable NumPy"):
        read_trial(tmp_path / "garbage.npy", 100.0)


# ---------------------------------------------------------------- BicycleParameters .mat


def _bp_mat(path: Path, **fields: object) -> Path:
    trial = gyro_trial(4, period=1.8)
    content: dict[str, object] = {
        "bicycle": "Browser",
        "part": "Frame",
        "pendulum": "Torsional",
        "angleOrder": "Second",
        "trial": "3",
        "notes": "",
        "data": trial.samples,
        "sampleRate": 1000.0,
        "duration": 30.0,
        "ActualRate": 1000,
    }
    content.update(fields)
    savemat(path, {k: v for k, v in content.items() if v is not None})
    return path


def test_bicycleparameters_mat(tmp_path: Path) -> None:
    trial = read_trial(_bp_mat(tmp_path / "BrowserFrameTorsionalSecond3.mat"))
    assert trial.name == "BrowserFrameTorsionalSecond3"
    assert (trial.bicycle, trial.part, trial.pendulum, trial.angle, trial.trial) == (
        "Browser",
        "Frame",
        "Torsional",
        "Second",
        "3",
    )
    assert trial.notes is None and trial.period_key == "TtB2"
    assert trial.sample_rate_hz == 1000.0 and trial.times is None and trial.samples.shape == (30000,)
    fit = fit_period(trial.samples, **trial.timing)
    assert abs(fit.period - 1.8) < 4 * fit.period_sigma


def test_mat_metadata_variants(tmp_path: Path) -> None:
    f = _bp_mat(tmp_path / "x.mat", angleOrder=None, angle="First", trial=2, part="Rwheel", pendulum="Compound")
    trial = read_trial(f)
    assert trial.angle == "First" and trial.trial == "2" and trial.period_key == "TcR1"
    bare = read_trial(_bp_mat(tmp_path / "bare.mat", bicycle=None, part=None, pendulum=None, trial=None))
    assert bare.name == "bare" and bare.period_key is None


def test_mat_with_time_array_uses_it(tmp_path: Path) -> None:
    times = np.sort(np.random.default_rng(1).uniform(0, 30, 30000))
    f = _bp_mat(tmp_path / "timed.mat", time=times, data=gyro_trial(2, period=1.1, times=times).samples)
    trial = read_trial(f)
    assert trial.times is not None and np.array_equal(trial.times, times) and trial.sample_rate_hz is None
    fit = fit_period(trial.samples, **trial.timing)
    assert abs(fit.period - 1.1) < 4 * fit.period_sigma


def test_mat_rate_falls_back_to_the_argument(tmp_path: Path) -> None:
    f = _bp_mat(tmp_path / "norate.mat", sampleRate=None, ActualRate=None)
    with pytest.raises(InputFileError, match="missing sample rate") as exc:
        read_trial(f)
    assert "ActualRate" in exc.value.reason
    assert read_trial(f, sample_rate_hz=250.0).sample_rate_hz == 250.0
    # ActualRate (measured) wins over sampleRate (asked for) and the argument when they agree (within 1 %)
    g = _bp_mat(tmp_path / "actual.mat", ActualRate=998.5)
    assert read_trial(g, sample_rate_hz=1000.0).sample_rate_hz == 998.5
    with pytest.raises(InputFileError, match="ActualRate says 998.5 Hz, but --rate says 1 Hz"):
        read_trial(g, sample_rate_hz=1.0)


@pytest.mark.parametrize(
    ("fields", "key", "message"),
    [
        ({"data": None}, "data", "no 'data' array"),
        ({"data": np.zeros((4, 5))}, "data", r"wrong shape \(4, 5\)"),
        ({"data": "volts"}, "data", "not numbers"),
        ({"ActualRate": 0.0}, "ActualRate", "positive number"),
        ({"ActualRate": None, "sampleRate": "fast"}, "sampleRate", "positive number"),
        ({"time": np.arange(10.0)}, "time", "10 times for 30000 samples"),
    ],
)
def test_mat_errors_name_the_key(tmp_path: Path, fields: dict[str, object], key: str, message: str) -> None:
    f = _bp_mat(tmp_path / "bad.mat", **fields)
    with pytest.raises(InputFileError, match=message) as exc:
        read_trial(f)
    assert exc.value.key == key
    assert f"key '{key}'" in str(exc.value)


def test_mat_garbage(tmp_path: Path) -> None:
    (tmp_path / "garbage.mat").write_bytes(b"MATLAB 5.0 MAT-file" + b"\x00" * 50)
    with pytest.raises(InputFileError, match="not a readable MATLAB"):
        read_trial(tmp_path / "garbage.mat")


# ---------------------------------------------------------------- paths


def test_missing_directory_and_unknown_files(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="no such file"):
        read_trial(tmp_path / "nope.csv")
    with pytest.raises(InputFileError, match="is a directory"):
        read_trial(tmp_path)
    with pytest.raises(InputFileError, match=r"unknown trial format '\.wav'"):
        read_trial(_write(tmp_path / "sound.wav", "RIFF"))
    with pytest.raises(InputFileError, match="positive number of Hz"):
        read_trial(_write(tmp_path / "r.csv", "1\n"), sample_rate_hz=0.0)
    assert read_trial(str(_write(tmp_path / "s.CSV", "1\n2\n")), 10.0).samples.size == 2


def test_evenly_spaced_time_stamps_are_fitted_by_their_rate() -> None:
    """A file and a live stream of the same samples get the same fit.

    Even time stamps become a sample rate (snapped to 1000.0 here), jittered ones stay time
    stamps.
    """
    from bike_rig.core.trials import uniform_sample_rate

    t = np.arange(30000) / 1000.0
    assert uniform_sample_rate(t) == 1000.0
    assert uniform_sample_rate(t + 1.7e9) is not None  # epoch stamps: float resolution allowed
    jittered = t + np.random.default_rng(1).normal(0, 1e-5, t.size)
    assert uniform_sample_rate(jittered) is None
    assert uniform_sample_rate(np.array([0.0, 0.001])) is None  # too short to tell
