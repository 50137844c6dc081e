"""bike_rig_msgs is built into the venv and its GyroBatch crosses between two real processes."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from test.support.processes import RosProcess

pytestmark = pytest.mark.ros

NODES = Path(__file__).with_name("gyro_nodes.py")
N_BATCHES = 5
N_SAMPLES = 50
RATE_HZ = 1000.0
STEP_TIMEOUT_S = 60.0


def make_batches() -> list[dict[str, Any]]:
    """Five batches of 50 samples with distinct, non-round values; odd batches carry volts."""
    batches = []
    for b in range(N_BATCHES):
        first = b * N_SAMPLES
        start_ns = 1_700_000_000_000_000_000 + first * 1_000_000
        rates = [0.8 * math.sin(2 * math.pi * 1.3 * (first + i) / RATE_HZ) + 1e-3 * b for i in range(N_SAMPLES)]
        batches.append(
            {
                "stamp": [start_ns // 1_000_000_000, start_ns % 1_000_000_000],
                "frame_id": "gyro",
                "trial_id": f"smoke-{b}",
                "sample_rate_hz": RATE_HZ,
                "rates": rates,
                "raw_volts": [2.5 + r / 3.0 for r in rates] if b % 2 else [],
            }
        )
    return batches


def check_env(line: str, domain_id: int) -> None:
    env = json.loads(line)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert env["ROS_DOMAIN_ID"] == str(domain_id)
    assert env["context_domain_id"] == domain_id
    assert env["rmw"] == "rmw_fastrtps_cpp"


def test_gyro_batch_between_two_processes(ros_env: dict[str, str], ros_domain_id: int, tmp_path: Path) -> None:
    batches = make_batches()
    batches_file = tmp_path / "batches.json"
    batches_file.write_text(json.dumps(batches))
    topic = f"/bike_rig/test/gyro_{os.getpid()}"

    sub_argv = [sys.executable, str(NODES), "sub", topic]
    pub_argv = [sys.executable, str(NODES), "pub", topic, str(batches_file)]
    # leaving the with-block stops both by PID, whatever happened
    with (
        RosProcess("sub", sub_argv, ros_env, tmp_path) as sub,
        RosProcess("pub", pub_argv, ros_env, tmp_path, stdin=True) as pub,
    ):
        check_env(sub.expect("ENV", STEP_TIMEOUT_S), ros_domain_id)
        check_env(pub.expect("ENV", STEP_TIMEOUT_S), ros_domain_id)
        # both ends have matched each other before a single sample is written
        assert json.loads(sub.expect("MATCHED", STEP_TIMEOUT_S))["count"] == 1
        assert json.loads(pub.expect("MATCHED", STEP_TIMEOUT_S))["count"] == 1
        pub.send("GO")
        received = [json.loads(sub.expect("MSG", STEP_TIMEOUT_S)) for _ in batches]
        published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
        pub_code = pub.stop()
        sub_code = sub.stop()

    assert published == {"count": N_BATCHES}
    assert received == batches  # exact: every float, in order, nothing lost or added
    assert all(len(b["rates"]) == N_SAMPLES for b in received)
    assert (pub_code, sub_code) == (0, 0), pub.describe() + sub.describe()


def test_spawned_process_environment(ros_env: dict[str, str], ros_domain_id: int) -> None:
    code = (
        "import json, os; print(json.dumps({k: os.environ.get(k) for k in "
        "('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', "
        "'ROS_LOCALHOST_ONLY')}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    assert json.loads(out) == {
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": str(ros_domain_id),
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "ROS_LOCALHOST_ONLY": None,
    }
    assert 0 <= ros_domain_id <= 101
