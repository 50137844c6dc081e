"""The operator console driven as a person drives it: under tmux, through a whole simulated session.

Real node processes over DDS (the console starts the graph: the operator-driven simulated rig,
the fitter, the parameter and model nodes and the recorder). Every static reading is typed in,
every trial started from the keyboard (F2), one trial is recorded too short, flagged and
redone, one reading is corrected; at the end the bag replays offline, with no external file, to
the same 25 parameters as the offline core on the same trials and readings.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.offline.session import read_session
from bike_rig.session.controller import COMMAND_HELP
from bike_rig.session.plan import ReadingItem, plan_from_rig
from test.support.sessions import kill_session, session_pids, wait_gone
from test.support.tmux import TMUX, TmuxSession, flatten
from test.support.wait import WAIT_TIMEOUT_S, wait_until

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
TIME_SCALE = 150.0


def _enter(tmux: TmuxSession, key: str, value: float, sigma: float, mistake: bool = False) -> None:
    """Enter a reading as the console offers it (F2 puts ``reading KEY`` on the command line; mistakes corrected)."""
    tmux.keys("F2")
    tmux.wait_for(rf"(?m)^\s*reading {re.escape(key)}\s*$")  # (on the command line)
    tmux.type(f"{value * 1.01 if mistake else value!r} {sigma!r}")
    tmux.keys("Enter")
    tmux.wait_for(rf"entered {key} =")
    if mistake:
        tmux.type(f"reading {key} {value!r} {sigma!r}")
        tmux.keys("Enter")
        tmux.wait_for(rf"corrected {key} =")


def _new_trial(tmux: TmuxSession, item_id: str, known: set[str], timeout_s: float = 30.0) -> str:
    """The trial id of ``item_id``'s new recording (not one of ``known``).

    From its start line, or, on a loaded machine when warnings have scrolled that away, from its
    result line.
    """
    pattern = rf"recording {re.escape(item_id)} as (\S+) \(|{re.escape(item_id)} (\S+): (?:T = |no period)"
    deadline = time.monotonic() + timeout_s
    screen = ""
    while time.monotonic() < deadline:
        screen = tmux.screen()
        fresh = [a or b for a, b in re.findall(pattern, flatten(screen)) if (a or b) not in known]
        if fresh:
            return fresh[-1]
        time.sleep(0.05)
    raise AssertionError(f"no new recording of {item_id} in {timeout_s} s; last screen:\n{screen}")


def _record(tmux: TmuxSession, item_id: str) -> int:
    """Record ``item_id`` with F2 until it is ok (a flagged trial is redone, as offered); the redos.

    Ok: the title's count of items done goes up; flagged: the plan's row of the item says REDO
    (it says ``recording`` from the start's reply on). Neither needs the result line, which a long
    REDO reason may push out of a small log pane.
    """
    # (trials of the item already on the screen, e.g. a REDO before: not this recording)
    known = {
        a or b
        for a, b in re.findall(
            rf"recording {re.escape(item_id)} as (\S+) \(|{re.escape(item_id)} (\S+): "
            r"(?:T = |no period)",
            flatten(tmux.screen()),
        )
    }
    for attempt in range(3):
        done = int(re.search(r"· (\d+)/\d+ done", tmux.screen()).group(1))  # type: ignore[union-attr]
        tmux.keys("F2")
        known.add(_new_trial(tmux, item_id, known))
        screen = tmux.wait_for(rf"· {done + 1}/\d+ done|\b{re.escape(item_id)}\s+REDO\s", 60)
        if re.search(rf"· {done + 1}/\d+ done", screen):
            return attempt
    raise AssertionError(f"{item_id}: flagged three times")


@pytest.fixture
def readings() -> dict[str, tuple[float, float]]:
    """Plausible static readings of the Browser (a simulated session's, seed 5)."""
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    sim = simulate_session(truth, rig, 5, name)
    return {k: (r.value, r.sigma) for k, r in sim.readings.items() if not k.startswith(("Tc", "Tt"))}


@pytest.mark.skipif(not Path(TMUX).exists(), reason="tmux is installed by tools/setup_debian.sh (make test)")
def test_a_whole_session_at_the_console(tmp_path: Path, ros_env: dict[str, str], readings) -> None:  # type: ignore[no-untyped-def]
    folder = tmp_path / "session"
    argv = [str(BIKE_RIG), "session", "--time-scale", str(TIME_SCALE), "--seed", "4", "--output", str(folder)]
    tmux = TmuxSession(argv, ros_env, tmp_path)
    plan = plan_from_rig(load_rig(config_file("rig.yaml")))
    try:
        tmux.wait_for(r"· 0/68 done", 60)
        flagged = False
        corrected = False
        redone = 0
        for item in plan.items:
            if isinstance(item, ReadingItem):
                mistake = item.key == "w" and not corrected  # the operator corrects the wheelbase
                _enter(tmux, item.key, *readings[item.key], mistake=mistake)
                corrected |= mistake
                continue
            if not flagged and item.key == "TtB2":
                tmux.type(f"start {item.item_id} 2")  # too short: too few cycles
                tmux.keys("Enter")
                # (the plan's row: the result line in the log pane may be scrolled away by warnings)
                tmux.wait_for(rf"\b{re.escape(item.item_id)}\s+REDO\s", WAIT_TIMEOUT_S)
                tmux.wait_for(rf"F2 records {re.escape(item.item_id)} again", flat=True)
                flagged = True
            redone += _record(tmux, item.item_id)
        screen = tmux.wait_for(r"68/68 done\s+weave [0-9.]+±[0-9.]+\s+capsize [0-9.]+±[0-9.]+ m/s", 60)
        shown = re.search(r"weave ([0-9.]+)±", screen).group(1)  # type: ignore[union-attr]
        weave, half_digit = float(shown), 0.5 * 10.0 ** -len(shown.partition(".")[2])
        tmux.keys("F10")
        tmux.wait_for(r"Quit\? F10 or Ctrl-C again leaves", 30, flat=True)  # asked first
        tmux.keys("F10")
        tmux.wait_for(r"\[exit 0\]", 60)
    finally:
        tmux.close()
        kill_session(folder)
    assert flagged and corrected
    bag = folder / "bag"
    out = subprocess.run(
        [str(BIKE_RIG), "replay", str(bag), "--json"], capture_output=True, text=True, timeout=120, env=ros_env
    )
    assert out.returncode == 0, out.stderr
    replayed = json.loads(out.stdout)
    # the offline core on the bag's own trials and readings gives what the live graph published
    assert replayed["complete"] and replayed["live"]["identical"], replayed["live"]
    assert not replayed["settings"]["readings_swapped"]
    assert abs(replayed["weave_speed"] - weave) <= half_digit * (1 + 1e-9)  # as the console showed it
    recorded = read_session(bag)
    w_entries = [(e.value, e.note) for e in recorded.reading_entries if e.key == "w"]
    assert [v for v, _ in w_entries] == [readings["w"][0] * 1.01, readings["w"][0]]  # the mistake and its correction
    assert {e.key for e in recorded.reading_entries} == set(readings)
    short = [t for t in replayed["trials"] if t["measurement_key"] == "TtB2" and "too_few_cycles" in t["flags"]]
    assert short, [(t["measurement_key"], t["flags"]) for t in replayed["trials"]]  # the trial recorded too short
    assert len(replayed["trials"]) == len(plan.trials) + 1 + redone  # every trial, the forced and the flagged redos


def _log_rows(screen: str) -> list[str]:
    """The log pane's rows of a screen, each right-stripped (the rest changes as it likes: health, sparkline)."""
    rows = screen.splitlines()
    top = next((i for i, row in enumerate(rows) if "─log ·" in row), -1)
    bottom = next((i for i, row in enumerate(rows) if " command (" in row), len(rows))
    return [flatten(row) for row in rows[top + 1 : bottom]]


def _scrolled_up(before: list[str], now: list[str]) -> bool:
    """``now`` shows the log scrolled up from ``before``: changed, and not merely moved up by new lines at its end.

    A line added at the log's end moves every row up (``before`` shifted); a page up shows the rows above
    (``before``'s rows gone, or moved down when the log's top is reached).
    """
    n = len(before)
    return now != before and not any(len(now) == n and now[: n - k] == before[k:] for k in range(1, n))


def _read_back(tmux: TmuxSession, first: str, wanted: list[str]) -> None:
    """Read a reply from its first line ``first`` on, scrolling the log up with PgUp as the screen says; End returns.

    Every pattern of ``wanted`` must be seen on some screen on the way (a reply longer than the log pane);
    the last one first, at the log's end. Each PgUp is followed by a wait for the scroll itself, so that no
    page is passed over unread (a new line at the log's end changes the pane too, without a scroll).
    """
    rows = _log_rows(tmux.wait_for(wanted[-1], WAIT_TIMEOUT_S, flat=True))
    seen = " ".join(rows)
    for _ in range(20):
        if re.search(first, seen):  # (the reply's first line: what it holds lies below)
            break
        tmux.keys("PageUp")

        def scrolled(before: list[str] = rows) -> list[str] | None:
            now = _log_rows(tmux.screen())
            return now if _scrolled_up(before, now) else None

        rows = wait_until(scrolled, "the log pane to scroll up a page", describe=tmux.screen)
        seen = f"{seen} {' '.join(rows)}"
    missing = [w for w in wanted if not re.search(w, seen)]
    assert not missing and re.search(first, seen), f"never seen {missing or first}; last screen:\n{tmux.screen()}"
    tmux.keys("End")


@pytest.mark.skipif(not Path(TMUX).exists(), reason="tmux is installed by tools/setup_debian.sh (make test)")
@pytest.mark.parametrize(("width", "height"), [(80, 24), (200, 50)], ids=["80x24", "200x50"])
def test_a_session_with_a_readings_file_at_the_console(  # type: ignore[no-untyped-def]
    tmp_path: Path, ros_env: dict[str, str], readings, width: int, height: int
) -> None:
    """A whole simulated session with ``--readings``: the console lays itself out for the terminal.

    The readings file marks every reading done; the connection line names the ROS domain and the view
    line; ``help`` lists every command; a trial far down the plan is flagged and the plan follows it
    (REDO in sight); every trial is recorded from the keyboard to the end of the plan; ``params``, a
    26-line reply with its echo, is read whole (scrolled with PgUp where it does not fit; the log pane at
    200×50 is tall enough for it).
    """
    folder = tmp_path / "session"
    file = tmp_path / "readings.yaml"
    file.write_text(dump_measurements_yaml(Measurements("Browser", {k: _reading(*v) for k, v in readings.items()}, "")))
    argv = [
        str(BIKE_RIG),
        "session",
        "--time-scale",
        str(TIME_SCALE),
        "--seed",
        "4",
        "--readings",
        str(file),
        "--output",
        str(folder),
    ]
    tmux = TmuxSession(argv, ros_env, tmp_path, width, height)
    plan = plan_from_rig(load_rig(config_file("rig.yaml")))
    domain = ros_env["ROS_DOMAIN_ID"]
    late = plan.trials[len(plan.trials) * 2 // 3].item_id  # far below the first screen of the plan
    try:
        tmux.wait_for(rf"· {len(plan.readings)}/{len(plan.items)} done", 60)
        tmux.wait_for(rf"ROS domain {domain} · live view: bike-rig view --domain-id {domain}", 30, flat=True)
        tmux.type("help")
        tmux.keys("Enter")
        _read_back(tmux, r"> help", [rf"{re.escape(u)}\s+{re.escape(what.split()[0])}" for u, what in COMMAND_HELP])
        flagged = False
        for item in plan.trials:
            if item.item_id == late:
                tmux.type(f"start {late} 2")  # too short: too few cycles
                tmux.keys("Enter")
                tmux.wait_for(rf"F2 records {re.escape(late)} again", 60, flat=True)
                tmux.wait_for(rf"{re.escape(late)}\s+REDO", 30)  # the plan follows the item to redo
                flagged = True
            _record(tmux, item.item_id)
        tmux.wait_for(rf"{len(plan.items)}/{len(plan.items)} done\s+weave [0-9.]+±[0-9.]+", 120)
        tmux.wait_for(r"weave [0-9.]+ ± [0-9.]+ m/s, capsize", 60, flat=True)  # (the set is in: params answers)
        tmux.type("params")
        tmux.keys("Enter")
        names = [rf"(?<![A-Za-z]){re.escape(n)}\s+-?[0-9.]+(?:e[-+]?\d+)? ± " for n in PARAMETER_NAMES]
        _read_back(tmux, r"> params", names)
        if height >= 50:  # the log pane holds the whole reply with its echo (late lines may scroll it, not its size)
            screen = tmux.screen()
            assert "─log ·" in screen and " command (" in screen, screen
            assert len(_log_rows(screen)) >= len(names) + 1, screen
        tmux.keys("C-c")
        tmux.wait_for(r"Quit\? F10 or Ctrl-C again leaves", 30, flat=True)  # Ctrl-C asks too (no textual notice)
        tmux.keys("C-c")
        tmux.wait_for(r"\[exit 0\]", 60)
    finally:
        tmux.close()
        kill_session(folder)
    assert flagged


def _reading(value: float, sigma: float) -> Reading:
    return Reading(value, sigma)


@pytest.mark.skipif(not Path(TMUX).exists(), reason="tmux is installed by tools/setup_debian.sh (make test)")
def test_closing_the_terminal_ends_the_session_and_its_graph(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """SIGHUP (the terminal or SSH link closed): the console stops the graph and leaves; the bag is closed."""
    folder = tmp_path / "session"
    tmux = TmuxSession([str(BIKE_RIG), "session", "--output", str(folder)], ros_env, tmp_path)
    try:
        tmux.wait_for(r"· 0/68 done", 60)
        # the nodes' /diagnostics: one level per node on the health line
        health = r"Health:(?=.*\bdriver OK\b)(?=.*\bfitter OK\b)(?=.*\bparameter WARN\b)"
        tmux.wait_for(health, WAIT_TIMEOUT_S, flat=True)
        pids = session_pids(folder)
        assert set(pids) >= {"console", "driver", "recorder"}
    finally:
        tmux.close()  # the terminal goes away: SIGHUP
    try:
        assert wait_gone(pids, 30) == []
        assert (folder / "bag" / "metadata.yaml").is_file()  # written when the recorder closes the bag
    finally:
        kill_session(folder)
