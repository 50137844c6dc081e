"""``bike-rig run``: start the rig's graph as processes, print each trial's result, stop cleanly.

The graph (``config/graph.yaml`` by default: the simulated rig's driver, fitter, parameter,
model and recorder) runs until Ctrl-C, until a node dies, or until a node finishes by itself
(a driver with ``exit_when_done``). Meanwhile a listener in this process
(:class:`bike_rig.ros.nodes.run_monitor.GraphMonitor`) prints every trial as it starts and its
result as the fitter publishes it: trial id, measurement key, period ± σ, cycles, r², ``ok``
or ``REDO`` with every flag's reason and advice. At the end it prints a summary and where the
session is:

* ``<session>/bag``: the recorded bag (``--param recorder.output=DIR`` puts it elsewhere);
* ``<session>/logs/<node>.log``: each node's output (``--log-dir DIR`` puts them elsewhere),
  and ``<session>/logs/pids``: this command's and each node's process id;

with ``<session>`` = ``--out DIR``, by default ``bike_rig_sessions/<YYYYmmdd-HHMMSS>`` in the
current directory. A bag in which no trial was recorded (a run that failed at start) is
removed.

A node that falls silent on ``/diagnostics`` while its process lives (stopped, swapping, in a
debugger), or that says it is behind its input, is one line on stderr when that starts and one
when it has caught up (:class:`bike_rig.pipeline.stalls.StallWatch`).

Ctrl-C stops the driver first: it publishes ABORT for a trial in progress (recorded, and
fitted as ``aborted``); the command then waits for the last results (trial results, the
parameter set holding them, its model): as long as they keep coming (:data:`SETTLE_S` at most
between two), and while a node is stalled or behind, up to :data:`SETTLE_MAX_S` in all; then it
stops the other nodes, the recorder last. Giving up is one line; another Ctrl-C ends the wait.

Every mistake found before the start (an unknown ``--param`` name, a bad value, a missing
file, a ``--domain-id`` or ``ROS_DOMAIN_ID`` outside 0..101) is one line with exit status 2,
and nothing is started or created.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config.paths import config_dir, config_file
from ..core.errors import BikeRigError
from ..core.textfmt import format_speed, format_uncertain, terminal_safe
from ..pipeline.stalls import StallWatch
from .commands import HELP
from .common import UsageError

if TYPE_CHECKING:
    from ..pipeline.assemble import SessionParameters
    from ..pipeline.fit import TrialFit
    from ..pipeline.model import StabilitySweep
    from ..ros.launch import Graph
    from ..ros.nodes.run_monitor import GraphMonitor, MonitorRecord
    from ..ros.running import RunningGraph

__all__ = ["SETTLE_MAX_S", "SETTLE_S", "RunTracker", "add_parser", "run", "session_folder"]

#: After the driver stopped, the longest wait for a result still awaited while nothing arrives, s.
SETTLE_S = 5.0
#: After the driver stopped, the longest wait in all while a node is stalled or behind its input, s.
SETTLE_MAX_S = 120.0
#: After the driver stopped, the results are in once nothing is pending and nothing arrived for this long, s.
QUIET_S = 0.5
#: How long the driver may take to stop after SIGINT (it waits for its ABORT to be acknowledged), s.
STOP_S = 15.0
#: How often the loop looks at the nodes and the listener, s.
POLL_S = 0.1
#: Giving up on an awaited result needs every node heard within this (none about to be found stalled), s.
HEARD_S = 2.0

_DRIVER = "bike_rig.ros.nodes.driver"
_PARAMETER = "bike_rig.ros.nodes.parameter"
_MODEL = "bike_rig.ros.nodes.model"
_RECORDER = "bike_rig.ros.nodes.recorder"
#: The nodes that publish a ``/diagnostics`` heartbeat (followed even if never heard).
_HEARTBEAT_MODULES = frozenset({_DRIVER, "bike_rig.ros.nodes.fitter", _PARAMETER, _MODEL, _RECORDER})


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``run``."""
    q = subparsers.add_parser(
        "run",
        help=HELP["run"],
        description="Start every node of a graph file as its own process on localhost with a ROS_DOMAIN_ID of "
        "its own, print each trial's result as it is fitted, and at the end a summary and where the session "
        "folder (bag/ and logs/) is. Ctrl-C aborts a trial in progress and stops the nodes cleanly; a node "
        "that dies is reported and the graph is stopped. The default graph is the simulated rig (Browser, "
        "in real time): --param driver.time_scale=25 plays it 25 times faster.",
    )
    q.add_argument(
        "--config",
        help="graph file (default: config/graph.yaml; a relative name not found here: from the config folder)",
    )
    q.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NODE.NAME=VALUE",
        help="a node parameter, e.g. driver.time_scale=25 or driver.session=DIR/session.yaml (repeatable); "
        "relative file names are taken from the current directory, else from the config folder",
    )
    q.add_argument(
        "--domain-id", metavar="N", help="ROS_DOMAIN_ID, 0..101 (default: the environment's, else a free one)"
    )
    q.add_argument(
        "--only",
        action="append",
        default=[],
        metavar="NODE",
        help="start only this node of the graph (repeatable), e.g. --only driver on the rig's host",
    )
    q.add_argument(
        "--without",
        action="append",
        default=[],
        metavar="NODE",
        help="start every node but this one (repeatable), e.g. --without driver at the desk",
    )
    q.add_argument(
        "--peer",
        action="append",
        default=[],
        metavar="ADDRESS",
        help="the other host's IP address when the graph is split over two hosts (ROS_STATIC_PEERS; repeatable)",
    )
    q.add_argument("--out", metavar="DIR", help="new session folder (default: ./bike_rig_sessions/<time>)")
    q.add_argument("--log-dir", metavar="DIR", help="node logs go here (default: <session folder>/logs)")
    q.set_defaults(func=run)


# ---------------------------------------------------------------------------------------------- what is printed
@dataclass
class _Trial:
    trial_id: str
    key: str = ""
    sample_rate_hz: float = math.nan
    stopped: bool = False
    aborted: bool = False
    fit: TrialFit | None = None


@dataclass
class RunTracker:
    """The session as ``run`` follows it: every trial, the parameter set, the speeds; and the lines it prints.

    Fed the listener's records in arrival order (:meth:`add`); ROS-free.

    Attributes:
        trials: Every trial seen, by id, in order of appearance.
        parameters: The latest parameter set (None before the first).
        stability: The latest stability sweep (None before the first).
    """

    trials: dict[str, _Trial] = field(default_factory=dict)
    parameters: SessionParameters | None = None
    stability: StabilitySweep | None = None
    _announced_complete: bool = False

    def add(self, record: MonitorRecord) -> list[str]:
        """Take in one record; return the lines to print (none for most)."""
        from ..pipeline.acquire import TrialEventKind, TrialEventRecord
        from ..pipeline.assemble import SessionParameters
        from ..pipeline.fit import TrialFit
        from ..pipeline.model import StabilitySweep

        if isinstance(record, TrialEventRecord):
            t = self.trials.setdefault(record.trial_id, _Trial(record.trial_id))
            t.key = record.measurement_key or t.key
            if math.isfinite(record.sample_rate_hz) and record.sample_rate_hz > 0:
                t.sample_rate_hz = record.sample_rate_hz
            if record.kind is TrialEventKind.START:
                return [] if t.fit is not None else [f"trial {t.trial_id} ({t.key or '?'}): recording"]
            t.stopped = True
            if record.kind is TrialEventKind.ABORT and not t.aborted:
                t.aborted = True
                return [f"trial {t.trial_id} ({t.key or '?'}): ABORTED after {record.sample_count} samples"]
            return []
        if isinstance(record, TrialFit):
            return self._fit(record)
        if isinstance(record, SessionParameters):
            self.parameters = record
        elif isinstance(record, StabilitySweep):
            self.stability = record
        else:
            return []  # the run's monitor hands on no samples or readings
        # (the set and its model, in either order: they come from two processes)
        if (
            self.parameters is not None
            and self.parameters.complete
            and self.stability is not None
            and (not self._announced_complete)
        ):
            self._announced_complete = True
            return [f"parameter set complete: {self.speeds_text()}"]
        return []

    def _fit(self, fit: TrialFit) -> list[str]:
        t = self.trials.setdefault(fit.trial_id, _Trial(fit.trial_id, fit.measurement_key))
        t.key = t.key or fit.measurement_key
        first = t.fit is None
        if first or fit.n_samples > t.fit.n_samples:  # type: ignore[union-attr]
            t.fit = fit  # a restarted fitter re-publishes: keep the estimate from the most samples
        return result_lines(t.trial_id, t.key, fit, t.sample_rate_hz) if first else []

    def pending(self) -> list[str]:
        """Trials that stopped (or were aborted) and whose result has not arrived yet."""
        return [t.trial_id for t in self.trials.values() if t.stopped and t.fit is None]

    def awaiting(self, parameters: bool = True, model: bool = True) -> list[str]:
        """What is still to come, in words: trial results, the parameter set holding them, its model.

        Args:
            parameters: The graph has a parameter node (a set holding every usable result is due).
            model: The graph has a model node (a model is due once the set is complete).
        """
        out = []
        pending = self.pending()
        if pending:
            out.append(f"{len(pending)} trial result(s)")
        p = self.parameters
        if parameters:
            held = set() if p is None else {t for k in p.periods for t in k.trial_ids}
            keys = None if p is None else {k.key for k in p.periods} | set(p.missing)
            new = [
                t
                for t in self.trials.values()
                if t.fit is not None and t.fit.usable and (keys is None or t.key in keys) and t.trial_id not in held
            ]
            if new:
                out.append(f"the parameter set ({len(new)} result(s) not in it yet)")
        if model and p is not None and p.complete and self.stability is None:
            out.append("the model of the complete parameter set")
        return out

    def speeds_text(self) -> str:
        """The weave and capsize speeds with σ, as the model node published them last."""
        st = self.stability
        if st is None:
            return "no model yet"
        rider = " (with the paper's rider)" if st.rider else ""
        return f"weave speed {_speed(st.weave)}, capsize speed {_speed(st.capsize)}{rider}"

    def summary(self) -> list[str]:
        """The closing lines: trials done, ok / to redo / without result, the parameter set."""
        done = [t for t in self.trials.values() if t.fit is not None]
        ok = [t for t in done if t.fit is not None and t.fit.usable]
        redo = [t for t in self.trials.values() if t not in ok and (t.fit is not None or t.aborted)]
        open_ = [t for t in self.trials.values() if t.fit is None and not t.aborted]
        lines = [f"{len(self.trials)} trial(s): {len(ok)} ok, {len(redo)} to redo, {len(open_)} without a result"]
        for t in redo:
            lines.append(f"  REDO {t.trial_id} ({t.key or '?'}): {_reasons(t)}")
        if open_:
            lines.append("  without a result: " + ", ".join(t.trial_id for t in open_))
        p = self.parameters
        if p is None:
            lines.append("parameters: none published")
        elif p.complete:
            lines.append(f"parameters: complete ({p.bicycle}); {self.speeds_text()}")
        else:
            lines.append(f"parameters: incomplete ({p.bicycle}); missing: {_listed(p.missing)}")
        return lines


def _speed(s: Any) -> str:
    return format_speed(s)


def _listed(items: tuple[str, ...], most: int = 12) -> str:
    shown = ", ".join(items[:most])
    return shown + (f" and {len(items) - most} more" if len(items) > most else "") if items else "nothing"


def _reasons(t: _Trial) -> str:
    if t.fit is None:
        return "aborted (no result)"
    return "; ".join(f"{c}: {r}" for c, r in zip(t.fit.flag_codes, t.fit.flag_reasons, strict=True)) or "no period"


def result_lines(trial_id: str, key: str, fit: TrialFit, sample_rate_hz: float = math.nan) -> list[str]:
    """A trial's result: one line (period ± σ, cycles, r², ok or REDO), then one per flag with its advice.

    Args:
        trial_id: The trial.
        key: Its measurement key.
        fit: Its period estimate.
        sample_rate_hz: Its sample rate (from its START), Hz, for the number of cycles.
    """
    from ..core.period.advice import flag_advice

    head = f"trial {trial_id} ({key or '?'}):"
    if fit.valid:
        n = fit.window[1] - fit.window[0]
        ok_rate = math.isfinite(sample_rate_hz) and sample_rate_hz > 0 and fit.period > 0
        cycles = f", {n / sample_rate_hz / fit.period:.0f} cycles" if ok_rate else ""
        numbers = f"T = {format_uncertain(fit.period, fit.period_sigma, 's')}{cycles}, r² {fit.fit.r2:.5f}"
    else:
        numbers = "no period"
    if fit.usable:
        return [f"{head} {numbers} - ok"]
    lines = [f"{head} {numbers} - REDO"]
    for code, reason in zip(fit.flag_codes, fit.flag_reasons, strict=True):
        lines.append(f"    {code}: {reason} -> {flag_advice(code)}")
    return lines


# ---------------------------------------------------------------------------------------------- the set-up
def _say(line: str) -> None:
    print(f"bike-rig run: {terminal_safe(line)}", file=sys.stderr, flush=True)


def _out(line: str) -> None:
    print(terminal_safe(line), flush=True)


def _config_path(given: str | None) -> Path:
    """The graph file: the default, or the one given (a relative name not found here: from the config folder)."""
    if given is None:
        return config_file("graph.yaml")
    path = Path(given).expanduser()
    if not path.is_absolute() and not path.exists() and (config_dir() / path).is_file():
        return config_dir() / path
    return path


def session_folder(given: str | None, now: time.struct_time | None = None) -> Path:
    """The session folder: ``given``, or ``bike_rig_sessions/<YYYYmmdd-HHMMSS>`` (a new one).

    Raises:
        UsageError: The folder exists and is not empty (or is a file).
    """
    if given is None:
        stamp = time.strftime("%Y%m%d-%H%M%S", now or time.localtime())
        base = Path("bike_rig_sessions") / stamp
        out, n = base, 1
        while out.exists():
            n += 1
            out = base.with_name(f"{stamp}-{n}")
        return out
    out = Path(given).expanduser()
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise UsageError(f"--out {given}: exists and is not an empty folder; give a new folder for the session")
    return out


def _node_of(graph: Graph, module: str) -> str | None:
    return next((n.name for n in graph.nodes if n.module == module), None)


def _defaults(graph: Graph, overrides: dict[str, dict[str, object]], out: Path) -> list[str]:
    """Add the run's own overrides: the bag's place, the listener as a subscriber, the bicycle's readings.

    The bag goes to ``<session folder>/bag``; a driver that waits for its subscribers waits for
    this process's listener too; a simulated bicycle or session given on the command line
    gives the parameter node its static readings.

    Returns:
        Lines saying what was linked, for the user.
    """
    notes: list[str] = []
    recorder = _node_of(graph, _RECORDER)
    if recorder is not None and "output" not in {**graph.node(recorder).parameters, **overrides.get(recorder, {})}:
        overrides.setdefault(recorder, {})["output"] = str(out / "bag")
    driver, parameter = _node_of(graph, _DRIVER), _node_of(graph, _PARAMETER)
    waits = graph.node(driver).parameters.get("wait_for_subscribers") if driver is not None else None
    if (
        driver is not None
        and isinstance(waits, int)
        and waits > 0
        and "wait_for_subscribers" not in overrides.get(driver, {})
    ):
        overrides.setdefault(driver, {})["wait_for_subscribers"] = waits + 1  # this process's listener too
    if driver is None or parameter is None or "measurements" in overrides.get(parameter, {}):
        return notes
    given = overrides.get(driver, {})
    for name in ("session", "bicycle"):
        value = given.get(name)
        if isinstance(value, str) and value.strip() and _is_measurement_file(value):
            overrides.setdefault(parameter, {})["measurements"] = value
            notes.append(f"{parameter}.measurements = {value} (the static readings of {driver}.{name})")
            break
    return notes


def _is_measurement_file(value: str) -> bool:
    """Whether ``value`` (from here, else the config folder) is a measurement file (not a parameter file)."""
    from ..core.loader import load_input
    from ..core.measurements import Measurements

    path = Path(value).expanduser()
    if not path.exists() and not path.is_absolute():
        path = config_dir() / path
    try:
        return isinstance(load_input(str(path)), Measurements)
    except BikeRigError:
        return False


def _domain_id(given: str | None) -> int:
    from ..ros.env import check_domain_id, ros_environment

    if given is not None:
        return check_domain_id(given, "--domain-id")  # (a ROS_DOMAIN_ID in the environment is then not used)
    return int(ros_environment(os.environ)["ROS_DOMAIN_ID"])


def run(args: argparse.Namespace) -> int:
    """Check everything, start the graph, follow it until Ctrl-C or a node ends, stop it, summarise."""
    from ..ros.env import static_peers_value
    from ..ros.launch import load_graph, parse_overrides

    domain_id = _domain_id(args.domain_id)
    graph = load_graph(_config_path(args.config)).subset(args.only, args.without)
    peers = static_peers_value(args.peer) if args.peer else ""
    overrides = parse_overrides(args.param)
    out = session_folder(args.out)
    notes = _defaults(graph, overrides, out)
    graph = graph.with_parameters(overrides).checked()
    log_dir = Path(args.log_dir).expanduser() if args.log_dir else out / "logs"
    for line in notes:
        _say(line)
    if peers:  # this process's listener finds the other host's nodes too
        os.environ["ROS_STATIC_PEERS"] = peers
    return _Session(graph, out, log_dir, domain_id, tuple(args.peer)).run()


# ---------------------------------------------------------------------------------------------- the run
@dataclass
class _Stop:
    """What the signal handler records: how many times the user asked to stop."""

    requests: int = 0

    def handler(self, _signum: int, _frame: Any) -> None:
        self.requests += 1


class _Session:
    def __init__(self, graph: Graph, out: Path, log_dir: Path, domain_id: int, peers: tuple[str, ...] = ()) -> None:
        self.graph, self.out, self.log_dir, self.domain_id, self.peers = graph, out, log_dir, domain_id, peers
        self.tracker = RunTracker()
        self.stop = _Stop()
        self.watch = StallWatch(
            nodes={n.name for n in graph.nodes},
            expected={n.name for n in graph.nodes if n.module in _HEARTBEAT_MODULES},
        )
        self.stopping: set[str] = set()  # nodes asked to stop: silent, not stalled
        self.running: RunningGraph | None = None
        recorder = _node_of(graph, _RECORDER)
        output = graph.node(recorder).parameters.get("output") if recorder else None
        self.bag = Path(str(output)) if output else None

    def run(self) -> int:
        from ..ros.nodes.run_monitor import GraphMonitor
        from ..ros.running import RunningGraph

        inside = self.out.resolve()
        if (self.bag is not None and self.bag.parent == inside) or self.log_dir.resolve().parent == inside:
            self.out.mkdir(parents=True, exist_ok=True)
        previous = {s: signal.signal(s, self.stop.handler) for s in (signal.SIGINT, signal.SIGTERM)}
        # the listener first: matched while the nodes start, it misses no heartbeat period of history
        monitor = GraphMonitor(self.domain_id, diagnostics=True)
        try:
            running = RunningGraph(self.graph, self.log_dir, self.domain_id, static_peers=self.peers).start()
            self.running = running
            try:
                self._write_pids(running)
                n = len(self.graph.nodes)
                _say(
                    f"{n} node{'' if n == 1 else 's'} on ROS_DOMAIN_ID={running.domain_id} "
                    f"({'peers ' + ', '.join(self.peers) if self.peers else 'localhost'}); session "
                    f"folder {self.out}; Ctrl-C to stop"
                )
                ended = self._loop(running, monitor)
                status = self._wind_down(running, monitor, ended)
            finally:
                running.stop()
        finally:
            monitor.close()
            for s, h in previous.items():
                signal.signal(s, h)
        return self._finish(status, ended)

    def _write_pids(self, running: RunningGraph) -> None:
        """``<logs>/pids``: this process's id and each node's, one ``name pid`` a line."""
        lines = [f"run {os.getpid()}", *(f"{n.name} {running.pid(n.name)}" for n in self.graph.nodes)]
        (self.log_dir / "pids").write_text("\n".join(lines) + "\n", encoding="utf-8")

    def _feed(self, monitor: GraphMonitor, timeout_s: float) -> int:
        """Print what arrived (waiting up to ``timeout_s``, s) and who stalled; return the number of results."""
        from ..pipeline.diagnostics import StatusReport

        results = 0
        for record in monitor.poll(timeout_s):
            if isinstance(record, StatusReport):
                self.watch.heard(record.statuses)
                continue
            results += 1
            for line in self.tracker.add(record):
                _out(line)
        ended = {name for name, _, _ in self.running.dead()} if self.running is not None else set()
        for change in self.watch.check(ended | self.stopping):
            _say(change.text)
        return results

    def _loop(self, running: RunningGraph, monitor: GraphMonitor) -> list[tuple[str, int, str]]:
        """Follow the graph until a stop is asked for or a node ends; return the nodes that ended."""
        while not self.stop.requests:
            self._feed(monitor, POLL_S)
            ended = running.dead()
            if ended:
                return ended
        _say("stopping (Ctrl-C again to skip waiting for the last results)")
        return []

    def _wind_down(
        self, running: RunningGraph, monitor: GraphMonitor, ended: list[tuple[str, int, str]]
    ) -> dict[str, int]:
        """Stop the source first, wait for the last results, then stop the rest (the recorder last)."""
        source = self.graph.nodes[-1].name
        if source not in {name for name, _, _ in ended}:
            self.stopping.add(source)
            running.interrupt(source)  # the driver publishes ABORT for a trial in progress, then exits
            deadline = time.monotonic() + STOP_S
            while time.monotonic() < deadline and source not in {n for n, _, _ in running.dead()}:
                self._feed(monitor, POLL_S)
            running.stop_node(source)  # (SIGTERM, SIGKILL if it is still running)
        if not any(code != 0 for _, code, _ in ended):
            self._settle(monitor)
        status = running.stop()
        self._feed(monitor, 0.0)
        return status

    def _awaited(self) -> list[str]:
        """What is still to come (:meth:`RunTracker.awaiting` for this graph's nodes)."""
        has = {n.module for n in self.graph.nodes}
        return self.tracker.awaiting(_PARAMETER in has, _MODEL in has)

    def _settle(self, monitor: GraphMonitor) -> None:
        """Take in the last results: until none is awaited and nothing arrived for :data:`QUIET_S`.

        While something is awaited: as long as results keep coming (:data:`SETTLE_S` at most
        between two); and while a node is stalled or behind its input (its results will
        follow), up to :data:`SETTLE_MAX_S` in all. Giving up is one line; another Ctrl-C ends
        the wait at once.
        """
        start = last = time.monotonic()
        asked, said = self.stop.requests, False
        while self.stop.requests == asked and asked < 2:  # (a second Ctrl-C during the stop skips it)
            if self._feed(monitor, POLL_S):
                last = time.monotonic()
            now = time.monotonic()
            awaited, stalled = self._awaited(), bool(self.watch.troubled())
            if not awaited and not stalled:
                if now - last >= QUIET_S:
                    return
                continue
            what = ", ".join(awaited) or "the nodes to catch up"
            troubles = "; ".join(self.watch.troubles())
            if now - start >= SETTLE_MAX_S:
                _say(f"gave up after {SETTLE_MAX_S:g} s waiting for {what}" + (f" ({troubles})" if troubles else ""))
                return
            if now - last < SETTLE_S:
                continue
            if not stalled and self.watch.longest_silence() < HEARD_S:
                _say(f"gave up waiting for {what}: nothing arrived for {SETTLE_S:g} s")
                return
            if not stalled:
                continue  # (a node not heard for a while: stalled, or about to be heard)
            if not said:
                said = True
                _say(f"waiting for {what}: {troubles} (at most {SETTLE_MAX_S:g} s; Ctrl-C to stop waiting)")

    def _finish(self, status: Mapping[str, int], ended: list[tuple[str, int, str]]) -> int:
        died = [(name, code, tail) for name, code, tail in ended if code != 0]
        for name, code, tail in died:
            _report_death(name, code, tail, self.log_dir / f"{name}.log")
        for name, code, _ in ended:
            if code == 0:
                _say(f"node '{name}' finished; the graph was stopped")
        unclean = {n: c for n, c in status.items() if c not in (0, -signal.SIGINT) and n not in {d[0] for d in died}}
        if unclean:
            _say(f"nodes that did not stop cleanly: {json.dumps(unclean)} (logs in {_shown(self.log_dir)})")
        if self.tracker.trials or not died:  # (a run that failed at start has nothing to summarise)
            for line in self.tracker.summary():
                _out(line)
        self._where()
        if died:
            return 2 if any(code == 2 for _, code, _ in died) else 1
        return 1 if unclean else 0

    def _where(self) -> None:
        """Print where the session is; remove a bag in which no trial was recorded."""
        if self.out.is_dir():
            _out(f"session folder: {_shown(self.out)}")
        if self.bag is not None:
            if not self.tracker.trials and _no_trial_recorded(self.bag):
                shutil.rmtree(self.bag, ignore_errors=True)
                _out("  bag:  none (no trial was recorded; the empty bag was removed)")
            elif (self.bag / "metadata.yaml").is_file():
                _out(f"  bag:  {_shown(self.bag)}  (bike-rig bag info | replay | report BAG)")
            elif self.bag.exists():
                _out(f"  bag:  {_shown(self.bag)}  (not closed by the recorder: bike-rig bag recover BAG)")
        _out(f"  logs: {_shown(self.log_dir)}")


def _shown(path: Path) -> str:
    """A path as the user reads it: relative to the current directory when it is inside it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except (ValueError, OSError):
        return str(path)


def _no_trial_recorded(bag: Path) -> bool:
    """Whether the bag holds no trial event and no gyro batch (or is missing its summary and empty)."""
    import yaml

    from ..config.topics import GYRO, TRIAL_EVENTS

    if not bag.exists():
        return False
    meta = bag / "metadata.yaml"
    if not meta.is_file():
        return True  # the recorder did not close it, and the listener saw no trial
    try:
        info = yaml.safe_load(meta.read_text(encoding="utf-8"))["rosbag2_bagfile_information"]
        counts = {t["topic_metadata"]["name"]: int(t["message_count"]) for t in info["topics_with_message_count"]}
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return False
    return counts.get(GYRO.name, 0) == 0 and counts.get(TRIAL_EVENTS.name, 0) == 0


def _report_death(name: str, code: int, tail: str, log: Path) -> None:
    """One line for a node that stopped on a user mistake (its own error line), else the log's last lines."""
    errors = [line.partition(": error: ")[2] for line in tail.splitlines() if ": error: " in line]
    if code == 2 and errors:
        _say(f"error: node '{name}': {errors[-1]} (log: {_shown(log)})")
    else:
        _say(f"error: node '{name}' died with status {code} (log: {_shown(log)}); its last lines:\n{tail}")
