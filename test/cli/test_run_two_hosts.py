"""``bike-rig run`` split over two hosts: the driver in one network namespace, the analysis in another.

Two network namespaces created by the test, joined by a veth pair with their own addresses
(10.213.N.1/30 and .2, no default route): nothing leaves the machine. The rig's host runs
``bike-rig run --only driver --peer <desk>``, the desk ``bike-rig run --without driver --peer
<rig>`` (fitter, parameter, model, recorder): discovery is unicast to the static peer with the
LOCALHOST discovery range (no multicast at all). The simulated session is seeded, so the desk's
bag must hold the same periods, bit for bit, as a run of the whole graph on one host; and a
link that drops for a few seconds mid-session must leave no trial silently short: a trial is
either complete (every sample the driver announced, the same period: the gyro topic is
reliable with a transient-local history of 50 000 batches, so the driver sends again what the
desk missed) or flagged.

Skipped when not root or without ``ip netns`` (CI here runs as root).
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader

from bike_rig.config.paths import config_file
from bike_rig.config.topics import GYRO
from bike_rig.core.period.result import TRIAL_FLAG_CODES
from bike_rig.offline.info import TrialSummary, summarize
from test.support.processes import RosProcess
from test.support.wait import wait_until

pytestmark = pytest.mark.ros

#: Trials of the short rig (one per period of the paper's 13).
TRIALS = 13
#: How long the link stays down, s (wall clock).
DROP_S = 3.0


def _netns_usable() -> str:
    """Why the test cannot run here ("" if it can)."""
    if os.geteuid() != 0:
        return "needs root to create network namespaces"
    if shutil.which("ip") is None:
        return "needs iproute2's ip"
    name = f"brchk{os.getpid()}"
    done = subprocess.run(["ip", "netns", "add", name], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        return f"ip netns add fails: {done.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", name], check=False)
    return ""


@dataclass(frozen=True)
class Hosts:
    """The two namespaces: the rig's (driver) and the desk's (analysis)."""

    rig: str
    desk: str
    rig_link: str
    rig_address: str
    desk_address: str


def _ip(*argv: str) -> None:
    subprocess.run(["ip", *argv], check=True, capture_output=True, text=True)


@pytest.fixture(scope="module")
def hosts() -> Iterator[Hosts]:
    """Two namespaces joined by a veth pair; deleted (with the pair) however the tests end."""
    reason = _netns_usable()
    if reason:
        pytest.skip(reason)
    tag = os.getpid() % 100_000
    net = f"10.213.{tag % 250}"
    h = Hosts(f"br2h{tag}r", f"br2h{tag}d", f"v2h{tag}r", f"{net}.1", f"{net}.2")
    made: list[str] = []
    try:
        for ns in (h.rig, h.desk):
            _ip("netns", "add", ns)
            made.append(ns)
        _ip("link", "add", h.rig_link, "netns", h.rig, "type", "veth", "peer", "name", f"v2h{tag}d", "netns", h.desk)
        for ns, link, address in ((h.rig, h.rig_link, h.rig_address), (h.desk, f"v2h{tag}d", h.desk_address)):
            _ip("-n", ns, "addr", "add", f"{address}/30", "dev", link)
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "link", "set", link, "up")
        yield h
    finally:
        for ns in made:  # deleting a namespace deletes its end of the pair, and so the pair
            subprocess.run(["ip", "netns", "del", ns], check=False)


def _rig(directory: Path) -> Path:
    """A short rig: one 15 s trial per period, no beating (every trial gets a period)."""
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, "duration": 15})
    data["coupled_swing"].update({"probability": 0.0, "trials": []})
    path = directory / "rig.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def _driver_params(rig: Path, time_scale: int, exit_when_done: bool) -> list[str]:
    params = {"rig": rig, "bicycle": "bicycles/browser.yaml", "time_scale": time_scale, "seed": 4}
    params["exit_when_done"] = "true" if exit_when_done else "false"
    return [arg for k, v in params.items() for arg in ("--param", f"driver.{k}={v}")]


def _bike_rig(ns: str | None, *argv: str) -> list[str]:
    prefix = ["ip", "netns", "exec", ns] if ns else []
    return [*prefix, sys.executable, "-m", "bike_rig.cli.main", *argv]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory, ros_domain_id: int) -> dict[str, TrialSummary]:
    """The whole graph on one host (loopback), recorded: the trials by id."""
    from bike_rig.ros.env import ros_environment

    tmp = tmp_path_factory.mktemp("one_host")
    rig = _rig(tmp)
    cmd = _bike_rig(None, "run", "--out", "s", *_driver_params(rig, 100, True))
    done = subprocess.run(
        cmd, cwd=tmp, env=ros_environment(domain_id=ros_domain_id), capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return {t.trial_id: t for t in summarize(tmp / "s" / "bag").trials}


def _split_run(
    hosts: Hosts, tmp: Path, ros_domain_id: int, time_scale: int, drop_after: int | None = None
) -> tuple[dict[str, TrialSummary], list[str]]:
    """The driver in the rig's namespace, the rest at the desk; returns the desk's trials and stdout.

    Args:
        hosts: The namespaces.
        tmp: The test's folder (the session folders ``rig`` and ``desk`` go there).
        ros_domain_id: The run's domain id (both hosts).
        time_scale: The simulated driver's speed-up.
        drop_after: Take the rig's end of the link down for :data:`DROP_S` when this many
            trials have started (as the rig's own listener sees them), then up again.
    """
    from bike_rig.ros.env import ros_environment

    env = ros_environment(domain_id=ros_domain_id)
    rig = _rig(tmp)
    desk_cmd = _bike_rig(
        hosts.desk, "run", "--without", "driver", "--peer", hosts.rig_address, "--out", str(tmp / "desk")
    )
    rig_cmd = _bike_rig(
        hosts.rig,
        "run",
        "--only",
        "driver",
        "--peer",
        hosts.desk_address,
        "--out",
        str(tmp / "rig"),
        *_driver_params(rig, time_scale, exit_when_done=drop_after is None),
    )
    desk = RosProcess("desk", desk_cmd, env, tmp)
    driver: RosProcess | None = None
    results: set[str] = set()
    started: set[str] = set()

    def desk_line() -> None:
        """Read the desk's next trial line: a start ("recording") or a result ("T = " / "no period")."""
        rest = desk.expect("trial", 60)
        if rest.endswith(": recording"):
            started.add(rest.split()[0].rstrip(":"))
        elif ": T = " in rest or ": no period" in rest:
            results.add(rest.split()[0])

    try:
        driver = RosProcess("rig", rig_cmd, env, tmp)
        if drop_after is not None:
            # the desk's own view decides when: it has seen the trials start and its recorder takes
            # the gyro topic, so the bag shows when each batch was sent and taken
            while len(started) < drop_after:
                desk_line()
            recorder_log = tmp / "desk" / "logs" / "recorder.log"
            wait_until(
                lambda: recorder_log.is_file() and f"recording {GYRO.name} " in recorder_log.read_text(),
                "the desk's recorder recording the gyro topic",
                describe=desk.describe,
            )
            # the outage as written is the span the link was surely down: from after ``down`` returned
            # to before ``up`` is issued (wall clock, ns: the clock of the DDS source timestamps)
            _ip("-n", hosts.rig, "link", "set", hosts.rig_link, "down")
            try:
                down = time.time_ns()
                time.sleep(DROP_S)  # the outage itself is what is tested: it must last
                up = time.time_ns()
            finally:
                _ip("-n", hosts.rig, "link", "set", hosts.rig_link, "up")
            (tmp / "outage").write_text(f"{down} {up}", encoding="utf-8")
        while len(results) < TRIALS:  # each trial's result at the desk
            desk_line()
        assert desk.stop() == 0, desk.describe()
        if drop_after is not None:
            assert driver.stop() == 0, driver.describe()
        else:
            assert driver.proc.wait(timeout=30) == 0, driver.describe()
    finally:
        desk.stop()
        if driver is not None:
            driver.stop()
    trials = {t.trial_id: t for t in summarize(tmp / "desk" / "bag").trials}
    return trials, desk.lines


def test_the_desk_records_the_same_periods_as_one_host(
    hosts: Hosts, reference: dict[str, TrialSummary], tmp_path: Path, ros_domain_id: int
) -> None:
    trials, lines = _split_run(hosts, tmp_path, ros_domain_id, time_scale=100)
    assert sorted(trials) == sorted(reference) and len(trials) == TRIALS, "\n".join(lines)
    for key, ref in reference.items():
        t = trials[key]
        assert t.state == "complete" and t.samples == t.announced == ref.samples == 15_000, t
        # the seeded simulation and the deterministic fit: bit-identical when no sample is lost
        assert (t.period, t.period_sigma, t.flags) == (ref.period, ref.period_sigma, ref.flags), (t, ref)
        assert t.usable and math.isfinite(t.period)


@dataclass(frozen=True)
class _Batch:
    """A recorded gyro batch's times, ns since the epoch."""

    sent: int  # the MCAP publish time: the DDS source timestamp, set by the rig's writer
    received: int  # the MCAP log time: when the desk's recorder took it


def _gyro_times(bag: Path) -> list[_Batch]:
    """Every gyro batch in the bag, with its send and take times."""
    out = []
    for path in sorted(bag.glob("*.mcap")):
        with path.open("rb") as f:
            for _, _, message in make_reader(f).iter_messages(topics=[GYRO.name]):
                out.append(_Batch(message.publish_time, message.log_time))
    assert out, f"no {GYRO.name} batch in {bag}"
    return out


def _silently_short(t: TrialSummary) -> bool:
    """A trial fitted as usable from fewer samples than the driver announced."""
    return bool(t.usable) and (t.announced is None or t.samples < t.announced)


def test_a_link_that_drops_mid_session_leaves_no_trial_silently_short(
    hosts: Hosts, reference: dict[str, TrialSummary], tmp_path: Path, ros_domain_id: int
) -> None:
    t0 = time.monotonic()
    trials, lines = _split_run(hosts, tmp_path, ros_domain_id, time_scale=10, drop_after=3)
    wall = time.monotonic() - t0
    out = "\n".join(lines)
    down, up = (int(t) for t in (tmp_path / "outage").read_text(encoding="utf-8").split())
    batches = _gyro_times(tmp_path / "desk" / "bag")
    sent = [b.sent for b in batches]
    # the outage fell mid-stream for the rig: it sent batches before it, during it and after it
    # (by the source stamps: the desk's take times lag by however far its recorder is behind)
    assert min(sent) < down < up < max(sent), (min(sent), down, up, max(sent))
    during = [b for b in batches if down < b.sent < up]
    assert during, "the rig sent no batch while the link was down"
    # nothing bypassed the link: no batch sent while it was surely down reached the desk before
    # ``up`` (the link came back after that); those sent then arrived later, sent again
    early = [b for b in during if b.received < up]
    assert not early, f"{len(early)} of {len(during)} batches sent while the link was down reached the desk before"
    received = sorted(b.received for b in batches)
    pause = max(b - a for a, b in zip(received, received[1:])) / 1e9  # (shown only: it shrinks with a busy recorder)
    assert sorted(trials) == sorted(reference), out
    complete, flagged = [], []
    for key, ref in reference.items():
        t = trials[key]
        assert not _silently_short(t), t
        if t.state == "complete" and t.samples == t.announced == ref.samples:
            assert (t.period, t.period_sigma) == (ref.period, ref.period_sigma), (t, ref)
            complete.append(key)
        else:  # a trial the link cut short is flagged by the fitter (gap, sample count, no stop...)
            assert not t.usable and {c.value for c in TRIAL_FLAG_CODES} & set(t.flags), t
            flagged.append(key)
    print(
        f"link down {DROP_S} s after 3 trials: {len(during)} batches sent meanwhile, all taken after it; longest "
        f"pause at the desk {pause:.2f} s; {len(complete)} trials complete, "
        f"{len(flagged)} flagged; {wall:.1f} s wall"
    )
