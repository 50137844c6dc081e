"""A recorded session, read back from a bag.

Trials (their events and gyro batches), static readings (the parameter node's latest, and
every reading entered during the session), and the live results (period estimates with the
fitter's ``FitDetails``, parameter set, model) the graph published.

Messages are the dataclasses rosbags deserializes into (:mod:`bike_rig.bag.typestore`), with
the same fields as the rclpy messages, so the nodes' ROS-free functions take them as they are;
each topic is decoded with its type's definition in the bag (:mod:`bike_rig.bag.schemas`).
Gyro batches are kept per trial in the order they were received (log time). The live graph's
results and static readings (period estimates, parameter sets, model, ``StaticReadings``) are
kept in the order their publishers published them (:mod:`bike_rig.bag.order`), so the last of
each is the live graph's last, whatever the recorder's clock did.

An MCAP bag's messages are read with the ``mcap`` library
(:meth:`bike_rig.bag.reader.BagReader.records`), its gyro batches decoded straight from their
CDR bytes (:mod:`bike_rig.bag.gyro_cdr`, when the bag's GyroBatch is the installed one) and
the other messages by rosbags; any other bag is read with rosbags' reader.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..bag.errors import BagReadError, NoRigTopicsError, ReplayError
from ..bag.gyro_cdr import gyro_batch, gyro_columns
from ..bag.order import publication_order
from ..bag.reader import BagReader, Record, TopicInfo
from ..config import topics
from ..messages import MessageError, sample_batch_from_msg, trial_event_from_msg
from ..pipeline.acquire import SampleBatch, SampleBlock, TrialEventKind, TrialEventRecord

__all__ = ["LIVE_TOPICS", "RecordedSession", "RecordedTrial", "read_session"]

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

#: The topics whose messages are kept in publication order (one publisher at a time each).
LIVE_TOPICS = (
    topics.STATIC_READINGS.name,
    topics.PERIODS.name,
    topics.PARAMETERS.name,
    topics.MATRICES.name,
    topics.EIGEN_SWEEP.name,
)

#: :attr:`RecordedSession.live_order` when the publication sequence numbers ordered the live results.
BY_SEQUENCE = "publication sequence"
#: ... when the bag records no sequence: the recorder's order of storage.
BY_STORAGE = "order of storage"
#: ... when neither could be read (rosbags' order: the log time).
BY_LOG_TIME = "log time"


class _Keyed(NamedTuple):
    """A live-topic message with its publication sequence and its rank in the order of storage."""

    topic: str
    message: Any
    sequence: int
    stream: int


@dataclass
class RecordedTrial:
    """One trial as recorded.

    Attributes:
        trial_id: The trial's id.
        start: Its START event, or None.
        stop: Its first STOP or ABORT event, or None.
        batches: Its gyro batches, in receiving order (duplicates included).
        estimates: The PeriodEstimate messages published for it, in publication order.
    """

    trial_id: str
    start: TrialEventRecord | None = None
    stop: TrialEventRecord | None = None
    batches: list[SampleBatch] | SampleBlock = field(default_factory=list)
    estimates: list[Any] = field(default_factory=list)

    @property
    def event(self) -> TrialEventRecord | None:
        """The START event, else the STOP/ABORT (what describes the trial)."""
        return self.start if self.start is not None else self.stop

    @property
    def measurement_key(self) -> str:
        """The measurement the trial contributes to ("" when no event and no estimate says)."""
        if self.event is not None:
            return str(self.event.measurement_key)
        return str(self.estimates[-1].measurement_key) if self.estimates else ""

    @property
    def state(self) -> str:
        """The trial's state.

        ``complete`` (START and STOP), ``aborted``, ``open`` (no STOP recorded), ``no start``
        (a STOP without START) or ``unannounced`` (batches without events).
        """
        if self.stop is not None and self.stop.kind is TrialEventKind.ABORT:
            return "aborted"
        if self.start is not None:
            return "complete" if self.stop is not None else "open"
        return "no start" if self.stop is not None else "unannounced"

    @property
    def samples(self) -> int:
        """Samples recorded (batches with the same first index counted once)."""
        seen: dict[int, int] = {}
        for b in self.batches:
            seen.setdefault(int(b.first_index), len(b.rates))
        return sum(seen.values())

    @property
    def duplicates(self) -> int:
        """Batches recorded again with a first index seen before."""
        return len(self.batches) - len({int(b.first_index) for b in self.batches})

    @property
    def announced(self) -> int | None:
        """Samples the driver announced on STOP/ABORT (None without one)."""
        return None if self.stop is None else int(self.stop.sample_count)

    @property
    def sample_rate_hz(self) -> float:
        """The trial's sample rate, Hz (from its events, else its batches; NaN if unknown)."""
        if self.event is not None and float(self.event.sample_rate_hz) > 0:
            return float(self.event.sample_rate_hz)
        return float(self.batches[0].sample_rate_hz) if self.batches else float("nan")

    @property
    def estimate(self) -> Any | None:
        """The last PeriodEstimate published for it (the one consumers keep), or None."""
        return self.estimates[-1] if self.estimates else None


@dataclass
class RecordedSession:
    """Everything a bag holds of a session.

    Attributes:
        path: The bag, as given.
        topics: Every topic of the bag.
        start_time: Log time of the first message, ns.
        end_time: Log time of the last message, ns.
        message_count: Messages in the bag.
        storage_files: The bag's storage files.
        trials: The trials by id, in the order they were first heard of.
        static_readings: The last StaticReadings message published, or None (the parameter
            node's: the measurement file's readings with every entered reading applied).
        reading_entries: Every ReadingEntry message (readings entered during the session,
            corrections too), in the order received.
        parameters: Every BenchmarkParameters message, in publication order.
        matrices: Every CanonicalMatrices message, in publication order.
        eigen_sweeps: Every EigenSweep message, in publication order.
        stray_batches: Gyro batches outside any trial (empty trial id).
        all_static_readings: Every StaticReadings message, in publication order.
        fit_details: The last FitDetails message of each trial (log time), by trial id.
        notes: What of the bag was not read, and why (e.g. FitDetails of a definition bike_rig
            cannot read: the estimates are read without them).
        live_order: What ordered the live topics' messages (:data:`BY_SEQUENCE`,
            :data:`BY_STORAGE` or :data:`BY_LOG_TIME`; see :mod:`bike_rig.bag.order`).
    """

    path: str
    topics: dict[str, TopicInfo]
    start_time: int
    end_time: int
    message_count: int
    storage_files: list[Path]
    trials: dict[str, RecordedTrial] = field(default_factory=dict)
    static_readings: Any | None = None
    reading_entries: list[Any] = field(default_factory=list)
    parameters: list[Any] = field(default_factory=list)
    matrices: list[Any] = field(default_factory=list)
    eigen_sweeps: list[Any] = field(default_factory=list)
    stray_batches: int = 0
    all_static_readings: list[Any] = field(default_factory=list)
    fit_details: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    live_order: str = BY_STORAGE

    @property
    def duration(self) -> int:
        """From the first to the last message, ns."""
        return self.end_time - self.start_time

    @property
    def bicycle(self) -> str:
        """The bicycle's name, from the static readings or the parameter sets ("" if none)."""
        for msg in [self.static_readings, *reversed(self.parameters), *reversed(self.matrices)]:
            if msg is not None and str(msg.bicycle):
                return str(msg.bicycle)
        return ""

    @property
    def final_parameters(self) -> Any | None:
        """The last BenchmarkParameters message, or None."""
        return self.parameters[-1] if self.parameters else None

    @property
    def final_matrices(self) -> Any | None:
        """The last CanonicalMatrices message, or None."""
        return self.matrices[-1] if self.matrices else None

    @property
    def final_eigen_sweep(self) -> Any | None:
        """The last EigenSweep message, or None."""
        return self.eigen_sweeps[-1] if self.eigen_sweeps else None

    def trial(self, trial_id: str) -> RecordedTrial:
        """The trial with this id (created empty when first heard of)."""
        t = self.trials.get(trial_id)
        if t is None:
            t = self.trials[trial_id] = RecordedTrial(trial_id)
        return t


def _add_batch(session: RecordedSession, batch: SampleBatch) -> None:
    if batch.trial_id:
        t = session.trial(batch.trial_id)
        if not isinstance(t.batches, list):
            t.batches = list(t.batches)
        t.batches.append(batch)
    else:
        session.stray_batches += 1


def _add_event(session: RecordedSession, msg: Any) -> None:
    t = session.trial(str(msg.trial_id))
    try:
        event = trial_event_from_msg(msg)
    except MessageError:
        return  # an unknown kind: neither starts nor ends the trial
    if event.kind is TrialEventKind.START:
        if t.start is None:
            t.start = event
    elif t.stop is None:
        t.stop = event


def _add(session: RecordedSession, topic: str, msg: Any) -> None:
    if topic == topics.GYRO.name:
        _add_batch(session, sample_batch_from_msg(msg))
    elif topic == topics.TRIAL_EVENTS.name:
        _add_event(session, msg)
    elif topic == topics.PERIODS.name:
        session.trial(str(msg.trial_id)).estimates.append(msg)
    elif topic == topics.STATIC_READINGS.name:
        session.static_readings = msg
        session.all_static_readings.append(msg)
    elif topic == topics.READINGS.name:
        session.reading_entries.append(msg)
    elif topic == topics.PARAMETERS.name:
        session.parameters.append(msg)
    elif topic == topics.MATRICES.name:
        session.matrices.append(msg)
    elif topic == topics.EIGEN_SWEEP.name:
        session.eigen_sweeps.append(msg)
    elif topic == topics.FIT_DETAILS.name:
        session.fit_details[str(msg.trial_id)] = msg


def read_session(path: str | Path, which: Iterable[str] | None = None) -> RecordedSession:
    """Read a session from a bag.

    Args:
        path: The bag (directory, metadata.yaml or .mcap file).
        which: The rig topics to read (all of them if None).

    Raises:
        BagError: The bag cannot be read (see :func:`bike_rig.bag.reader.open_bag`).
        NoRigTopicsError: It holds none of the rig's topics.
        ReplayError: A rig topic's type is not bike_rig's, or its definition in the bag lacks
            what bike_rig reads.
    """
    with BagReader(path) as bag:
        rig = [t.name for t in topics.TOPICS if t.name in bag.topics]
        if not rig:
            names = ", ".join(t.name for t in topics.TOPICS)
            found = ", ".join(sorted(bag.topics)) or "no topics at all"
            raise NoRigTopicsError(bag.shown, f"holds none of bike_rig's topics ({names}); it has {found}")
        empty = RecordedSession(
            bag.shown, dict(bag.topics), bag.start_time, bag.end_time, bag.message_count, bag.storage_files
        )
        if topics.FIT_DETAILS.name in bag.topics:
            rig.append(topics.FIT_DETAILS.name)
        wanted = rig if which is None else [t for t in rig if t in set(which)]
        notes = _details_readable(bag, wanted)
        empty.notes += notes
        for t in wanted:
            bag.decoding(t)
        records = bag.records(wanted)
        keyed: list[_Keyed] | None
        if records is not None:
            session, keyed = empty, _from_records(empty, records, bag)
            for trial in session.trials.values():
                if isinstance(trial.batches, list) and trial.batches:
                    trial.batches = _block(trial.trial_id, trial.batches)
        else:
            session = empty
            for topic, _, msg in bag.decoded(wanted):
                _add(session, topic, msg)
            keyed = _stamped_live(bag, [t for t in wanted if t in LIVE_TOPICS])
        if keyed is not None:
            _order_live(session, keyed)
        else:
            session.live_order = BY_LOG_TIME
    return session


def _details_readable(bag: BagReader, wanted: list[str]) -> list[str]:
    """Leave the FitDetails topic out of ``wanted`` when its definition cannot be read, and say so.

    The estimates carry what the parameters need; the details only add to them.
    """
    name = topics.FIT_DETAILS.name
    if name not in wanted:
        return []
    try:
        bag.decoding(name)
    except ReplayError as exc:
        wanted.remove(name)
        return [f"the fit details on {name} were not read ({exc.reason})"]
    return []


def _stamped_live(bag: BagReader, live: list[str]) -> list[_Keyed] | None:
    """The live topics' messages with their sequence and rank in storage, read again (None: not readable)."""
    stamped = bag.stamped(live) if live else []
    if stamped is None:
        return None
    out = []
    for m in stamped:
        try:
            msg = bag.decoding(m.topic).store.deserialize_cdr(m.data, bag.topics[m.topic].msgtype)
        except Exception as exc:  # rosbags raises several kinds for bad CDR
            reason = f"a {bag.topics[m.topic].msgtype} message on {m.topic} does not deserialize ({exc})"
            raise BagReadError(bag.shown, reason) from None
        out.append(_Keyed(m.topic, msg, m.sequence, m.stream))
    return out


def _order_live(session: RecordedSession, keyed: list[_Keyed]) -> None:
    """Put the live topics' messages in publication order (:func:`bike_rig.bag.order.publication_order`)."""
    ordered: dict[str, list[Any]] = {}
    by_sequence = False
    for topic in LIVE_TOPICS:
        items = [k for k in keyed if k.topic == topic]
        order = publication_order([k.sequence for k in items], [k.stream for k in items])
        ordered[topic] = [items[i].message for i in order]
        by_sequence |= bool(items) and all(k.sequence > 0 for k in items)
    session.live_order = BY_SEQUENCE if by_sequence else BY_STORAGE
    session.parameters = ordered[topics.PARAMETERS.name]
    session.matrices = ordered[topics.MATRICES.name]
    session.eigen_sweeps = ordered[topics.EIGEN_SWEEP.name]
    session.all_static_readings = ordered[topics.STATIC_READINGS.name]
    session.static_readings = session.all_static_readings[-1] if session.all_static_readings else None
    for t in session.trials.values():
        t.estimates = []
    for msg in ordered[topics.PERIODS.name]:
        session.trial(str(msg.trial_id)).estimates.append(msg)


def _block(trial_id: str, batches: Sequence[SampleBatch]) -> SampleBlock:
    """A trial's batches as one block of columns (what the fitting stage takes at once)."""
    bounds = np.zeros(len(batches) + 1, dtype=np.int64)
    np.cumsum([len(b.rates) for b in batches], out=bounds[1:])
    volt_bounds = np.zeros(len(batches) + 1, dtype=np.int64)
    np.cumsum([len(b.raw_volts) for b in batches], out=volt_bounds[1:])
    frame_ids = tuple(dict.fromkeys(b.frame_id for b in batches))
    code = {f: i for i, f in enumerate(frame_ids)}

    def volts() -> tuple[IntArray, FloatArray]:
        return volt_bounds, np.concatenate([b.raw_volts for b in batches])

    return SampleBlock(
        trial_id,
        np.array([b.first_index for b in batches], dtype=np.int64),
        np.array([b.sample_rate_hz for b in batches], dtype=np.float64),
        bounds,
        np.concatenate([b.rates for b in batches]),
        volts,
        np.array([b.stamp_ns for b in batches], dtype=np.int64),
        frame_ids,
        np.array([code[b.frame_id] for b in batches], dtype=np.int64),
    )


def _from_records(session: RecordedSession, records: list[Record], bag: BagReader) -> list[_Keyed]:
    """Add the messages to the session, as :func:`_add` on each decoded message does.

    Returns:
        The live topics' messages with their sequence and rank in storage.

    Raises:
        BagReadError: A message does not deserialize.
    """
    gyro = topics.GYRO.name
    ours = gyro in bag.topics and bag.decoding(gyro).installed
    at = [k for k, r in enumerate(records) if r.topic == gyro] if ours else []
    columns = gyro_columns([records[k].data for k in at]) if at else None
    blocks: list[tuple[int, str, SampleBlock]] = []
    if columns is not None:  # every trial's batches at once, the trial made where its first one is
        blocks = sorted(zip([at[k] for k in columns.first], columns.trial_ids, columns.blocks, strict=True))
    keyed = []
    for k, r in enumerate(records):
        while blocks and blocks[0][0] <= k:
            _add_block(session, *blocks.pop(0)[1:])
        if columns is not None and r.topic == gyro:
            continue
        batch = gyro_batch(r.data) if ours and r.topic == gyro else None
        if batch is not None:
            _add_batch(session, batch)
            continue
        msgtype = bag.topics[r.topic].msgtype
        try:
            msg = bag.decoding(r.topic).store.deserialize_cdr(r.data, msgtype)
        except Exception as exc:  # rosbags raises several kinds for bad CDR
            raise BagReadError(bag.shown, f"a {msgtype} message on {r.topic} does not deserialize ({exc})") from None
        _add(session, r.topic, msg)
        if r.topic in LIVE_TOPICS:
            keyed.append(_Keyed(r.topic, msg, r.sequence, r.stream))
    return keyed


def _add_block(session: RecordedSession, trial_id: str, block: SampleBlock) -> None:
    """Add a trial's batches at once, as :func:`_add_batch` on each."""
    if trial_id:
        session.trial(trial_id).batches = block
    else:
        session.stray_batches += len(block)
