"""The recorder node and a rig publisher as child processes, and waiting for what the recorder flushed."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from bike_rig.bag.recover import scan_mcap
from test.support.processes import RosProcess
from test.support.wait import wait_until

PUBLISHER = Path(__file__).resolve().parents[1] / "bag" / "rig_publisher.py"


def start_publisher(tmp_path: Path, env: dict[str, str], spec: dict[str, Any]) -> RosProcess:
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(spec))
    return RosProcess("publisher", [sys.executable, str(PUBLISHER), str(spec_file)], env, tmp_path, stdin=True)


def start_recorder(tmp_path: Path, env: dict[str, str], bag: Path, *params: str) -> RosProcess:
    argv = [sys.executable, "-m", "bike_rig.ros.nodes.recorder", "--ros-args", "-p", f"output:={bag}"]
    for p in params:
        argv += ["-p", p]
    return RosProcess("recorder", argv, env, tmp_path)


def wait_for_data(bag: Path, expected: dict[str, int], recorder: RosProcess, timeout_s: float = 30.0) -> None:
    """Wait until the recorder's flushed chunks hold the expected number of messages per topic.

    The recorder flushes at least every 0.5 s, so no stop is needed to see them.
    """
    data = bag / f"{bag.name}_0.mcap"
    counts: dict[str, int] = {}

    def recorded() -> bool:
        assert recorder.proc.poll() is None, recorder.describe()
        if not data.exists():
            return False
        scan = scan_mcap(data)
        topic = {cid: ch.topic for cid, ch in scan.channels.items()}
        counts.clear()
        for m in scan.messages:
            counts[topic[m.channel_id]] = counts.get(topic[m.channel_id], 0) + 1
        return all(counts.get(k, 0) >= n for k, n in expected.items())

    wait_until(recorded, f"{expected} recorded", timeout_s, 0.1, lambda: f"recorded {counts}\n{recorder.describe()}")
