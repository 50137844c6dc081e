"""Binary trial files checked before their arrays are read: bounded memory whatever their headers say."""

from __future__ import annotations

import struct
import tracemalloc
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest
from numpy.lib import format as npy_format
from scipy.io import savemat

from bike_rig.core import trial_binary
from bike_rig.core.errors import InputFileError
from bike_rig.core.trials import read_trial


def _npy(tmp_path: Path) -> bytes:
    np.save(tmp_path / "ok.npy", np.column_stack([np.arange(500) / 100.0, np.sin(np.arange(500) / 10.0)]))
    return (tmp_path / "ok.npy").read_bytes()


def test_a_header_claiming_20_billion_samples_is_refused_before_allocating(tmp_path: Path) -> None:
    path = tmp_path / "huge.npy"
    with path.open("wb") as f:
        npy_format.write_array_header_1_0(f, {"descr": "<f8", "fortran_order": False, "shape": (20_000_000_000,)})
        f.write(b"\0" * 64)
    tracemalloc.start()
    try:
        with pytest.raises(InputFileError, match=r"announces a \(20000000000,\) array of float64 .* only 64 bytes"):
            read_trial(path, 100.0)
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peak < 5e6


@pytest.mark.parametrize("cut", [10, 40, 200, 7999])
def test_a_truncated_npy_is_refused_in_one_line(tmp_path: Path, cut: int) -> None:
    path = tmp_path / "cut.npy"
    path.write_bytes(_npy(tmp_path)[:cut])
    with pytest.raises(InputFileError, match="not a readable NumPy|truncated or damaged") as info:
        read_trial(path, 100.0)
    assert "\n" not in str(info.value)


def test_an_unknown_npy_version_is_refused(tmp_path: Path) -> None:
    data = bytearray(_npy(tmp_path))
    data[6] = 9
    path = tmp_path / "v9.npy"
    path.write_bytes(bytes(data))
    with pytest.raises(InputFileError, match="not a readable NumPy .npy file"):
        read_trial(path, 100.0)


def _mat_with_compressed(path: Path, raw: bytes) -> None:
    """A MATLAB v5 file: a 128-byte header and one compressed element holding ``raw``."""
    header = b"MATLAB 5.0 MAT-file".ljust(116) + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"
    body = zlib.compress(raw, 9)
    path.write_bytes(header + struct.pack("<II", 15, len(body)) + body)


def test_a_mat_that_inflates_beyond_any_trial_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A small .mat file whose compressed element inflates past the cap never reaches scipy."""
    monkeypatch.setattr(trial_binary, "MAX_TRIAL_BYTES", 1 << 20)
    path = tmp_path / "bomb.mat"
    _mat_with_compressed(path, b"\0" * (4 << 20))
    assert path.stat().st_size < 10_000
    with pytest.raises(InputFileError, match=f"more than {1 << 20} bytes"):
        read_trial(path, 100.0)


def test_a_valid_compressed_mat_passes_the_check(tmp_path: Path) -> None:
    path = tmp_path / "ok.mat"
    savemat(path, {"data": np.sin(np.arange(3000) / 50.0), "sampleRate": 100.0}, do_compression=True)
    trial_binary.check_mat_sizes(str(path), path)
    assert read_trial(path).samples.size == 3000


def test_mat_errors_are_one_line_and_warnings_stay_quiet(tmp_path: Path) -> None:
    """Multi-line messages of scipy, and its warnings, printed before the error line."""
    path = tmp_path / "ok.mat"
    savemat(path, {"data": np.sin(np.arange(3000) / 50.0), "sampleRate": 100.0})
    data = path.read_bytes()
    for cut in (130, 200, 300, len(data) - 5):
        (tmp_path / "cut.mat").write_bytes(data[:cut])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(InputFileError) as info:
                read_trial(tmp_path / "cut.mat", 100.0)
        assert "\n" not in str(info.value)


def test_a_text_trial_larger_than_any_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from bike_rig.core import trials

    monkeypatch.setattr(trials, "MAX_TEXT_TRIAL_BYTES", 1000)
    path = tmp_path / "big.csv"
    path.write_text("0.1\n" * 1000)
    with pytest.raises(InputFileError, match="4000 bytes: larger than any trial file"):
        read_trial(path, 100.0)


def test_a_mat_that_crashes_scipy_is_one_line() -> None:
    """This fuzzed file (test/fuzz/corpus) made scipy 1.17's loadmat segfault the whole process."""
    path = Path(__file__).parents[1] / "fuzz" / "corpus" / "segfault-scipy-1.17.mat"
    with pytest.raises(InputFileError, match="not a readable MATLAB .mat file") as info:
        read_trial(path, 100.0)
    assert "\n" not in str(info.value)


def test_a_damaged_header_literal_prints_no_syntax_warning() -> None:
    """'shape': (200inf0,) made Python print a SyntaxWarning before the error line (found by fuzzing)."""
    path = Path(__file__).parents[1] / "fuzz" / "corpus" / "syntax-warning-header.npy"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(InputFileError, match="not a readable NumPy .npy file"):
            read_trial(path, 100.0)
    assert [str(w.message) for w in caught] == []
