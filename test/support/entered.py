"""Sessions whose static readings are entered as they are measured, for the replay and node tests.

:func:`entries_bag` writes, without ROS, what the rig records when the parameter node starts
from the bicycle's name alone: its first (empty) ``StaticReadings``, each ``ReadingEntry``
followed by the merged ``StaticReadings`` the node re-publishes
(:func:`bike_rig.pipeline.readings.apply_entries`), and the trials.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from bike_rig.bag.simulated import SimulatedMessage, simulated_messages
from bike_rig.bag.typestore import new_message, rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config import topics
from bike_rig.config.paths import config_file
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.measurements import Measurements
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.messages import fill_reading_entry, fill_static_readings, set_stamp
from bike_rig.pipeline.readings import ReadingEntry, apply_entries

#: A reading entered wrongly (grams for kilograms) and corrected later.
MISTAKE_KEY = "mR"


def one_trial_session(seed: int = 11, duration_s: float = 12.0) -> SimulatedSession:
    """The Browser on the paper's rig: one 12 s trial per period (13 trials), no beating."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    rig = load_rig(config_file("rig.yaml"))
    trials = dataclasses.replace(rig.trials, durations=(duration_s,), per_measurement=1)
    rig = dataclasses.replace(rig, trials=trials, coupled_swing=None)
    return simulate_session(truth, rig, seed=seed, bicycle=name)


def session_static(session: SimulatedSession) -> Measurements:
    """The session's static readings (what the operator measures)."""
    return Measurements(session.bicycle, dict(session.readings), session.label)


def operator_entries(session: SimulatedSession, stamp0_ns: int, skip: Sequence[str] = ()) -> list[ReadingEntry]:
    """Every static reading as the operator enters it, one per second of wall time.

    The rear wheel's mass is first entered in grams and corrected at the end (``note``
    ``"correction"``); ``skip`` leaves readings out.
    """
    out = []
    t = stamp0_ns
    for key, r in session.readings.items():
        if key in skip:
            continue
        value = r.value * 1000.0 if key == MISTAKE_KEY else r.value
        out.append(ReadingEntry(key, value, r.sigma, t))
        t += 1_000_000_000
    if MISTAKE_KEY not in skip:
        r = session.readings[MISTAKE_KEY]
        out.append(ReadingEntry(MISTAKE_KEY, r.value, r.sigma, t, "correction"))
    return out


def _published(topic: topics.Topic, msg: object, log_time: int) -> SimulatedMessage:
    return SimulatedMessage(topic.name, log_time, msg)


def node_messages(base: Measurements, entries: Sequence[ReadingEntry]) -> list[SimulatedMessage]:
    """What the parameter node and the console publish for the entries, logged at their stamps.

    The first StaticReadings (``base``), then per entry the ``ReadingEntry`` and 1 ms later the
    merged ``StaticReadings``.
    """
    first = fill_static_readings(new_message(topics.STATIC_READINGS.type), base, dump_measurements_yaml(base))
    first.source = "no static readings yet"
    t0 = entries[0].stamp_ns - 1_000_000 if entries else 0
    set_stamp(first, t0)
    out = [_published(topics.STATIC_READINGS, first, t0)]
    for n, entry in enumerate(entries, start=1):
        out.append(
            _published(topics.READINGS, fill_reading_entry(new_message(topics.READINGS.type), entry), entry.stamp_ns)
        )
        merged = apply_entries(base, entries[:n])
        msg = fill_static_readings(new_message(topics.STATIC_READINGS.type), merged, dump_measurements_yaml(merged))
        set_stamp(msg, entry.stamp_ns + 1_000_000)
        out.append(_published(topics.STATIC_READINGS, msg, entry.stamp_ns + 1_000_000))
    return out


def entries_bag(path: Path, session: SimulatedSession, skip: Sequence[str] = ()) -> tuple[Path, list[ReadingEntry]]:
    """A bag of ``session`` whose static readings were all entered before the trials (see the module docstring).

    Returns:
        The bag and the entries, in the order published.
    """
    start_ns = 1_800_000_000 * 1_000_000_000
    trials = [
        m for m in simulated_messages(session, start_ns=start_ns, pause_s=2.0) if m.topic != topics.STATIC_READINGS.name
    ]
    entries = operator_entries(session, start_ns - 100 * 1_000_000_000, skip)
    messages = sorted(
        [*node_messages(Measurements(session.bicycle, {}, ""), entries), *trials], key=lambda m: m.log_time
    )
    return write_messages(path, messages), entries


def write_messages(path: Path, messages: list[SimulatedMessage]) -> Path:
    """A bag of every rig topic (the contract QoS) holding ``messages``, in their order."""
    store = rig_typestore()
    types = {t.name: t.type for t in topics.TOPICS}
    with BagWriter(path) as w:
        for t in topics.TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for m in messages:
            w.write(m.topic, m.log_time, bytes(store.serialize_cdr(m.message, types[m.topic])))
    return path
