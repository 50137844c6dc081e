"""``bike-rig run``: start the whole graph as separate processes (the project's own launcher)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..launch import load_graph, parse_overrides, run_graph
from ..paths import config_file

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``run``."""
    q = subparsers.add_parser(
        "run",
        help="start the rig's ROS graph (driver, fitter, parameter, model, recorder) as processes",
        description="Start every node of a graph file as its own process on localhost with a ROS_DOMAIN_ID of "
        "its own; Ctrl-C stops them all cleanly; a node that dies is reported and the graph is stopped.",
    )
    q.add_argument("--config", help="graph file (default: config/graph.yaml)")
    q.add_argument("--param", action="append", default=[], metavar="NODE.NAME=VALUE", help="parameter override")
    q.add_argument("--domain-id", type=int, help="ROS_DOMAIN_ID (default: a free one is allocated)")
    q.add_argument("--log-dir", help="where node logs go (default: ./bike_rig_logs/<time>)")
    q.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the graph until Ctrl-C or until a node dies."""
    graph = load_graph(args.config or config_file("graph.yaml"))
    graph = graph.with_parameters(parse_overrides(args.param))
    log_dir = Path(args.log_dir or Path("bike_rig_logs") / time.strftime("%Y%m%d-%H%M%S"))
    return run_graph(graph, log_dir, args.domain_id)
