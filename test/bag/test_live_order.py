"""The live results a replay compares with are the last ones published, whatever the log times or file list say.

A wall-clock step back (log times going backwards) and a metadata.yaml listing the split files
out of order made ``replay`` compare with a stale parameter set; the live topics are now taken
in publication order (:mod:`bike_rig.bag.order`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from bike_rig.bag import reader as reader_module
from bike_rig.bag.order import publication_order
from bike_rig.bag.simulated import RECORDED_TOPICS, SimulatedMessage, live_results, simulated_messages
from bike_rig.bag.typestore import rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import PARAMETERS, TRIAL_EVENTS
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline.info import summarize
from bike_rig.offline.replay import replay_bag
from bike_rig.offline.session import BY_LOG_TIME, BY_SEQUENCE, BY_STORAGE, LIVE_TOPICS, read_session
from bike_rig.pipeline.acquire import NS_PER_S
from test.support.replay import LIVE_OPTIONS, run_cli
from test.support.samples import as_plain

HOUR = 3600 * NS_PER_S


@pytest.fixture(scope="module")
def stream(session: SimulatedSession) -> list[SimulatedMessage]:
    """The session's input and the live graph's results, in publication (log-time) order."""
    extra = live_results(simulated_messages(session, pause_s=2.0), LIVE_OPTIONS)
    return sorted([*simulated_messages(session, pause_s=2.0), *extra], key=lambda m: m.log_time)


def _start_of(stream: list[SimulatedMessage], k: int) -> int:
    """Where the k-th trial's START event is in the stream."""
    starts = [i for i, m in enumerate(stream) if m.topic == TRIAL_EVENTS.name and m.message.kind == 0]
    return starts[k]


def write_bag(
    path: Path,
    stream: list[SimulatedMessage],
    log_time: Callable[[int, int], int] = lambda i, t: t,
    split_before: tuple[int, ...] = (),
    sequences: bool = True,
) -> Path:
    """The stream as the recorder writes it: in publication order, each with its publisher's sequence.

    ``log_time(i, t)`` is the log time the recorder's clock gives message ``i`` (logged at ``t``);
    a new storage file starts before each message of ``split_before``.
    """
    store = rig_typestore()
    types = {t.name: t.type for t in RECORDED_TOPICS}
    counts = dict.fromkeys(types, 0)
    with BagWriter(path, flush_period_s=3600.0) as w:
        for t in RECORDED_TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for i, m in enumerate(stream):
            if i in split_before:
                w.split()
            counts[m.topic] += 1
            data = bytes(store.serialize_cdr(m.message, types[m.topic]))
            t = log_time(i, m.log_time)
            w.write(m.topic, t, data, publish_time=t, sequence=counts[m.topic] if sequences else 0)
    return path


def _last_set(stream: list[SimulatedMessage]) -> object:
    return as_plain([m.message for m in stream if m.topic == PARAMETERS.name][-1])


def _check_replay_uses_the_last_set(bag: Path, stream: list[SimulatedMessage], order: str) -> None:
    session = read_session(bag)
    assert session.live_order == order
    assert as_plain(session.final_parameters) == _last_set(stream)
    assert session.final_parameters.complete
    result = replay_bag(bag)
    assert result.complete and not result.live.missing
    assert result.live.identical, result.live.worst
    assert summarize(bag).live.complete
    code, out, err = run_cli("replay", str(bag))
    assert (code, err) == (0, "") and "live results: identical" in out


def test_a_clock_step_back_does_not_make_an_earlier_set_the_last(
    stream: list[SimulatedMessage], tmp_path: Path
) -> None:
    step = _start_of(stream, len([m for m in stream if m.topic == TRIAL_EVENTS.name]) // 4)
    bag = write_bag(tmp_path / "stepped", stream, lambda i, t: t - HOUR if i >= step else t)
    with reader_module.open_bag(bag) as b:  # the stale sets are the last by log time
        assert b.end_time == max(m.log_time for m in stream[:step])
    _check_replay_uses_the_last_set(bag, stream, BY_SEQUENCE)


def test_split_files_listed_out_of_order_do_not_make_an_earlier_set_the_last(
    stream: list[SimulatedMessage], tmp_path: Path
) -> None:
    trials = len([m for m in stream if m.topic == TRIAL_EVENTS.name]) // 2
    cuts = (_start_of(stream, trials // 3), _start_of(stream, 2 * trials // 3))
    for sequences, order in ((True, BY_SEQUENCE), (False, BY_STORAGE)):
        bag = write_bag(tmp_path / f"listed_{sequences}", stream, split_before=cuts, sequences=sequences)
        meta_path = bag / "metadata.yaml"
        meta = yaml.safe_load(meta_path.read_text())
        info = meta["rosbag2_bagfile_information"]
        assert len(info["relative_file_paths"]) == 3
        info["relative_file_paths"].reverse()
        info["files"].reverse()
        meta_path.write_text(yaml.safe_dump(meta, sort_keys=False))
        with reader_module.open_bag(bag) as b:  # read in the listed order: the first file's last
            assert b.records(list(b.topics)) is not None
            assert [p.name for p in b.storage_files] == [f"listed_{sequences}_{k}.mcap" for k in (2, 1, 0)]
        _check_replay_uses_the_last_set(bag, stream, order)


def test_the_message_by_message_path_orders_them_the_same(
    stream: list[SimulatedMessage], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    step = _start_of(stream, 3)
    bag = write_bag(tmp_path / "slow", stream, lambda i, t: t - HOUR if i >= step else t)

    # when the mcap library cannot read the bag, rosbags' reader gives it in log-time order and the replay says so
    monkeypatch.setattr(reader_module.BagReader, "records", lambda self, names: None)
    session = read_session(bag)
    assert session.live_order == BY_LOG_TIME and as_plain(session.final_parameters) != _last_set(stream)
    assert any("log-time order" in n for n in replay_bag(bag).notes)


def test_every_live_topic_is_ordered(stream: list[SimulatedMessage], tmp_path: Path) -> None:
    step = _start_of(stream, 5)
    bag = write_bag(tmp_path / "all", stream, lambda i, t: t - HOUR if i >= step else t)
    session = read_session(bag)
    published = {name: as_plain([m.message for m in stream if m.topic == name]) for name in LIVE_TOPICS}
    assert as_plain(session.parameters) == published[PARAMETERS.name]
    assert as_plain(session.matrices) == published["/bike_rig/model/matrices"]
    assert as_plain(session.eigen_sweeps) == published["/bike_rig/model/eigen_sweep"]
    assert as_plain(session.all_static_readings) == published["/bike_rig/static_readings"]
    estimates = sorted((e for t in session.trials.values() for e in t.estimates), key=lambda e: str(e.trial_id))
    assert as_plain(estimates) == sorted(published["/bike_rig/periods"], key=lambda e: e["trial_id"])


def test_publication_order() -> None:
    # one publisher: its sequence, whatever the order of storage
    assert publication_order([1, 3, 2], [0, 1, 2]) == [0, 2, 1]
    # restarted (it counts from 1 again): the later run last, however long the first
    assert publication_order([1, 2, 3, 1, 2], [0, 1, 2, 3, 4]) == [0, 1, 2, 3, 4]
    # the recorder joined late (the first run's latched 40 onwards), then the node restarted
    assert publication_order([40, 41, 42, 1, 2], [0, 1, 2, 3, 4]) == [0, 1, 2, 3, 4]
    # no sequence recorded: the order of storage
    assert publication_order([0, 0, 0], [2, 0, 1]) == [1, 2, 0]
    assert publication_order([], []) == []
