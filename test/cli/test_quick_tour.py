"""The manual's quick tour, offline, from an empty folder; a ride validated straight from a session bag.

Every command where a bicycle is meant takes a parameter file, a measurement file or a session
bag, and the shipped examples are found by the paths the manual writes (``config/bicycles/…``,
``config/feedback/…``) or by a bare name, from any folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from bike_rig.bag.simulated import simulated_messages
from bike_rig.bag.typestore import rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config import topics
from test.support.simulated import short_session

BROWSER = "config/bicycles/browser.yaml"
FEEDBACK = "config/feedback/balance_assist.yaml"


def _run(folder: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "BIKE_RIG_CONFIG"}
    return subprocess.run(
        [sys.executable, "-m", "bike_rig.cli.main", *args],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def _ok(folder: Path, *args: str) -> str:
    got = _run(folder, *args)
    assert got.returncode == 0, f"bike-rig {' '.join(args)}: {got.stderr}"
    assert "Traceback" not in got.stderr
    return got.stdout


@pytest.fixture(scope="module")
def empty(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("empty")
    assert not any(folder.iterdir())
    return folder


def test_the_quick_tour_runs_from_an_empty_folder(empty: Path) -> None:
    assert not (empty / BROWSER).exists()
    table = _ok(empty, "params", BROWSER)
    assert "Browser" in table and "w [m]" in table
    assert _ok(empty, "params", "browser") == table  # a bare name is the same shipped file
    model = _ok(empty, "model", BROWSER)
    assert "weave speed" in model and "-0.000000" not in model
    assert "measure better first" in _ok(empty, "budget", BROWSER, "--top", "5")
    _ok(empty, "report", BROWSER, "-o", "out/")
    assert (empty / "out" / "index.html").is_file()


def test_the_ride_example_runs_from_an_empty_folder(empty: Path) -> None:
    _ok(
        empty,
        "ride",
        "simulate",
        "browser",
        "--speed",
        "4",
        "-o",
        "ride.csv",
        "--rider",
        "paper",
        "--feedback",
        "balance_assist",
        "--seed",
        "1",
    )
    assert "segments combined" in _ok(empty, "ride", "fit", "ride.csv")
    out = _ok(empty, "ride", "validate", BROWSER, "ride.csv", "--rider", "paper", "--feedback", FEEDBACK)
    assert "verdict:" in out and "hint:" not in out
    assert f"model: {BROWSER}, rider paper, feedback {FEEDBACK}" in out.splitlines()
    riderless = _ok(empty, "ride", "validate", BROWSER, "ride.csv", "--feedback", "balance_assist")
    assert "rider none (the bicycle alone)" in riderless and "hint: the model has no rider" in riderless


def test_a_name_that_is_no_shipped_file_is_still_refused_in_one_line(empty: Path) -> None:
    got = _run(empty, "params", "no_such_bicycle")
    assert got.returncode == 2
    assert "no_such_bicycle" in got.stderr and "Traceback" not in got.stderr


def _write_bag(path: Path) -> Path:
    store = rig_typestore()
    types = {t.name: t.type for t in topics.TOPICS}
    with BagWriter(path, flush_period_s=3600.0) as w:
        for t in topics.TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for m in simulated_messages(short_session()):
            w.write(m.topic, m.log_time, bytes(store.serialize_cdr(m.message, types[m.topic])))
    return path


def test_a_ride_is_validated_straight_from_a_session_bag(empty: Path) -> None:
    bag = str(_write_bag(empty / "session_bag"))
    table = _ok(empty, "params", bag)
    assert "w [m]" in table
    assert "weave speed" in _ok(empty, "model", bag)
    _ok(empty, "ride", "simulate", bag, "--speed", "5", "-o", "bag_ride.csv", "--seed", "2")
    out = _ok(empty, "ride", "validate", bag, "bag_ride.csv")
    assert "verdict:" in out
