"""The session controller and state on an in-process graph: plan states, results, REDO, readings, plain mode."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig
from bike_rig.pipeline.fit import TrialFit
from bike_rig.session.plain import run_plain
from bike_rig.session.plan import ItemState, ReadingItem, TrialItem, plan_from_rig
from bike_rig.session.setup import build_controller
from bike_rig.session.state import result_line
from test.support.fakelink import FakeLink, browser_truth


@pytest.fixture
def ctl_link():  # type: ignore[no-untyped-def]
    link = FakeLink()
    ctl = build_controller(load_rig(config_file("rig.yaml")), "Browser", link)
    t = [0.0]
    ctl.clock = lambda: t[0]
    return ctl, link, t


def test_plan_covers_every_reading_and_trial_in_rig_order() -> None:
    rig = load_rig(config_file("rig.yaml"))
    plan = plan_from_rig(rig)
    assert len(plan.trials) == 13 * rig.trials.per_measurement  # 13 periods with 3 orientations each
    keys = [i.key for i in plan.readings]
    assert keys[:4] == ["g", "w", "gamma", "f"]
    assert {"alphaB3", "aB3", "alphaH3", "aH3", "mP", "lP", "dP"} <= set(keys)
    # a part's readings come before its trials
    first = {i.key: n for n, i in reversed(list(enumerate(plan.items)))}
    assert first["mB"] < first["TcB1"] and first["mR"] < first["TcR1"]
    frame2 = plan.item("TtB2#1")
    assert isinstance(frame2, TrialItem)
    assert "orientation 2" in frame2.instruction and f"{rig.frame_orientations_deg[1]:.0f}°" in frame2.instruction
    with pytest.raises(KeyError, match="no plan item"):
        plan.item("TtB9#1")


def test_trial_states_follow_start_result_and_redo(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    first = ctl.session.plan.trials[0]
    out = ctl.execute("start")
    assert out[0].kind == "ok" and first.item_id in out[0].text
    trial_id = link.started[0][0]
    ctl.pump()
    assert ctl.session.state(first) == ItemState.RECORDING
    assert ctl.execute("start")[0].kind == "error"  # one trial at a time
    link.period(trial_id, first.key, 1.2, 1e-4, flags=("beating",))
    replies = ctl.pump()
    result = [r for r in replies if r.kind == "result"]
    assert result and "REDO" in result[0].text and "beating: beating reason" in result[0].text
    assert ctl.session.state(first) == ItemState.REDO
    assert ctl.session.next_trial() == first  # the redo comes first
    ctl.execute(f"start {first.item_id}")
    link.period(link.started[1][0], first.key, 1.2, 1e-4)
    replies = ctl.pump()
    assert any(r.kind == "result" and r.text.endswith("— ok") for r in replies)
    assert ctl.session.state(first) == ItemState.OK
    assert ctl.session.next_trial() == ctl.session.plan.trials[1]


def test_a_result_before_its_stop_event_ends_the_recording(ctl_link) -> None:  # type: ignore[no-untyped-def]
    """Periods and trial events are two topics: the result may come first; the next start must not wait."""
    ctl, link, t = ctl_link
    first = ctl.session.plan.trials[0]
    ctl.execute("start")
    trial_id = link.started[0][0]
    ctl.pump()
    link.period(trial_id, first.key, 1.2, 1e-4)
    link.events_out = [e for e in link.events_out if not getattr(e, "kind", None)]  # the STOP is late
    ctl.pump()
    assert ctl.session.recording() is None
    assert ctl.execute("start")[0].kind == "ok"


def test_another_process_result_without_start_under_the_recording_id_is_not_its_result(ctl_link) -> None:  # type: ignore[no-untyped-def]
    """A rogue's STOP of the driver's next trial id is published (``no_start``) before the driver's START.

    The console started that id: the result is not its trial's; it says so and keeps recording.
    """
    ctl, link, t = ctl_link
    first = ctl.session.plan.trials[0]
    ctl.execute("start")
    trial_id = link.started[0][0]
    ctl.pump()
    nan = float("nan")
    reasons = ("STOP without a START event", "50 of 100 samples")
    link.events_out.append(TrialFit.from_period(trial_id, first.key, nan, nan, False, ("no_start", "gap"), reasons))
    replies = ctl.pump()
    assert not [r for r in replies if r.kind == "result"]
    warned = [r for r in replies if r.kind == "warning" and r.data.get("foreign")]
    assert len(warned) == 1 and "another process" in warned[0].text and "no_start, gap" in warned[0].text
    assert ctl.session.state(first) == ItemState.RECORDING and ctl.session.recording() is not None
    link.period(trial_id, first.key, 1.2, 1e-4)  # the driver's own
    result = [r for r in ctl.pump() if r.kind == "result"]
    assert result and result[0].text.endswith("— ok") and ctl.session.state(first) == ItemState.OK


def test_a_result_whose_events_are_late_counts_its_cycles_from_the_batches_rate(ctl_link) -> None:  # type: ignore[no-untyped-def]
    """The START (which gives the rate) late or lost: the live trace's batches give it, so the cycles are counted."""
    ctl, link, t = ctl_link
    first = ctl.session.plan.trials[0]
    ctl.execute("start")
    trial_id = link.started[0][0]
    link.events_out = []  # the START is late
    link.samples(trial_id, np.zeros(50))
    ctl.pump()
    link.period(trial_id, first.key, 1.2, 1e-4)
    link.events_out = [e for e in link.events_out if not getattr(e, "kind", None)]  # and the STOP too
    result = [r for r in ctl.pump() if r.kind == "result"]
    assert result and "T = 1.20000 ± 0.00010 s, 25 cycles, r²" in result[0].text  # (30,000 samples at 1 kHz)
    # with no batch either, the line leaves the cycles out rather than print "nan cycles"
    second = ctl.session.plan.trials[1]
    ctl.execute(f"start {second.item_id}")
    link.events_out = []
    ctl.pump()
    link.period(link.started[1][0], second.key, 0.8, 1e-4)
    link.events_out = [e for e in link.events_out if not getattr(e, "kind", None)]
    result = [r for r in ctl.pump() if r.kind == "result"]
    assert result and "T = 0.80000 ± 0.00010 s, r² 0.99990 — ok" in result[0].text


def test_abort_records_redo_and_refusal_is_reported(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    ctl.execute("start TtB2#1")
    ctl.pump()
    out = ctl.execute("abort")
    assert out[0].kind == "ok" and link.stopped == [(link.started[0][0], True)]
    replies = ctl.pump()
    assert any("aborted — REDO" in r.text for r in replies)
    assert ctl.session.state(ctl.session.plan.item("TtB2#1")) == ItemState.REDO
    link.refuse = "orientation 4 is outside the plan"
    out = ctl.execute("start TtB2#1")
    assert out[0].kind == "error" and "orientation 4 is outside the plan" in out[0].text
    assert ctl.execute("stop")[0].text == "no trial is recording"


def test_silence_warns_within_one_second_and_once(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    ctl.execute("start")
    ctl.pump()
    t[0] = 0.9
    assert not [r for r in ctl.pump() if r.kind == "warning"]
    t[0] = 1.0
    warnings = [r for r in ctl.pump() if r.kind == "warning"]
    assert len(warnings) == 1 and "no samples yet" in warnings[0].text
    # advice for the source's kind: a simulated source is starved, never an unplugged gyro
    assert "machine loaded" in warnings[0].text and "unplugged" not in warnings[0].text
    t[0] = 1.5
    assert not [r for r in ctl.pump() if r.kind == "warning"]  # said once
    trial_id = link.started[0][0]
    x = np.arange(2000) / 1000.0
    link.samples(trial_id, 0.05 * np.sin(2 * np.pi * x / 1.2) + 1e-4 * np.random.default_rng(1).standard_normal(2000))
    ctl.pump()
    live = ctl.session.live_status(1.6)
    assert live is not None and live.samples == 2000 and not live.warnings
    assert live.amplitude == pytest.approx(0.05, rel=0.05)


def test_clipping_and_small_amplitude_warn(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    ctl.execute("start")
    trial_id = link.started[0][0]
    x = np.arange(4000) / 1000.0
    link.samples(trial_id, np.clip(np.sin(2 * np.pi * x / 1.2), -0.8, 0.8))
    warnings = [r.text for r in ctl.pump() if r.kind == "warning"]
    assert any("clips at its maximum" in w for w in warnings)
    ctl.execute("abort")
    ctl.pump()
    ctl.execute("start")
    trial_id = link.started[1][0]
    noise = 1e-3 * np.random.default_rng(2).standard_normal(4000)
    link.samples(trial_id, 1e-4 * np.sin(2 * np.pi * x / 1.2) + noise)
    warnings = [r.text for r in ctl.pump() if r.kind == "warning"]
    assert any("too small to fit" in w for w in warnings)


def test_a_reading_that_looks_like_radians_is_held_until_answered(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    gamma = ctl.session.plan.item("gamma")
    out = ctl.execute("reading gamma 1.2 0.01")
    assert all(r.kind == "warning" for r in out) and any("radian" in r.text for r in out)
    assert "held" in out[-1].text and out[-1].data["held"]
    assert ctl.session.state(gamma) == ItemState.TODO and not link.entries  # not marked done, not sent
    assert any("held" in r.text for r in ctl.execute("status"))  # still said until answered
    assert ctl.execute("reading mR 3.0 0.02")[0].kind == "ok" and ctl.held is not None  # another key: still held
    assert ctl.execute("reading gamma 68.9 0.1")[0].text.startswith("entered gamma")  # answered: in degrees
    assert ctl.held is None and ctl.session.state(gamma) == ItemState.DONE
    ctl.execute("reading gamma 1.2 0.01")
    assert ctl.execute("keep")[0].text.startswith("corrected gamma")  # kept as it is, on purpose
    assert ctl.held is None and link.entries[-1].value == 1.2
    assert ctl.execute("keep")[0].kind == "error"
    assert ctl.execute("reading TtB9 1 0")[0].kind == "error"


def test_progress_is_one_count_everywhere(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    ctl.execute("reading mR 3.0 0.02")
    p = ctl.session.progress()
    assert (p.done, p.readings_done, p.trials_done) == (1, 1, 0)
    assert p.total == p.trials + p.readings == len(ctl.session.plan.items)
    assert len(ctl.session.missing()) == len(p.open) == p.total - p.done
    status = {r.text.split()[0]: r for r in ctl.execute("status")}
    assert status["progress"].data["done"] == 1 and p.line() in status["progress"].text
    assert f"({len(p.open)} in all)" in status["missing:"].text


def test_readings_are_checked_corrected_and_kept(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    assert ctl.execute("reading mR 3.0 -0.1")[0].kind == "error"
    assert "not a number" in ctl.execute("reading mR three 0.1")[0].text
    assert "pendulum period" in ctl.execute("reading TcR1 1.2 0.001")[0].text
    assert ctl.execute("reading mR 3.0 0.02")[0].text.startswith("entered mR")
    out = ctl.execute("reading mR 3.1 0.02")
    assert out[0].text.startswith("corrected mR")
    assert [e.value for e in link.entries] == [3.0, 3.1] and link.entries[1].note == "correction"
    assert ctl.session.reading("mR").value == 3.1  # type: ignore[union-attr]
    ctl.pump()
    assert ctl.session.state(ctl.session.plan.item("mR")) == ItemState.DONE


def test_a_whole_session_completes_with_speeds(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    rig, sim = browser_truth()
    for item in ctl.session.plan.items:
        if isinstance(item, ReadingItem):
            r = sim.readings[item.key]
            assert ctl.execute(f"reading {item.key} {r.value!r} {r.sigma!r}")[0].kind == "ok"
        else:
            assert ctl.execute(f"start {item.item_id}")[0].kind == "ok"
            link.period(link.started[-1][0], item.key, sim.truth.damped_periods[item.key], 1e-5)
        ctl.pump()
    p = ctl.session.progress()
    assert (p.done, p.total, p.open) == (len(ctl.session.plan.items), len(ctl.session.plan.items), ())
    assert ctl.session.complete and ctl.session.next_item() is None
    status = ctl.execute("status")
    assert any("weave" in r.text and "capsize" in r.text for r in status)
    # a poor wheelbase reading (25x the tape's σ) becomes the next-best measurement
    w = sim.readings["w"]
    assert ctl.execute(f"reading w {w.value!r} 0.05")[0].text.startswith("corrected w")
    ctl.pump()
    best = ctl.execute("best")
    assert best[0].data["item"] == "w" and "take it again" in best[0].text and "weave σ" in best[0].text
    assert ctl.execute("next")[-1].data["best"] == "w"
    ctl.execute(f"reading w {w.value!r} {w.sigma!r}")
    ctl.pump()
    params = ctl.execute("params")
    assert len(params) == 26 and {r.data["name"] for r in params} >= {"w", "c", "lam", "g"}  # 25 and g
    # the true periods and noisy readings give the true parameters within a few σ
    for r in params:
        truth = sim.truth.parameters[r.data["name"]]
        assert abs(r.data["value"] - truth) <= 5 * r.data["sigma"] + 1e-9 * abs(truth), r.text


def test_plain_mode_reads_commands_and_writes_json_lines(ctl_link) -> None:  # type: ignore[no-untyped-def]
    ctl, link, t = ctl_link
    stdin = io.StringIO("reading mR 3.0 0.02\nstart TcR1#1\nbogus\nstatus\nabort\nquit\n")
    stdout = io.StringIO()
    status = run_plain(ctl, stdin, stdout, as_json=True)
    lines = [json.loads(x) for x in stdout.getvalue().splitlines()]
    assert status == 1  # 'bogus' failed
    kinds = [x["kind"] for x in lines]
    assert kinds[0] == "ok" and lines[0]["key"] == "mR"
    assert any(x.get("trial_id") and x.get("command") == "start" for x in lines)
    assert any(x["kind"] == "error" and "unknown command 'bogus'" in x["text"] for x in lines)
    assert kinds[-1] == "done"


def test_a_flagged_result_gives_each_flag_its_reason_and_advice(ctl_link) -> None:  # type: ignore[no-untyped-def]
    from bike_rig.core.period.advice import flag_advice

    ctl, link, _ = ctl_link
    first = ctl.session.plan.trials[0]
    ctl.execute("start")
    link.period(link.started[0][0], first.key, 1.2, 1e-4, flags=("beating", "too_few_cycles"))
    result = next(r for r in ctl.pump() if r.kind == "result")
    for code in ("beating", "too_few_cycles"):
        assert f"{code}: {code} reason → {flag_advice(code)}" in result.text
    assert result.data["advice"] == [flag_advice("beating"), flag_advice("too_few_cycles")]
    assert flag_advice("beating") != flag_advice("too_few_cycles") != "redo the trial"


def test_a_resumed_session_starts_nothing_until_its_recorded_trials_are_back(ctl_link) -> None:  # type: ignore[no-untyped-def]
    from bike_rig.pipeline.acquire import TrialEventKind, TrialEventRecord
    from bike_rig.pipeline.readings import ReadingEntry

    ctl, link, _ = ctl_link
    items = ctl.session.plan.trials[:2]
    ids = [f"recorded_{i}" for i in range(2)]
    entries = [ReadingEntry("mR", 3.0, 0.02, stamp_ns=1), ReadingEntry("mR", 3.02, 0.02, stamp_ns=2)]
    ctl.resume(ids, entries, "2 trials and 2 readings from old")
    assert link.entries == entries  # published again, as they were
    first = ctl.pump()
    assert first[0].data == {"resuming": [0, 2]} and "old" in first[0].text
    refused = ctl.execute("start")
    assert refused[0].kind == "error" and "still coming back (0/2)" in refused[0].text
    assert not link.started
    assert any(r.data.get("resuming") == [0, 2] for r in ctl.execute("status"))
    # the driver streams them: START, then their results (the first one flagged)
    for trial_id, item in zip(ids, items, strict=True):
        link.events_out.append(
            TrialEventRecord(TrialEventKind.START, trial_id, item.key, repeat=item.repeat, sample_rate_hz=1000.0)
        )
    link.period(ids[0], items[0].key, 1.2, 1e-4, flags=("beating",))
    assert not any("resumed" in r.data for r in ctl.pump())
    assert ctl.execute("start")[0].kind == "error"
    link.period(ids[1], items[1].key, 1.2, 1e-4)
    back = [r for r in ctl.pump() if "resumed" in r.data]
    assert len(back) == 1 and back[0].data["resumed"] == 2
    assert ctl.session.state(items[0]) == ItemState.REDO and ctl.session.state(items[1]) == ItemState.OK
    assert ctl.session.reading("mR").value == 3.02  # type: ignore[union-attr]
    started = ctl.execute("start")
    assert started[0].kind == "ok" and started[0].data["item"] == items[0].item_id  # the redo first
    assert not any("resumed" in r.data for r in ctl.pump())  # announced once


@pytest.mark.parametrize("details_first", [True, False])
def test_the_fit_details_join_the_result_before_or_after_it(ctl_link, details_first: bool) -> None:  # type: ignore[no-untyped-def]
    from bike_rig.pipeline.fit_details import FitDetails

    ctl, link, _ = ctl_link
    first = ctl.session.plan.trials[0]
    ctl.execute("start")
    trial_id = link.started[0][0]
    details = FitDetails(
        trial_id,
        damping_model="dry",
        friction=0.025,
        friction_sigma=4e-4,
        swing_kappa=-0.0017,
        centre_period=1.2027,
        small_swing_period=1.19998,
        small_swing_period_sigma=2.7e-5,
        window_periods=(1.2057, 1.2035, 1.2017, 1.2018),
        window_period_sigmas=(4e-4,) * 4,
        notes=("the period along the record: ...: moves beyond its σ",),
    )
    if details_first:
        link.events_out.append(details)
    link.period(trial_id, first.key, 1.2, 1e-4)
    if not details_first:
        link.events_out.append(details)
    replies = ctl.pump()
    view = ctl.session.trials[trial_id]
    assert view.fit is not None and view.fit.fit.damping_model == "dry" and ctl.session.state(first) == ItemState.OK
    line = result_line(view)
    assert line.split(" — ")[1].startswith("ok; damping dry, small-swing T₀ 1.19998 ± 2.7e-05 s")
    assert "period moves 1.2057 → 1.2018 s (0.33 %)" in line
    results = [r.text for r in replies if r.kind == "result"]
    if details_first:  # the line the operator saw has them
        assert results == [line]
    else:  # the result line came first: what the details add follows as its own line
        assert results == [line.split("; ")[0]]
        info = [r.text for r in replies if r.kind == "info"]
        assert info == [f"{first.item_id} {trial_id}: {line.split('; ', 1)[1]}"]
    link.period(trial_id, first.key, 1.2, 1e-4)  # published again (a restarted fitter): the details stay
    again = [r.text for r in ctl.pump() if r.kind == "result"]
    assert again == [line] and result_line(ctl.session.trials[trial_id]) == line


def test_diagnostics_give_a_health_line_and_a_reply_when_a_node_changes_level(ctl_link) -> None:  # type: ignore[no-untyped-def]
    from bike_rig.pipeline.diagnostics import Level, Status, StatusReport

    ctl, link, _ = ctl_link

    def report(node: str, **levels: Level) -> StatusReport:
        return StatusReport(tuple(Status.of(node, c, lv, f"{c} is {lv.name}") for c, lv in levels.items()))

    link.events_out += [report("driver", source=Level.OK, samples=Level.OK), report("recorder", disk=Level.OK)]
    assert [r for r in ctl.pump() if r.text.startswith("health")] == []  # first seen OK: nothing to say
    assert ctl.health.line() == "driver OK · recorder OK"
    link.events_out.append(report("driver", source=Level.OK, samples=Level.ERROR))
    (reply,) = ctl.pump()
    assert (reply.kind, reply.text) == ("health", "health: driver ERROR: samples: samples is ERROR")
    assert reply.data == {"node": "driver", "level": "ERROR"}
    assert ctl.health.line() == "driver ERROR (samples: samples is ERROR) · recorder OK"
    link.events_out.append(report("driver", source=Level.OK, samples=Level.ERROR))
    assert ctl.pump() == []  # the same level again: no new line
    link.events_out.append(report("driver", source=Level.OK, samples=Level.OK))
    (back,) = ctl.pump()
    assert back.kind == "health" and back.text.startswith("health: driver OK")


def test_a_stalled_or_lagging_node_is_one_health_line_each_way(ctl_link) -> None:  # type: ignore[no-untyped-def]
    from bike_rig.pipeline.diagnostics import Level, Status, StatusReport
    from bike_rig.pipeline.health import InputLag, input_lag_statuses

    ctl, link, t = ctl_link

    def heartbeat(node: str, lag_s: float) -> None:
        t[0] += 1.0
        ok = Status.of(node, "fits", Level.OK, "fine")
        link.events_out.append(StatusReport((ok, *input_lag_statuses(InputLag(lag_s, lag_s, 5), node))))

    def health() -> list[tuple[str, dict[str, object]]]:
        return [(r.text, r.data) for r in ctl.pump() if r.kind == "health"]

    heartbeat("fitter", 0.01)
    heartbeat("recorder", 0.01)
    assert health() == []
    heartbeat("fitter", 20.0)  # lagging: one line, no "health: fitter WARN" besides
    assert health() == [
        (
            "fitter 20 s behind: results will follow",
            {"node": "fitter", "level": "WARN", "standing": "behind", "seconds": 20.0},
        )
    ]
    heartbeat("fitter", 0.01)
    assert health() == []
    heartbeat("fitter", 0.01)
    ((text, data),) = health()
    assert text == "fitter caught up" and data["level"] == "OK"
    t[0] += 10.0  # nothing from either for 10 s: the recorder's process ended, the fitter's did not
    ctl.ended = lambda: {"recorder"}
    assert [text for text, _ in health()] == ["fitter silent for 10 s (stalled?): results will follow"]
    assert health() == []  # said once
    status = [r.text for r in ctl.execute("status") if r.kind == "warning"]
    assert status == ["fitter silent for 10 s"]


def test_help_lists_every_command_and_typos_get_a_suggestion(ctl_link) -> None:  # type: ignore[no-untyped-def]
    """'help' lists each command once with its usage; 'strat' and 'reading gama …' suggest the word meant."""
    from bike_rig.session.controller import COMMANDS
    from bike_rig.session.readings import UnknownKeyError, parse_reading

    ctl = ctl_link[0]
    listed = ctl.execute("help")
    assert [r.kind for r in listed] == ["info"] * len(COMMANDS)
    assert [r.text.split()[0] for r in listed] == list(COMMANDS) and "reading KEY VALUE SIGMA" in listed[3].text
    (typo,) = ctl.execute("strat")
    assert typo.kind == "error" and typo.text == "unknown command 'strat' (did you mean 'start'?)"
    (far,) = ctl.execute("xyzzy")
    assert far.kind == "error" and "commands: start, stop" in far.text
    with pytest.raises(UnknownKeyError, match=r"did you mean 'gamma'\?") as caught:
        parse_reading("gama", "67", "0.1")
    assert "alpha<part>" not in str(caught.value)


def test_a_readings_file_marks_the_plans_readings_done(ctl_link) -> None:  # type: ignore[no-untyped-def]
    """A --readings file: the parameter node reads the file; the plan stops asking for its readings."""
    from bike_rig.core.loader import load_static_readings
    from bike_rig.session.plan import ItemState
    from bike_rig.session.setup import take_readings_file

    ctl = ctl_link[0]
    readings = list(ctl.session.plan.readings)
    assert all(ctl.session.state(i) is ItemState.TODO for i in readings)
    taken = take_readings_file(ctl, load_static_readings(config_file("bicycles/browser.yaml")))
    assert taken == len(readings) > 10
    assert all(ctl.session.state(i) is ItemState.DONE for i in readings)
    assert ctl.session.next_trial() is not None and not any(r.kind == "error" for r in ctl.execute("next"))
