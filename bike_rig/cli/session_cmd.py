"""``bike-rig session``: the operator's console (or plain mode) on a live graph it starts or joins."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ..config.paths import config_file
from ..core.errors import BikeRigError
from ..core.sim import load_rig, load_true_parameters
from ..core.sim.rig import RigConfig
from ..core.textfmt import terminal_safe
from ..offline.resume import ResumePoint, resume_point
from ..session.controller import SessionController
from .commands import HELP

if TYPE_CHECKING:
    from ..ros.graphwatch import NodeWatch
    from ..ros.launch import Graph, NodeSpec
    from ..ros.running import RunningGraph

__all__ = ["SessionArgumentError", "add_parser", "run"]


class SessionArgumentError(BikeRigError):
    """Options of ``bike-rig session`` that do not go together."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``session``."""
    q = subparsers.add_parser(
        "session",
        help=HELP["session"],
        description="Start the rig's graph (or join one with --join) and walk the operator through the session: "
        "the plan, trials started from the keyboard, static readings typed in, each result at once, the "
        "parameters and speeds as they form, and the next-best measurement. With no hardware source the "
        "simulated rig is driven by the operator. --plain reads one command per line from standard input.",
    )
    q.add_argument("--bicycle", help="sim: the bicycle on the simulated rig (default config/bicycles/browser.yaml)")
    q.add_argument("--name", help="the bicycle's name in the results (default: from --bicycle)")
    q.add_argument(
        "--rig", help="rig description: orientations, trials per period, durations (default config/rig.yaml)"
    )
    q.add_argument("--source", default="sim", help="gyro source: sim (default), can or daq")
    q.add_argument("--time-scale", type=float, default=1.0, help="sim: rig seconds per wall second (default 1)")
    q.add_argument("--seed", type=int, default=0, help="sim: seed of the simulated trials (default 0)")
    q.add_argument("--readings", help="a measurement file whose static readings are taken as entered (optional)")
    q.add_argument("--param", action="append", default=[], metavar="NODE.NAME=VALUE", help="parameter override")
    q.add_argument("--output", help="session folder for the bag and logs (default ./bike_rig_sessions/<time>)")
    q.add_argument("--domain-id", help="ROS_DOMAIN_ID (default: a free one; with --join: the graph's)")
    q.add_argument("--join", action="store_true", help="join a graph already running instead of starting one")
    q.add_argument(
        "--resume",
        metavar="FOLDER",
        help="continue an interrupted session from its folder (or its bag): its trials and readings count, and "
        "the new session folder's bag holds the whole session (give the same --bicycle, --rig and --seed)",
    )
    q.add_argument("--plain", action="store_true", help="one command per line on stdin, one reply per line")
    q.add_argument("--json", action="store_true", help="with --plain: replies as JSON lines")
    q.set_defaults(func=run)


def _graph_overrides(
    args: argparse.Namespace, bicycle_file: str, name: str, folder: Path, resume: ResumePoint | None
) -> dict[str, dict[str, object]]:
    driver: dict[str, object] = {"source": args.source}
    if resume is not None:
        # the recorded trials stream at once: wait for the recorder, the fitter and this console
        driver.update(resume=str(resume.bag), wait_for_subscribers=3)
    if args.source == "sim":
        driver.update(mode="operator", bicycle=bicycle_file, seed=args.seed, time_scale=args.time_scale)
    if args.rig:
        driver["rig"] = str(Path(args.rig).resolve())
    parameter: dict[str, object] = {
        "bicycle": name,
        "measurements": str(Path(args.readings).resolve()) if args.readings else _resumed_readings(resume, folder),
    }
    over: dict[str, dict[str, object]] = {
        "driver": driver,
        "parameter": parameter,
        "recorder": {"output": str(folder / "bag")},
    }
    from ..ros.launch import parse_overrides

    for node, values in parse_overrides(args.param).items():
        over.setdefault(node, {}).update(values)
    return over


def _carry_over(ctl: SessionController, resume: ResumePoint | None, readings: str | None) -> None:
    """Give the console what it knows before the first command.

    A resumed session's trials and readings, and the readings of a ``--readings`` file (the
    parameter node reads that file itself: nothing is sent).
    """
    from ..core.loader import load_static_readings
    from ..session.setup import take_readings_file

    if resume is not None:
        ctl.resume(resume.trial_ids, resume.entries, resume.describe())
    if readings:
        take_readings_file(ctl, load_static_readings(readings))


def _resumed_readings(resume: ResumePoint | None, folder: Path) -> str:
    """The static readings file the interrupted session started from, written into ``folder`` ("" if none)."""
    if resume is None or not resume.readings_document:
        return ""
    path = folder / f"resumed_static_readings{resume.readings_suffix}"
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(resume.readings_document, encoding="utf-8")
    return str(path)


def _resume_from(args: argparse.Namespace, name: str, folder: Path) -> tuple[ResumePoint | None, str]:
    """The interrupted session to continue (None without --resume), and the bicycle's name.

    Raises:
        BikeRigError: --resume with --join, a bag that cannot be read or recovered, or a
            session of another bicycle than --name.
    """
    if not args.resume:
        return None, name
    if args.join:
        raise SessionArgumentError(
            "--resume starts its own graph (the driver streams the recorded trials): it cannot be used with --join"
        )
    point = resume_point(args.resume, folder / "recovered_bag")
    if point.bicycle and args.name and point.bicycle != args.name:
        raise SessionArgumentError(f"{args.resume}: the session is of bicycle {point.bicycle!r}, not {args.name!r}")
    return point, args.name or point.bicycle or name


def _checked(args: argparse.Namespace) -> tuple[RigConfig, str, str]:
    """Check the domain id (argument and environment), read the rig and the bicycle's name.

    Sets ``args.domain_id`` to the checked id. Returns (rig, bicycle name, bicycle file).

    Raises:
        BikeRigError: A domain id out of range, or a rig or bicycle file that cannot be read.
    """
    from ..ros.env import check_domain_id

    args.domain_id = None if args.domain_id is None else check_domain_id(args.domain_id, "--domain-id")
    if "ROS_DOMAIN_ID" in os.environ:
        check_domain_id(os.environ["ROS_DOMAIN_ID"], where=" in the environment")
    bicycle_file = str(Path(args.bicycle).resolve()) if args.bicycle else str(config_file("bicycles/browser.yaml"))
    rig = load_rig(args.rig or str(config_file("rig.yaml")))
    return rig, args.name or load_true_parameters(bicycle_file)[0], bicycle_file


def _node_watch(graph: RunningGraph, folder: Path) -> NodeWatch:
    """The session's watch of its nodes: the driver's or the recorder's death ends it (resume it)."""
    from ..ros.graphwatch import NodeWatch

    then = f"quit, then continue it with 'bike-rig session --resume {folder}'"
    hints = {"driver": f"the session cannot go on: {then}", "recorder": f"nothing more is recorded: {then}"}
    return NodeWatch(graph, hints=hints)


def _ended_nodes(graph: RunningGraph) -> Callable[[], set[str]]:
    """The graph's nodes whose process has ended, now (gone: not stalled)."""
    return lambda: {name for name, _, _ in graph.dead()}


def _end_on(started: list[RunningGraph]) -> Callable[[int, object], None]:
    """A SIGTERM/SIGHUP handler: stop the graph (recorder last, the bag closed), then leave.

    It exits at once instead of raising: an exception raised by a signal handler inside the
    console's event loop is caught there, and the console would run on, detached from its
    closed terminal.
    """

    def end(signum: int, _frame: object) -> None:
        for graph in started:
            graph.stop()
        os._exit(128 + signum)

    return end


def _driver_values(node: NodeSpec) -> dict[str, object]:
    """The driver's parameters as it will read them: its parameter file's, the overrides on top."""
    from ..ros.launch import _params_file_values

    values: dict[str, object] = {}
    if node.params_file is not None:
        try:
            values, _ = _params_file_values(node.params_file, "driver")
        except BikeRigError:
            values = {}  # (the graph's start says what is wrong with it)
    return {**values, **node.parameters}


def _start(spec: Graph, folder: Path, domain_id: int | None, started: list[RunningGraph]) -> RunningGraph:
    """Start the session's graph (its PIDs in ``logs/pids``, its domain in this process's environment)."""
    from ..ros.running import RunningGraph

    graph = RunningGraph(spec, folder / "logs", domain_id).start()
    started.append(graph)
    pids = f"console {os.getpid()}\n" + "".join(f"{n.name} {graph.pid(n.name)}\n" for n in spec.nodes)
    (folder / "logs" / "pids").write_text(pids, encoding="utf-8")
    os.environ["ROS_DOMAIN_ID"] = str(graph.domain_id)
    return graph


def _domain(graph: RunningGraph | None, given: int | None) -> int | None:
    """The session's ROS domain: the started graph's, else the one given or the environment's."""
    if graph is not None:
        return graph.domain_id
    text = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
    return given if given is not None else int(text) if text.isdigit() else None


def run(args: argparse.Namespace) -> int:
    """Start (or join) the graph, run the console or plain mode, stop what was started.

    SIGTERM and SIGHUP (a closed terminal or SSH link) end the session like quitting: the
    graph is stopped and nothing recorded is lost.
    """
    from ..ros.launch import LaunchError, load_graph
    from ..session.plain import run_plain
    from ..session.setup import build_controller, connection

    if args.json and not args.plain:
        print("bike-rig session: error: --json needs --plain", file=sys.stderr)
        return 2
    folder = Path(args.output or Path("bike_rig_sessions") / time.strftime("%Y%m%d-%H%M%S")).resolve()
    try:
        rig, name, bicycle_file = _checked(args)
        resume, name = _resume_from(args, name, folder)
    except BikeRigError as exc:
        print(f"bike-rig session: error: {terminal_safe(str(exc), keep='')}", file=sys.stderr)
        return 2
    started: list[RunningGraph] = []
    signal.signal(signal.SIGTERM, _end_on(started))
    signal.signal(signal.SIGHUP, _end_on(started))
    graph = None
    driver: dict[str, object] = {}
    try:
        if not args.join:
            spec = load_graph(config_file("graph.yaml")).with_parameters(
                _graph_overrides(args, bicycle_file, name, folder, resume)
            )
            driver = _driver_values(spec.node("driver"))
            graph = _start(spec, folder, args.domain_id, started)
        elif args.domain_id is not None:
            os.environ["ROS_DOMAIN_ID"] = str(args.domain_id)
        from ..ros.nodes.session_link import SessionLink

        link = SessionLink()
        try:
            ctl = build_controller(rig, name, link, args.source)
            ctl.connect(*connection(args.source, driver, _domain(graph, args.domain_id)))
            if graph is not None:
                ctl.watch = _node_watch(graph, folder)
                ctl.ended = _ended_nodes(graph)
            _carry_over(ctl, resume, args.readings)
            if args.plain:
                status = run_plain(ctl, sys.stdin, sys.stdout, as_json=args.json)
            else:
                from ..console.app import run_console

                status = run_console(ctl)
        finally:
            link.close()
    except (LaunchError, BikeRigError) as exc:
        print(f"bike-rig session: error: {terminal_safe(str(exc), keep='')}", file=sys.stderr)
        return 2
    finally:
        if graph is not None:
            graph.stop()
    if graph is not None:
        where = f"session folder: {folder} (bag: {folder / 'bag'}, logs: {folder / 'logs'})"
        print(terminal_safe(where), file=sys.stderr)
    return status
