"""The session timeline: one time base (the rig clock from the first trial's start), each thing once.

A simulated Browser session is written as a bag with what the live graph publishes, as a live
simulated rig 25× faster than real time records it: the trial events on the rig's clock, the
static readings, parameter sets and model on the computer's clock (another epoch, 25× slower).
Every parameter set and the last model are published twice (latched results re-published), one
trial's START is recorded twice, and the operator enters a reading before any result and corrects
it later (the correction recorded twice). The timeline must put everything on the rig's clock and
list each thing once.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass
from html.parser import HTMLParser

import pytest

from bike_rig.bag.simulated import SimulatedMessage, live_results, simulated_messages, write_simulated_bag
from bike_rig.bag.typestore import new_message
from bike_rig.config import topics
from bike_rig.messages import set_stamp, stamp_ns
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.offline.timeline import TIME_BASE, TimelineEntry
from bike_rig.report.html import esc
from bike_rig.report.sections import timeline_section, trials_section
from test.support.simulated import short_session

#: The simulated rig runs this many times faster than the computer's clock.
TIME_SCALE = 25.0
#: The computer's clock is this far behind the rig's at the session's start, ns.
EPOCH_SHIFT_NS = 3_600 * 1_000_000_000
#: A re-publication follows its original after this long on the computer's clock, ns.
REPUBLISH_NS = 40_000_000
PUBLISHED = (topics.STATIC_READINGS.name, topics.PARAMETERS.name, topics.MATRICES.name, topics.EIGEN_SWEEP.name)


@dataclass(frozen=True)
class Recorded:
    """The bag, its subject, and what the test knows independently of the timeline."""

    subject: Subject
    first_start_ns: int
    starts: dict[str, int]
    stops: dict[str, int]
    parameter_sets: list[tuple[bool, list[str]]]  # (complete, trial ids) of each distinct set
    matrices: int


def _computer_clock(rig_ns: int, origin_ns: int) -> int:
    return origin_ns - EPOCH_SHIFT_NS + round((rig_ns - origin_ns) / TIME_SCALE)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    session = short_session()
    stream = list(simulated_messages(session, pause_s=2.0))
    origin = stream[0].log_time
    starts: dict[str, int] = {}
    stops: dict[str, int] = {}
    for m in stream:
        if m.topic == topics.TRIAL_EVENTS.name:
            (starts if int(m.message.kind) == 0 else stops)[str(m.message.trial_id)] = stamp_ns(m.message.header)
    # the readings again, as the parameter node publishes them: on the computer's clock
    readings = copy.deepcopy(stream[0].message)
    set_stamp(readings, _computer_clock(origin, origin))
    extra = [SimulatedMessage(stream[0].topic, origin + 1, readings)]
    results = live_results(stream)
    last_model = max(i for i, m in enumerate(results) if m.topic == topics.MATRICES.name)
    sets: list[tuple[bool, list[str]]] = []
    matrices = 0
    for i, m in enumerate(results):
        extra.append(m)
        if m.topic not in PUBLISHED:
            continue
        set_stamp(m.message, _computer_clock(stamp_ns(m.message.header), origin))
        copies = 2 if m.topic == topics.PARAMETERS.name or i == last_model else 1
        if copies == 2:  # re-published, unchanged, with a later stamp (the model keeps its set's stamp)
            again = copy.deepcopy(m.message)
            if m.topic == topics.PARAMETERS.name:
                set_stamp(again, stamp_ns(m.message.header) + REPUBLISH_NS)
            extra.append(SimulatedMessage(m.topic, m.log_time + 1, again))
        if m.topic == topics.PARAMETERS.name:
            sets.append((bool(m.message.complete), [e.partition(":")[2] for e in m.message.trial_ids]))
        matrices += copies if m.topic == topics.MATRICES.name else 0
    # readings entered at the console (the computer's clock): one before any result, then a
    # correction after the fifth trial's parameter set, recorded twice
    fifth = [m for m in results if m.topic == topics.PARAMETERS.name][4]
    for k, (ns, value) in enumerate(
        ((_computer_clock(origin, origin) + 1, 3.10), (stamp_ns(fifth.message.header) + 1, 3.12))
    ):
        entry = new_message(topics.READINGS.type, key="mR", value=value, sigma=0.02, note="correction" if k else "")
        set_stamp(entry, ns)
        extra += [SimulatedMessage(topics.READINGS.name, fifth.log_time + 2 if k else origin + 2, entry)] * (k + 1)
    first_start = next(m for m in stream if m.topic == topics.TRIAL_EVENTS.name)
    extra.append(SimulatedMessage(first_start.topic, first_start.log_time + 5_000_000, first_start.message))
    bag = write_simulated_bag(tmp_path_factory.mktemp("timeline") / "bag", session, extra, pause_s=2.0)
    return Recorded(load_subject(bag), min(starts.values()), starts, stops, sets, matrices)


def _rig_s(ns: int, recorded: Recorded) -> float:
    return (ns - recorded.first_start_ns) / 1e9


def _newest_stop_s(trial_ids: list[str], recorded: Recorded) -> float | None:
    stops = [_rig_s(recorded.stops[t], recorded) for t in trial_ids if t in recorded.stops]
    return max(stops) if stops else None


def _rows(timeline: tuple[TimelineEntry, ...], pattern: str) -> list[TimelineEntry]:
    return [e for e in timeline if re.search(pattern, e.what)]


def test_trial_events_once_each_on_the_rig_clock(recorded: Recorded) -> None:
    timeline = recorded.subject.timeline
    assert len(recorded.starts) == len(recorded.stops) == 39
    for tid, ns in recorded.starts.items():
        started = _rows(timeline, rf"^trial {re.escape(tid)} \(\w+\) started$")
        assert len(started) == 1, tid  # the first trial's START was recorded twice
        assert started[0].time_s == pytest.approx(_rig_s(ns, recorded), abs=1e-9)
        stopped = _rows(timeline, rf"^trial {re.escape(tid)} \(\w+\) stopped")
        assert len(stopped) == 1 and stopped[0].count == 1
        assert stopped[0].time_s == pytest.approx(_rig_s(recorded.stops[tid], recorded), abs=1e-9)
    assert min(e.time_s for e in timeline if e.time_s is not None) == 0.0  # the first trial's start
    # the trials' start and stop (trials table, overview figure) are on the same clock
    for t in recorded.subject.trials:
        assert t.start_s == pytest.approx(_rig_s(recorded.starts[t.trial_id], recorded), abs=1e-9)
        assert t.stop_s == pytest.approx(_rig_s(recorded.stops[t.trial_id], recorded), abs=1e-9)


def test_publications_collapsed_and_placed_at_their_newest_trial(recorded: Recorded) -> None:
    timeline = recorded.subject.timeline
    last_stop = _rig_s(max(recorded.stops.values()), recorded)
    for complete, label in ((False, "incomplete"), (True, "complete")):
        rows = _rows(timeline, rf"^{label} parameter set published")
        sets = [ids for c, ids in recorded.parameter_sets if c is complete]
        assert len(rows) == 1 and rows[0].count == 2 * len(sets)  # each published twice
        assert f"published {2 * len(sets)}×" in rows[0].what
        assert rows[0].time_s == _newest_stop_s(sets[0], recorded)
        assert rows[0].last_s == pytest.approx(_newest_stop_s(sets[-1], recorded), abs=1e-9)
    complete_row = _rows(timeline, r"^complete parameter set")[0]
    assert complete_row.last_s == pytest.approx(last_stop, abs=1e-9)
    model = _rows(timeline, r"^model")
    assert len(model) == 1 and model[0].count == recorded.matrices
    assert model[0].time_s == complete_row.time_s and model[0].last_s == complete_row.last_s
    # the readings, re-published on the computer's clock before any trial's result
    readings = _rows(timeline, r"^static readings published")
    assert len(readings) == 1 and readings[0].time_s is None
    # readings entered: the first before any result, the correction at its parameter set's newest trial
    entered = _rows(timeline, r"^reading mR ")
    assert [e.what for e in entered] == [
        "reading mR = 3.1 ± 0.02 entered",
        "reading mR corrected to 3.12 ± 0.02 (was 3.1 ± 0.02): correction (recorded 2×)",
    ]
    assert entered[0].time_s is None and entered[1].count == 2
    assert entered[1].time_s == _newest_stop_s(recorded.parameter_sets[4][1], recorded)
    # one time base: nothing before the first trial's start or after the last stop
    times = [t for e in timeline for t in (e.time_s, e.last_s) if t is not None]
    assert 0.0 <= min(times) and max(times) <= last_stop + 1e-9
    keys = [(e.time_s is not None, e.time_s or 0.0) for e in timeline]
    assert keys == sorted(keys)
    assert len(timeline) == 2 * 39 + 4 + 2


class _Table(HTMLParser):
    """The timeline table's header and rows (cell texts, and each first cell's data-value)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.head: list[str] = []
        self.rows: list[list[str]] = []
        self.values: list[str] = []
        self._cell: list[str] | None = None
        self._in_head = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "thead":
            self._in_head = True
        elif tag == "tbody":
            self._in_head = False
        elif tag == "tr" and not self._in_head:
            self.rows.append([])
        elif tag in ("td", "th"):
            self._cell = []
            if tag == "td" and not self.rows[-1]:
                self.values.append(dict(attrs).get("data-value") or "")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            text = "".join(self._cell).strip()
            (self.head if self._in_head else self.rows[-1]).append(text)
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def test_report_states_the_time_base_and_lists_each_row_once(recorded: Recorded) -> None:
    html = str(timeline_section(recorded.subject))
    table = html[html.index("<table") : html.index("</table>") + len("</table>")]
    parsed = _Table()
    parsed.feed(table)
    assert parsed.head[0] == f"time [{TIME_BASE}]" and "rig clock" in TIME_BASE and "first trial" in TIME_BASE
    entries = recorded.subject.timeline
    assert [r[1] for r in parsed.rows] == [e.what for e in entries]
    assert [None if v == "none" else float(v) for v in parsed.values] == [e.time_s for e in entries]
    for row, e in zip(parsed.rows, entries, strict=True):
        assert row[2] == (f"{e.last_s:.1f}" if e.count > 1 and e.last_s is not None else "")
    assert "its trials span" in html
    assert esc(TIME_BASE) in str(trials_section(recorded.subject))
