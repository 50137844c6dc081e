"""Where an interrupted session stands, read from its bag: what a resumed session starts from.

:func:`resume_point` reads, for ``bike-rig session --resume``: the trials recorded (ids never
reused; those without STOP, which the resumed driver records ABORT; the last rig time;
:func:`started_trials`), every reading entered (in order, for the console to enter again) and
the static readings the session started from (the last ``StaticReadings``). A bag that did not
end cleanly is first recovered (:func:`~bike_rig.bag.recover.recover_bag`) into
``recover_into``, the damaged bag left as it is. :mod:`bike_rig.sources.resume` streams the
recorded trials again before the new ones.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..bag.errors import BagError, IncompleteBagError
from ..bag.reader import BagReader
from ..bag.recover import recover_bag
from ..messages import reading_entry_from_msg
from ..pipeline.readings import ReadingEntry
from .session import RecordedSession, RecordedTrial, read_session

__all__ = ["NO_STATIC_READINGS", "ResumePoint", "resolve_session_bag", "resume_point", "started_trials"]

#: The parameter node's ``source`` of a StaticReadings message when no file was given.
NO_STATIC_READINGS = "no static readings yet"

#: A ``source`` with reading entries applied (:func:`bike_rig.pipeline.readings.apply_entries`):
#: ``"<file> + N reading entries"``, or ``"N reading entries"`` without a file.
_WITH_ENTRIES = re.compile(r"^(?:(?P<file>.*) \+ )?\d+ reading entr(?:y|ies)$")


@dataclass(frozen=True)
class ResumePoint:
    """What an interrupted session leaves to its continuation (see the module docstring).

    Attributes:
        bag: The readable bag (the recovered copy when the recording did not end cleanly).
        given: The path as the user gave it.
        bicycle: The bicycle's name ("" when the bag does not say).
        trial_ids: Every trial started, in order of START.
        open_trials: Trials started but never stopped, in order.
        entries: Every reading entry, in the order received.
        readings_document: The static readings the session started from: the measurement file's
            text, or its readings with the entries applied as a ``bike_rig-measurements/1``
            document (entries applied again on top change nothing); "" when it had no file.
        readings_suffix: The file suffix that document is read by (``.yaml``, ``.txt``).
        last_stamp_ns: The latest rig-time stamp of a trial event, ns (0 if none).
        recovered: True when ``bag`` is a recovered copy.
    """

    bag: Path
    given: str
    bicycle: str
    trial_ids: tuple[str, ...]
    open_trials: tuple[str, ...]
    entries: tuple[ReadingEntry, ...]
    readings_document: str
    readings_suffix: str
    last_stamp_ns: int
    recovered: bool = False

    def describe(self) -> str:
        """One line: what is resumed, e.g. ``12 trials (1 left open: aborted) and 9 readings from …``."""
        left = f" ({len(self.open_trials)} left open: recorded as aborted)" if self.open_trials else ""
        copy = " (recovered: the recording had not ended cleanly)" if self.recovered else ""
        return f"{len(self.trial_ids)} trials{left} and {len(self.entries)} readings from {self.given}{copy}"


def resolve_session_bag(path: str | Path) -> Path:
    """The bag of ``path``: a session folder's ``bag`` (when it has one), else ``path`` itself.

    Raises:
        BagError: No such path.
    """
    p = Path(path)
    if not p.exists():
        raise BagError(str(path), "no such session folder or bag")
    return p / "bag" if (p / "bag").is_dir() else p


def started_trials(session: RecordedSession) -> list[RecordedTrial]:
    """The trials of ``session`` that have a START, in order of their START stamps."""
    started = [t for t in session.trials.values() if t.start is not None]
    return sorted(started, key=lambda t: t.start.stamp_ns if t.start is not None else 0)


def _readable(bag: Path, recover_into: Path) -> tuple[Path, bool]:
    """``bag`` itself when it opens, else its recovered copy in ``recover_into``."""
    try:
        BagReader(bag).open().close()
        return bag, False
    except IncompleteBagError:
        return recover_bag(bag, recover_into).output, True


def _started_from(session: RecordedSession) -> tuple[str, str]:
    """The static readings the session started from: (document, file suffix), ("", "") without a file."""
    msg = session.static_readings
    if msg is None:
        return "", ""
    source = str(msg.source)
    with_entries = _WITH_ENTRIES.match(source)
    file = (with_entries.group("file") or "") if with_entries else ("" if source == NO_STATIC_READINGS else source)
    if not file:
        return "", ""
    return str(msg.document), ".yaml" if with_entries else (Path(file).suffix or ".yaml")


def resume_point(path: str | Path, recover_into: str | Path) -> ResumePoint:
    """Read where the session of ``path`` (session folder or bag) stands.

    Args:
        path: The interrupted session's folder, or its bag.
        recover_into: Where to write the recovered copy of a bag that did not end cleanly
            (must not exist).

    Raises:
        BagError: No such bag, unreadable and unrecoverable, or without any of the rig's topics.
    """
    bag, recovered = _readable(resolve_session_bag(path), Path(recover_into))
    session = read_session(bag)
    trials = started_trials(session)
    stamps = [e.stamp_ns for t in session.trials.values() for e in (t.start, t.stop) if e is not None]
    document, suffix = _started_from(session)
    return ResumePoint(
        bag=bag,
        given=str(path),
        bicycle=session.bicycle,
        trial_ids=tuple(t.trial_id for t in trials),
        open_trials=tuple(t.trial_id for t in trials if t.stop is None),
        entries=tuple(reading_entry_from_msg(m) for m in session.reading_entries),
        readings_document=document,
        readings_suffix=suffix,
        last_stamp_ns=max(stamps, default=0),
        recovered=recovered,
    )
