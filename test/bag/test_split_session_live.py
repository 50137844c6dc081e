"""A live session recorded across splits (by size and by a service call) reads as one session.

The simulated session runs through the node processes over DDS (``bike_rig.ros.demo``) with the
recorder splitting its bag at 250 kB and once more when the test calls its ``split_bag``
service mid-session. The split bag is then replayed, summarized and reported as one session:
the replay equals the live results, and equals, number for number, the replay of the same
recording as one storage file (rewritten by ``recover``, which joins the files).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from bike_rig.bag.recover import recover_bag
from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.config.topics import RECORDER_SPLIT
from bike_rig.offline.info import summarize
from bike_rig.offline.replay import replay_bag, result_json
from bike_rig.ros.demo import run_demo
from bike_rig.ros.env import ros_environment
from bike_rig.ros.running import RunningGraph
from test.support.probe import Probe

pytestmark = pytest.mark.ros

srvs: Any = pytest.importorskip("bike_rig_msgs.srv")

MAX_BAG_SIZE = 250_000


def test_a_session_split_by_size_and_by_request_replays_as_the_unsplit_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig = yaml.safe_load(config_file("rig.yaml").read_text())
    rig["trials"]["duration"] = 12  # shorter trials keep the run short (still ≥ 5 cycles of every part)
    rig_file = tmp_path / "rig.yaml"
    rig_file.write_text(yaml.safe_dump(rig))
    state: dict[str, Any] = {}

    def split_once(running: RunningGraph, fitted: int) -> None:
        if fitted < 10 or "split" in state:
            return
        probe = state["probe"] = Probe(ros_environment(domain_id=running.domain_id))
        client = probe.node.create_client(srvs.SplitBag, RECORDER_SPLIT)
        state["split"] = probe.call(client, srvs.SplitBag.Request())

    try:
        live = run_demo(
            tmp_path / "session",
            seed=3,
            time_scale=60.0,
            samples_per_batch=50,
            timeout_s=240,
            progress=lambda _: None,
            rig=rig_file,
            on_progress=split_once,
            recorder={"max_bag_size": MAX_BAG_SIZE},
        )
    finally:
        if "probe" in state:
            state["probe"].close()
    split = state["split"]
    assert split.ok, split.message
    meta = yaml.safe_load((live.bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    files = meta["relative_file_paths"]
    assert len(files) >= 3 and split.closed_file in files[:-1] and split.new_file in files
    sizes = {name: (live.bag / name).stat().st_size for name in files}
    assert all(size <= MAX_BAG_SIZE for size in sizes.values()), (sizes, split)
    log = (tmp_path / "session" / "logs" / "recorder.log").read_text()
    assert "split (limit reached)" in log and f"split: closed {split.closed_file}" in log

    result = replay_bag(live.bag)
    assert result.complete and len(result.trials) == live.trials == 39
    assert result.live.compared_trials == 39 and not result.live.missing
    assert result.live.identical, [d for d in result.live.differences if not d.identical][:5]

    whole = recover_bag(live.bag, tmp_path / "whole")  # the same messages, in one storage file
    assert whole.was_complete and whole.message_count == meta["message_count"]
    assert [name for name, _ in summarize(whole.output).files] == ["whole_0.mcap"]
    assert result_json(replay_bag(whole.output)) == result_json(result)

    summary = summarize(live.bag)  # bag info
    assert [name for name, _ in summary.files] == files
    assert len(summary.trials) == 39 and all(t.usable and t.samples == t.announced for t in summary.trials)
    where = {"path": "", "files": []}

    def heard(d: dict[str, Any]) -> dict[str, Any]:
        # a topic that stayed silent is listed in metadata.yaml only (no MCAP channel): recover cannot see it
        return d | where | {"topics": [t for t in d["topics"] if t["count"]]}

    assert heard(summary.to_dict()) == heard(summarize(whole.output).to_dict())

    for bag, out in ((live.bag, tmp_path / "report_split"), (whole.output, tmp_path / "report_whole")):
        assert main(["report", str(bag), "-o", str(out), "-j", "1"]) == 0
        assert ", 39 trials, in " in capsys.readouterr().err
