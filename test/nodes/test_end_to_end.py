"""The rig as a live graph.

A whole simulated session through the real node processes over DDS (localhost, the run's own
domain id), recorded, and read back.

One session with the paper's shorter trials (15 s instead of 30 s, no beating) keeps the run short; everything
else is the shipped configuration (``config/graph.yaml``, the node parameter files).
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader

from bike_rig.bag.typestore import rig_typestore
from bike_rig.config.paths import config_file
from bike_rig.config.topics import READINGS
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.trials import read_trial
from bike_rig.pipeline.resend import batch_samples
from bike_rig.ros.demo import DemoResult, run_demo
from bike_rig.ros.nodes.recorder import RECORDED

pytestmark = pytest.mark.ros  # a whole graph of node processes (run_demo)

BATCH = 50
TIME_SCALE = 50.0


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> tuple[DemoResult, Path]:
    tmp = tmp_path_factory.mktemp("e2e")
    rig = yaml.safe_load(config_file("rig.yaml").read_text())
    rig["trials"]["duration"] = 15  # the paper's shorter trials (≥ 4 cycles of every part)
    rig.pop("coupled_swing", None)
    rig_file = tmp / "short_rig.yaml"
    rig_file.write_text(yaml.safe_dump(rig))
    out = tmp / "session"
    lines: list[str] = []
    result = run_demo(
        out, seed=5, time_scale=TIME_SCALE, samples_per_batch=BATCH, timeout_s=240, progress=lines.append, rig=rig_file
    )
    return result, out


def test_every_trial_is_fitted_live(live: tuple[DemoResult, Path]) -> None:
    result, _ = live
    assert result.trials == 39 and result.periods == 39
    assert result.invalid == {}


def test_live_parameters_equal_the_offline_core(live: tuple[DemoResult, Path]) -> None:
    """The graph's parameters equal the core's on the same session's trial files."""
    result, out = live
    offline = compute_parameters(load_measurements(out / "session" / "session.yaml")).parameters
    ps = result.session.parameters
    assert ps is not None
    for name in PARAMETER_NAMES:
        assert ps.parameters.value(name) == pytest.approx(offline.value(name), rel=1e-12, abs=0), name
        assert ps.parameters.sigma(name) == pytest.approx(offline.sigma(name), rel=1e-9), name
    st = result.stability
    assert st.weave is not None and st.capsize is not None
    assert 3.5 < st.weave.speed < 5.5 and st.weave.sigma > 0


def _expected_counts(out: Path) -> tuple[Counter[str], int]:
    trials = sorted((out / "session" / "trials").glob("*.npy"))
    samples = [read_trial(t).samples.size for t in trials]
    counts: Counter[str] = Counter()
    size = batch_samples(BATCH, TIME_SCALE)  # (the driver's batches grow with the time scale)
    counts["/bike_rig/gyro"] = sum(math.ceil(n / size) for n in samples)
    counts["/bike_rig/trial_events"] = 2 * len(trials)
    counts["/bike_rig/periods"] = len(trials)
    counts["/bike_rig/static_readings"] = 1
    return counts, sum(samples)


def test_the_bag_holds_everything_published(live: tuple[DemoResult, Path]) -> None:
    """Rosbags and mcap's own reader both read the bag.

    Profile ros2, every topic, the counts published, and every sample (no loss).
    """
    result, out = live
    expected, total_samples = _expected_counts(out)
    ts = rig_typestore()
    info = yaml.safe_load((result.bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["storage_identifier"] == "mcap" and info["version"] == 9
    with Reader(result.bag) as reader:
        counts = Counter(c.topic for c, _, _ in reader.messages())
        samples = 0
        gyro = [c for c in reader.connections if c.topic == "/bike_rig/gyro"]
        for conn, _, raw in reader.messages(connections=gyro):
            samples += len(ts.deserialize_cdr(raw, conn.msgtype).rates)
    # every topic the recorder's 'all' names (the fitter's details and /diagnostics too) but the
    # readings an operator enters in a console session (the demo has none)
    assert {t.name for t in RECORDED if t is not READINGS} == set(counts)
    for topic, n in expected.items():
        assert counts[topic] == n, topic
    assert counts["/bike_rig/parameters"] >= 1 and counts["/bike_rig/model/eigen_sweep"] >= 1
    assert samples == total_samples
    (mcap_file,) = sorted(result.bag.glob("*.mcap"))
    with mcap_file.open("rb") as f:
        reader2 = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader2.get_header().profile == "ros2"
        summary = reader2.get_summary()
        assert summary is not None
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        decoded = Counter(ch.topic for _, ch, _, _ in reader2.iter_decoded_messages())
    assert decoded == counts


def test_every_period_saw_all_its_samples(live: tuple[DemoResult, Path]) -> None:
    result, _ = live
    ts = rig_typestore()
    with Reader(result.bag) as reader:
        conns = [c for c in reader.connections if c.topic == "/bike_rig/periods"]
        estimates = [ts.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    assert len(estimates) == 39
    for e in estimates:
        assert e.n_samples == e.n_expected == 15000, e.trial_id
        assert e.valid and list(e.flags) == []
    assert np.all(np.isfinite([e.period for e in estimates]))


def test_offline_replay_is_identical_to_the_live_run(live: tuple[DemoResult, Path]) -> None:
    """``bike-rig replay`` recomputes the session from the bag with no ROS runtime.

    It gets exactly what the live graph published (same fit settings: recorded in the bag).
    """
    from bike_rig.offline.replay import compare_with_live, replay_bag
    from bike_rig.offline.session import read_session

    result, _ = live
    replayed = replay_bag(result.bag)
    comparison = compare_with_live(replayed, read_session(result.bag))
    assert comparison.compared_trials == 39 and comparison.missing == ()
    assert comparison.identical, comparison.worst
    ps, live_ps = replayed.session.parameters, result.session.parameters
    assert ps is not None and live_ps is not None
    for name in PARAMETER_NAMES:
        assert ps.parameters.value(name) == live_ps.parameters.value(name), name
