"""A recorded session replayed as a gyro source.

The ``/bike_rig/gyro`` and ``/bike_rig/trial_events`` messages of a rosbag2 bag (MCAP or
SQLite, read with rosbags and :func:`bike_rig.bag.typestore.rig_typestore`; no ROS runtime) are
replayed in recorded order, paced by their log times and ``time_scale``. Stamps, trial ids, keys
and STOP's announced ``sample_count`` pass unchanged (a loss stays visible); batches of a trial
whose START is not in the bag, or outside any trial, are skipped and counted.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..bag.typestore import rig_typestore
from ..config.settings import ParamSpec
from ..config.topics import GYRO, TRIAL_EVENTS
from ..messages.fields import record_fields, stamp_ns
from .base import (
    TIME_SCALE,
    GyroSource,
    Parameters,
    RigClock,
    SampleBlock,
    SourceEvent,
    TrialInfo,
    TrialStarted,
    TrialStopped,
)
from .errors import SourceConfigError, SourceIOError

__all__ = ["BagSource"]

_log = logging.getLogger(__name__)

_START, _STOP, _ABORT = 0, 1, 2


class BagSource(GyroSource):
    """Replays a bag's gyro batches and trial events (see the module docstring).

    Args:
        path: The bag (its directory, or a single ``.mcap`` file).
        clock: Paces the replay (``time_scale``; ``math.inf``: no pacing).
        gyro_topic: Topic of the batches.
        events_topic: Topic of the trial events.

    Raises:
        SourceConfigError: No such bag, unreadable, or without the two topics.
    """

    name = "bag"
    PARAMETERS = (
        ParamSpec("bag", "", "bag: the recorded bag to replay (rosbag2 directory or .mcap file)"),
        TIME_SCALE,
    )

    def __init__(
        self,
        path: str | Path,
        clock: RigClock | None = None,
        gyro_topic: str = GYRO.name,
        events_topic: str = TRIAL_EVENTS.name,
    ):
        """Open the bag and check that it holds both topics with the rig's message types."""
        from rosbags.rosbag2 import Reader

        self.path = str(path)
        self.clock = clock or RigClock()
        if not Path(path).exists():
            raise SourceConfigError("bag", "bag", "no such bag (a rosbag2 directory or .mcap file)", self.path)
        try:
            self._reader = Reader(Path(path))
            self._reader.open()
        except Exception as exc:  # rosbags raises several kinds; all mean "unreadable"
            raise SourceConfigError("bag", "bag", f"cannot be read as a rosbag2 bag: {exc}", self.path) from None
        wanted = {gyro_topic: GYRO.type, events_topic: TRIAL_EVENTS.type}
        found = {c.topic: c for c in self._reader.connections if c.topic in wanted}
        for topic, msgtype in wanted.items():
            if topic not in found:
                topics = ", ".join(sorted({c.topic for c in self._reader.connections})) or "none"
                self._reader.close()
                raise SourceConfigError("bag", "bag", f"holds no {topic} topic (its topics: {topics})", self.path)
            if found[topic].msgtype != msgtype:
                self._reader.close()
                raise SourceConfigError(
                    "bag", "bag", f"topic {topic} holds {found[topic].msgtype}, expected {msgtype}", self.path
                )
        self._store: Any = rig_typestore()
        self._gyro_topic = gyro_topic
        self._messages: Iterator[tuple[Any, int, bytes]] = self._reader.messages(connections=list(found.values()))
        self._pending: tuple[Any, int, bytes] | None = None
        self._first_log_ns: int | None = None
        self._finished = False
        self._open_trials: set[str] = set()
        self.skipped_batches = 0

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> BagSource:
        """Parameters: ``bag`` (the bag's path) and ``time_scale``."""
        p = Parameters(cls.name, parameters, cls.PARAMETERS)
        path = p.text("bag")
        if not path:
            raise p.error("bag", "the bag source needs the path of a recorded bag", "")
        time_scale = p.number("time_scale")
        return cls(path, RigClock(None, time_scale))

    def describe(self) -> str:
        """The bag's path and the time scale, for the log."""
        return f"bag: {self.path}, time scale {self.clock.time_scale:g}"

    def silence_hint(self) -> str:
        """Why a replayed trial goes silent: the recording has a gap there."""
        return "the recording has a gap here (samples lost while it was recorded)"

    @property
    def finished(self) -> bool:
        """True once the bag's last message has been replayed."""
        return self._finished

    def poll(self) -> list[SourceEvent]:
        """The events whose (scaled) recording time has come, in recording order.

        Raises:
            SourceIOError: The bag became unreadable while replaying.
        """
        events: list[SourceEvent] = []
        if self._finished:
            return events
        now = self.clock.now_ns()
        elapsed = now - self.clock.start_ns
        while True:
            if self._pending is None:
                try:
                    self._pending = next(self._messages, None)
                except Exception as exc:  # a corrupt chunk, a vanished file
                    raise SourceIOError(f"bag source: reading {self.path} failed: {exc}") from None
                if self._pending is None:
                    self._finished = True
                    self.close()
                    if self.skipped_batches:
                        skipped = self.skipped_batches
                        _log.warning("bag %s: %d batches outside a recorded trial skipped", self.path, skipped)
                    break
            connection, log_ns, raw = self._pending
            if self._first_log_ns is None:
                self._first_log_ns = log_ns
            if not math.isinf(elapsed) and log_ns - self._first_log_ns > elapsed:
                break
            self._pending = None
            event = self._convert(connection, raw)
            if event is not None:
                events.append(event)
        return events

    def _convert(self, connection: Any, raw: bytes) -> SourceEvent | None:
        msg = self._store.deserialize_cdr(raw, connection.msgtype)
        if connection.topic == self._gyro_topic:
            if msg.trial_id not in self._open_trials:
                self.skipped_batches += 1
                return None
            volts = np.array(msg.raw_volts, dtype=np.float64) if len(msg.raw_volts) else None
            return SampleBlock(msg.trial_id, int(msg.first_index), np.array(msg.rates, dtype=np.float64), volts)
        if msg.kind == _START:
            self._open_trials.add(msg.trial_id)
            return TrialStarted(TrialInfo(**record_fields(TrialInfo, msg)), stamp_ns(msg.header))
        if msg.kind in (_STOP, _ABORT):
            if msg.trial_id not in self._open_trials:
                _log.warning("bag %s: STOP of trial %s without its START skipped", self.path, msg.trial_id)
                return None
            self._open_trials.discard(msg.trial_id)
            return TrialStopped(msg.trial_id, int(msg.sample_count), stamp_ns(msg.header), aborted=msg.kind == _ABORT)
        _log.warning("bag %s: trial event of unknown kind %d skipped", self.path, msg.kind)
        return None

    def close(self) -> None:
        """Close the bag (idempotent)."""
        reader = getattr(self, "_reader", None)
        if reader is not None and getattr(reader, "isopen", True):
            try:
                reader.close()
            except Exception:  # closing twice or a half-open reader
                pass
