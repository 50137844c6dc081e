"""Ride records from CSV files: columns by default or by name, timestamps, and clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bike_rig.core.ride.record import RideDataError, read_ride_csv


def _write(tmp_path: Path, text: str, name: str = "ride.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_default_columns_in_seconds(tmp_path: Path) -> None:
    p = _write(tmp_path, "time,roll_rate,speed,steer_torque\n10.0,0.1,3.0,0\n10.01,0.2,3.2,1\n10.02,0.3,3.4,0\n")
    r = read_ride_csv(p)
    assert r.times == pytest.approx([0.0, 0.01, 0.02])
    assert r.signal == pytest.approx([0.1, 0.2, 0.3])
    assert r.speed is not None and r.mean_speed() == pytest.approx(3.2)
    assert r.torque is not None and r.signal_name == "roll_rate"


def test_named_columns_and_iso_timestamps(tmp_path: Path) -> None:
    p = _write(
        tmp_path,
        "stamp,gx,v\n2024-05-01T10:00:00.000,1,2\n2024-05-01T10:00:00.010,2,2\n\n2024-05-01T10:00:00.020,3,2\n",
    )
    r = read_ride_csv(p, signal="gx", time="stamp", speed="v")
    assert r.times == pytest.approx([0.0, 0.01, 0.02], abs=1e-9)
    assert r.torque is None and r.speed is not None
    assert np.all(r.signal == [1, 2, 3])


@pytest.mark.parametrize(
    ("text", "options", "expect"),
    [
        ("time,roll_rate\n0,1\n0.01,x\n", {}, r"ride.csv:3: column 'roll_rate': 'x' is not a number"),
        ("time,roll_rate\n0,1\n0,2\n", {}, r"ride.csv:3: column 'time': the times do not increase"),
        ("time,yaw\n0,1\n0.01,2\n", {}, r"ride.csv:1: no signal column"),
        ("time,roll_rate\n0,1\n0.01,2\n", {"signal": "gyro"}, r"ride.csv:1: no signal column 'gyro'"),
        ("time,roll_rate\n0,1\n", {}, r"1 data rows"),
        ("time,roll_rate\n0,1\n0.01\n", {}, r"ride.csv:3: 1 cells, no column 'roll_rate'"),
        ("", {}, r"empty file"),
    ],
)
def test_bad_files_name_file_line_and_column(tmp_path: Path, text: str, options: dict, expect: str) -> None:
    p = _write(tmp_path, text)
    with pytest.raises(RideDataError, match=expect):
        read_ride_csv(p, **options)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(RideDataError, match="no such file"):
        read_ride_csv(tmp_path / "none.csv")
