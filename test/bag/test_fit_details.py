"""A bag's FitDetails complete its recorded estimates; a bag recorded before their newer fields still reads.

A session fitted with the option ``small_swing_period`` (compound pendulums swinging 6–10° as
the sin θ pendulums they are): the fitter's ``FitDetails`` carry each trial's small-swing
systematic and ends period, the recorded estimates read back from the bag have them, and the
budget of the bag shows the small-swing systematic as a line of its own. The same bag with the
FitDetails definition of before those fields (its own schema in the bag) reads them as NaN.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from bike_rig.bag.simulated import RECORDED_TOPICS, SimulatedMessage, live_results, simulated_messages
from bike_rig.bag.typestore import message_definition, rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.config.topics import FIT_DETAILS
from bike_rig.core.period.small_swing import SMALL_SWING_SOURCE
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.messages import fit_details_from_msg
from bike_rig.offline.replay import replay_bag
from bike_rig.offline.session import read_session
from bike_rig.pipeline.fit import TrialFitOptions

#: The FitDetails fields added after bags were recorded without them.
NEW_FIELDS = ("ends_period", "ends_period_sigma", "small_swing_systematic")


@dataclasses.dataclass(frozen=True)
class Recorded:
    session: SimulatedSession
    live: list[SimulatedMessage]


@pytest.fixture(scope="module")
def recorded() -> Recorded:
    """A Browser session with finite swings, and what the live graph publishes with the small-swing option."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    rig = load_rig(config_file("rig.yaml"))
    trials = dataclasses.replace(
        rig.trials, amplitude_deg=(6.0, 10.0), finite_swing=True, dry_friction=(0.0, 0.02), durations=(12.0,)
    )
    session = simulate_session(truth, dataclasses.replace(rig, coupled_swing=None, trials=trials), 11, name)
    options = TrialFitOptions()
    options = dataclasses.replace(options, fit=dataclasses.replace(options.fit, small_swing_period=True))
    return Recorded(session, live_results(simulated_messages(session), fit_options=options))


def old_definition() -> str:
    """The FitDetails schema text (with Header and Time) as it was before :data:`NEW_FIELDS`."""
    lines = message_definition(FIT_DETAILS.type).splitlines(keepends=True)
    kept = [line for line in lines if line.split("#", 1)[0].split()[1:2] not in [[f] for f in NEW_FIELDS]]
    assert len(lines) - len(kept) == len(NEW_FIELDS)
    return "".join(kept)


def _as(store: Any, msg: Any, msgtype: str) -> Any:
    """``msg`` as a message of ``store``'s ``msgtype`` (its fields by name; nested messages too)."""
    _, fields = store.fielddefs[msgtype]
    values = {}
    for name, (nodetype, spec) in fields:
        value = getattr(msg, name)
        values[name] = _as(store, value, spec) if nodetype == 2 else value
    return store.types[msgtype](**values)


def write_bag(path: Path, rec: Recorded, details_definition: str | None) -> Path:
    """The session and its live results; FitDetails written with ``details_definition`` (None: installed)."""
    rig = rig_typestore()
    store = rig
    if details_definition is not None:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(details_definition, FIT_DETAILS.type))
    messages = sorted([*simulated_messages(rec.session), *rec.live], key=lambda m: m.log_time)
    types = {t.name: t.type for t in RECORDED_TOPICS}
    with BagWriter(path, flush_period_s=3600.0) as w:
        for t in RECORDED_TOPICS:
            mine = t is FIT_DETAILS and details_definition is not None
            w.add_topic(
                t.name,
                t.type,
                offered_qos=[contract_qos(t.qos)],
                msgdef=details_definition if mine else None,
                rihs01=store.hash_rihs01(t.type) if mine else None,
            )
        for k, m in enumerate(messages):
            if m.topic == FIT_DETAILS.name and details_definition is not None:
                data = store.serialize_cdr(_as(store, m.message, FIT_DETAILS.type), FIT_DETAILS.type)
            else:
                data = rig.serialize_cdr(m.message, types[m.topic])
            w.write(m.topic, m.log_time, bytes(data), sequence=k + 1)
    return path


@pytest.fixture(scope="module")
def current_bag(recorded: Recorded, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(tmp_path_factory.mktemp("details") / "current", recorded, None)


def test_the_recorded_estimates_carry_their_fit_details(recorded: Recorded, current_bag: Path) -> None:
    session = read_session(current_bag)
    assert set(session.fit_details) == {t.name for t in recorded.session.trials}
    result = replay_bag(current_bag)
    assert result.live.identical and not result.notes
    swinging = [t for t in result.trials if math.isfinite(t.result.fit.small_swing_systematic)]
    assert swinging  # the compound pendulums' small-swing periods were checked over trimmed windows
    assert any(t.recorded is not None and math.isfinite(t.recorded.fit.ends_period) for t in result.trials)
    for t in result.trials:
        assert t.recorded is not None
        live, replayed = t.recorded.fit, t.result.fit
        for name in (*NEW_FIELDS, "small_swing_period", "damping_model", "window_periods"):
            a, b = getattr(live, name), getattr(replayed, name)
            assert a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)), (t.trial_id, name)


def test_the_budget_of_a_small_swing_bag_shows_its_systematic(
    current_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["budget", str(current_bag)]) == 0
    assert f"({SMALL_SWING_SOURCE})" in capsys.readouterr().out
    assert main(["budget", str(current_bag), "--json"]) == 0
    outputs = json.loads(capsys.readouterr().out)["outputs"]
    lines = [s for o in outputs for s in o["shares"] if s["input"].endswith(f"({SMALL_SWING_SOURCE})")]
    assert lines and all(s["contribution"] > 0 and s["share"] > 0 for s in lines)


def test_a_bag_recorded_before_the_new_fields_reads_them_as_nan(
    recorded: Recorded, current_bag: Path, tmp_path: Path
) -> None:
    definition = old_definition()
    bag = write_bag(tmp_path / "old", recorded, definition)
    session = read_session(bag)
    assert set(session.fit_details) == {t.name for t in recorded.session.trials}
    for msg in session.fit_details.values():
        assert not any(hasattr(msg, f) for f in NEW_FIELDS)  # decoded with the bag's own definition
        details = fit_details_from_msg(msg)
        assert all(math.isnan(getattr(details, f)) for f in NEW_FIELDS)
    old, new = replay_bag(bag), replay_bag(current_bag)
    assert old.live.identical and not old.notes
    for a, b in zip(old.trials, new.trials, strict=True):
        assert a.recorded is not None and b.recorded is not None
        assert all(math.isnan(getattr(a.recorded.fit, f)) for f in NEW_FIELDS)
        assert a.recorded.fit.small_swing_period == b.recorded.fit.small_swing_period or (
            math.isnan(a.recorded.fit.small_swing_period) and math.isnan(b.recorded.fit.small_swing_period)
        )
        assert a.result.fit.period == b.result.fit.period  # the replay refits: the same as ever


def test_fit_details_bike_rig_cannot_read_are_left_out_with_a_note(recorded: Recorded, tmp_path: Path) -> None:
    """A definition lacking a field that was always there: the bag still replays, without the details."""
    definition = old_definition().replace("float64 friction_sigma\n", "")
    bag = write_bag(tmp_path / "lacking", recorded, definition)
    result = replay_bag(bag)
    assert result.complete and result.live.identical
    assert len(result.notes) == 1 and "fit details" in result.notes[0] and "friction_sigma" in result.notes[0]
    assert all(t.recorded is not None and math.isnan(t.recorded.fit.small_swing_systematic) for t in result.trials)
