"""A bag recorded with another definition of a type is read with its own schema, or refused in one line.

A GyroBatch whose fields come in another order (the bag's MCAP schema says so, and its CDR
follows it) had been decoded with the installed definition: every trial empty, no word.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from bike_rig.bag.errors import ReplayError
from bike_rig.bag.reader import open_bag
from bike_rig.bag.simulated import SimulatedMessage, simulated_messages
from bike_rig.bag.typestore import message_definition, rig_typestore, type_hash
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, TOPICS
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline import session as session_module
from bike_rig.offline.replay import replay_bag
from bike_rig.offline.session import read_session
from test.support.cli import run_cli

#: GyroBatch's fields in another order than the installed .msg file's (same names and types).
REORDERED = """float64[] raw_volts
uint64 first_index
std_msgs/Header header
float64[] rates
string trial_id
float64 sample_rate_hz
"""


def gyro_definition(fields: str) -> str:
    """A GyroBatch schema text with these fields, and the installed Header and Time after them."""
    installed = message_definition(GYRO.type)
    return fields + installed[installed.index("=" * 80) :]


def store_of(definition: str) -> Any:
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(definition, GYRO.type))
    return store


def _as(store: Any, msg: Any, msgtype: str) -> Any:
    """``msg`` as a message of ``store`` (same field names; nested messages too)."""
    _, fields = store.fielddefs[msgtype]
    values = {}
    for name, (nodetype, spec) in fields:
        value = getattr(msg, name)
        if nodetype == 2:
            value = _as(store, value, spec)
        elif nodetype == 4 and spec[0][1][0] == "float32":
            value = np.asarray(value, dtype=np.float32)
        values[name] = value
    return store.types[msgtype](**values)


def write_bag(path: Path, session: SimulatedSession, definition: str | None, recorded_hash: str | None) -> Path:
    """The session's stream, its gyro batches serialized to ``definition`` (None: the installed one)."""
    rig = rig_typestore()
    store = store_of(definition) if definition is not None else rig
    messages: list[SimulatedMessage] = sorted(simulated_messages(session, pause_s=2.0), key=lambda m: m.log_time)
    types = {t.name: t.type for t in TOPICS}
    with BagWriter(path, flush_period_s=3600.0) as w:
        for t in TOPICS:
            mine = t is GYRO and definition is not None
            w.add_topic(
                t.name,
                t.type,
                offered_qos=[contract_qos(t.qos)],
                msgdef=definition if mine else None,
                rihs01=recorded_hash if mine else None,
            )
        for k, m in enumerate(messages):
            if m.topic == GYRO.name:
                data = store.serialize_cdr(_as(store, m.message, GYRO.type), GYRO.type)
            else:
                data = rig.serialize_cdr(m.message, types[m.topic])
            w.write(m.topic, m.log_time, bytes(data), sequence=k + 1)
    return path


@pytest.fixture(scope="module")
def installed_bag(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(tmp_path_factory.mktemp("schemas") / "installed", session, None, None)


def _samples(bag: Path) -> dict[str, list[float]]:
    return {
        tid: [float(x) for b in t.batches for x in np.asarray(b.rates)] for tid, t in read_session(bag).trials.items()
    }


@pytest.mark.parametrize("recorded", ["bag", "installed", "none"])
def test_a_gyro_batch_with_its_fields_in_another_order_is_read_with_the_bags_schema(
    session: SimulatedSession, installed_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, recorded: str
) -> None:
    """Whatever type hash metadata.yaml records (the bag's, the installed one's, none: a bare .mcap)."""
    definition = gyro_definition(REORDERED)
    bag_hash = store_of(definition).hash_rihs01(GYRO.type)
    assert bag_hash != type_hash(GYRO.type)
    recorded_hash = {"bag": bag_hash, "installed": type_hash(GYRO.type), "none": ""}[recorded]
    bag = write_bag(tmp_path / "reordered", session, definition, recorded_hash)
    path = bag / "reordered_0.mcap" if recorded == "none" else bag
    fast_calls: list[int] = []
    for name in ("gyro_batch", "gyro_columns"):
        real = getattr(session_module, name)

        def spy(data: Any, real: Any = real) -> Any:
            fast_calls.append(len(data))
            return real(data)

        monkeypatch.setattr(session_module, name, spy)
    with open_bag(path) as b:
        decoding = b.decoding(GYRO.name)
        assert not decoding.installed and decoding.bag_hash == bag_hash
        with pytest.raises(ReplayError, match="another definition than the installed one"):
            b.check_type(GYRO.name)  # its bytes cannot be republished as they are
    got = _samples(path)
    assert not any(fast_calls)  # the fast decoder reads the installed layout only
    expected = {t.name: [float(x) for x in t.rate] for t in session.trials}
    assert got == expected
    result = replay_bag(path)
    assert result.complete
    assert [r.result.n_samples for r in result.trials] == [t.rate.size for t in session.trials]
    baseline = replay_bag(installed_bag)
    assert [r.result.fit.period for r in result.trials] == [r.result.fit.period for r in baseline.trials]
    assert result.parameters is not None and baseline.parameters is not None
    assert list(result.parameters.parameters.values) == list(baseline.parameters.parameters.values)


def test_the_installed_definition_keeps_the_fast_decoder(installed_bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast_calls: list[Any] = []
    real = session_module.gyro_columns

    def spy(datas: list[bytes]) -> Any:
        fast_calls.append(real(datas))
        return fast_calls[-1]

    monkeypatch.setattr(session_module, "gyro_columns", spy)
    with open_bag(installed_bag) as b:
        assert b.decoding(GYRO.name).installed and b.check_type(GYRO.name) == GYRO.type
    session = read_session(installed_bag)
    assert len(fast_calls) == 1 and fast_calls[0] is not None  # every batch by the numpy decoder
    assert sum(len(t.batches) for t in session.trials.values()) == sum(len(b) for b in fast_calls[0].blocks)


@pytest.mark.parametrize(
    ("fields", "reason"),
    [
        (REORDERED.replace("float64[] raw_volts\n", ""), "bike_rig_msgs/GyroBatch has no field raw_volts"),
        (
            REORDERED.replace("float64[] rates", "float32[] rates"),
            "bike_rig_msgs/GyroBatch.rates is float32[], here float64[]",
        ),
    ],
)
def test_a_definition_without_what_bike_rig_reads_is_refused_in_one_line(
    session: SimulatedSession, tmp_path: Path, fields: str, reason: str
) -> None:
    definition = gyro_definition(fields)
    bag = write_bag(tmp_path / "other", session, definition, store_of(definition).hash_rihs01(GYRO.type))
    with pytest.raises(ReplayError) as caught:
        read_session(bag)
    message = str(caught.value)
    assert reason in message and GYRO.type in message
    assert message.count("RIHS01_") == 2  # the bag's definition's hash and the installed one's
    for command in (("replay", str(bag)), ("bag", "info", str(bag))):
        code, out, err = run_cli(*command)
        assert code == 2 and out == "" and err.count("\n") == 1 and reason in err, err


def test_a_schema_rosbags_cannot_parse_is_refused_with_its_text_hash(session: SimulatedSession, tmp_path: Path) -> None:
    rig = rig_typestore()
    bag = tmp_path / "garbled"
    with BagWriter(bag) as w:
        w.add_topic(GYRO.name, GYRO.type, msgdef="float64[ rates\n", rihs01="")
        batch = next(m for m in simulated_messages(session) if m.topic == GYRO.name)
        w.write(GYRO.name, batch.log_time, bytes(rig.serialize_cdr(batch.message, GYRO.type)))
    with pytest.raises(ReplayError, match=r"definition of bike_rig_msgs/msg/GyroBatch cannot be read .*sha256:"):
        read_session(bag / "garbled_0.mcap")
