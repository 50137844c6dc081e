"""Resume: a session whose console is killed mid-session continues from its bag (real node processes).

The session is scripted through ``bike-rig session --plain --json``; the console is SIGKILLed
between two trials (its nodes end with it, the recorder closing the bag); ``--resume`` continues
it in a new session folder. The finished session must equal the uninterrupted one: the same
simulated rig (seed) recording every trial in plan order with the same readings typed in, which
``simulate_session`` gives bit for bit and the offline replay turns into the reference.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
from dataclasses import replace
from pathlib import Path
from typing import IO, Any

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.offline.replay import replay_bag
from bike_rig.pipeline.readings import canonical_order
from bike_rig.session.plan import SessionPlan, plan_from_rig
from test.support.sessions import kill_session, plan_script, session_pids, wait_gone

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
SEED = 3


def _lines(stream: IO[str], out: queue.Queue[dict[str, Any]]) -> None:
    for line in stream:
        out.put(json.loads(line))


def _scripts(plan: SessionPlan, sim: SimulatedSession) -> tuple[list[str], list[str]]:
    """The whole session in plan order, cut after a trial's result near the middle.

    A reading is typed wrong before the cut and corrected after it.
    """
    script = plan_script(plan, sim.readings)
    half = script.index("wait 60", len(script) // 2) + 1
    first, rest = script[:half], script[half:]
    right = next(line for line in first if line.startswith("reading"))
    key = right.split()[1]
    first.insert(first.index(right) + 1, f"reading {key} {2 * sim.readings[key].value!r} {sim.readings[key].sigma!r}")
    rest.insert(0, right)
    return first, rest


def _run_then_kill(argv: list[str], script: list[str], trials: int, folder: Path, env: dict[str, str]) -> list[Any]:
    """Run the console on ``script``; SIGKILL it once ``trials`` results are in. Its replies."""
    replies: queue.Queue[dict[str, Any]] = queue.Queue()
    seen: list[dict[str, Any]] = []
    with subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env) as console:
        try:
            assert console.stdin is not None and console.stdout is not None
            threading.Thread(target=_lines, args=(console.stdout, replies), daemon=True).start()
            console.stdin.write("\n".join(script) + "\n")
            console.stdin.flush()
            while sum(r["kind"] == "result" for r in seen) < trials:
                seen.append(replies.get(timeout=120))
            pids = session_pids(folder)
            os.kill(pids["console"], signal.SIGKILL)  # mid-session, between two trials
            console.wait(10)
            assert wait_gone(pids, 30) == []  # the nodes end with their console
        finally:
            kill_session(folder)
            console.kill()
    return seen


def _diagnosis(stderr: str, lines: list[dict[str, Any]], folder: Path) -> str:
    """What went wrong: the errors, the flagged results, the nodes' warnings."""
    out = [stderr[-1000:], *(x["text"] for x in lines if x["kind"] in ("error", "warning"))]
    out += [x["text"] for x in lines if x["kind"] == "result" and x.get("state") != "ok"]
    for log in sorted((folder / "logs").glob("*.log")):
        loud = [line for line in log.read_text().splitlines() if "WARN" in line or "ERROR" in line]
        out += [f"{log.name}: {line[:300]}" for line in loud]
    return "\n".join(out[-60:])


def test_a_killed_session_resumes_from_its_bag_to_the_uninterrupted_result(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    sim = simulate_session(truth, rig, SEED, name)
    plan = plan_from_rig(rig)
    first, rest = _scripts(plan, sim)
    first_trials = sum(line.startswith("start") for line in first)
    a, b = tmp_path / "a", tmp_path / "b"
    common = [str(BIKE_RIG), "session", "--plain", "--json", "--time-scale", "150", "--seed", str(SEED)]
    seen = _run_then_kill([*common, "--output", str(a)], first, first_trials, a, ros_env)
    assert (a / "bag" / "metadata.yaml").is_file()  # the recorder closed the bag on its way out
    assert all(r["state"] == "ok" for r in seen if r["kind"] == "result")

    stdin = "\n".join(["wait 60", "status", *rest, "wait complete 60", "params", "quit"]) + "\n"
    try:
        done = subprocess.run(
            [*common, "--output", str(b), "--resume", str(a)],
            input=stdin,
            capture_output=True,
            text=True,
            timeout=600,
            env=ros_env,
        )
    finally:
        kill_session(b)
    lines = [json.loads(x) for x in done.stdout.splitlines()]
    assert done.returncode == 0, _diagnosis(done.stderr, lines, b)
    assert next(x for x in lines if "resuming" in x)["resuming"] == [0, first_trials], lines[:3]
    back = next(x for x in lines if "resumed" in x)
    assert back["resumed"] == first_trials
    progress = next(x for x in lines[lines.index(back) :] if "done" in x)
    # every reading typed and every trial recorded before the kill counts (the wrong one too)
    assert progress["done"] == first_trials + len({line.split()[1] for line in first if line.startswith("reading")})
    results = [x for x in lines if x["kind"] == "result"]
    assert len(results) == len(plan.trials)  # the recorded trials' results again, then the new ones
    new_ids = {x["trial_id"] for x in lines if x.get("command") == "start"}
    assert len(new_ids) == len(plan.trials) - first_trials
    assert not new_ids & {x["trial_id"] for x in results[:first_trials]}
    live = {x["name"]: x for x in lines if "name" in x and "value" in x}
    assert len(live) == 26

    # the resumed session's bag holds the whole session and replays to what the console showed
    replayed = replay_bag(b / "bag")
    got = replayed.session.complete_parameters().parameters
    for k, p in live.items():
        assert got.value(k) == p["value"], k
    # ... which is the uninterrupted session: the same trials and readings, recorded in one go
    # (readings typed in are kept in the canonical order of a measurement file: so are these,
    # as the order of the inputs' covariance changes σ in the last bit)
    typed = replace(sim, readings={k: sim.readings[k] for k in sorted(sim.readings, key=canonical_order)})
    reference = replay_bag(write_simulated_bag(tmp_path / "uninterrupted", typed))
    want = reference.session.complete_parameters().parameters
    periods = {t.trial_id: t.result.period for t in replayed.trials}
    assert periods == {t.trial_id: t.result.period for t in reference.trials}
    for k in live:
        assert (got.value(k), got.sigma(k)) == (want.value(k), want.sigma(k)), k
