"""``bike-rig view``: the live graph in the Foxglove app.

    bike-rig view [--port N] [--host ADDR] [--domain-id N]

Starts the Foxglove bridge node (:mod:`bike_rig.ros.nodes.foxglove_bridge`) in this process on the
graph's ROS domain, prints the address to open in Foxglove and the layout file to import, and
serves until Ctrl-C. Once discovery has had :data:`~bike_rig.ros.liveview.GRAPH_GRACE_S` s, it says
whether a bike_rig graph is on the domain (and how to point the view at one when none is), and
again whenever one appears or goes. The Foxglove SDK is imported only here and in the node, so the other
commands start no slower.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import TYPE_CHECKING

from ..core.errors import BikeRigError
from .commands import HELP

if TYPE_CHECKING:
    from ..ros.nodes.foxglove_bridge import FoxgloveBridge

__all__ = ["add_parser", "run"]


class ViewUsageError(BikeRigError):
    """A ``view`` argument is invalid."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``view``."""
    from ..ros.liveview import DEFAULT_PORT

    q = subparsers.add_parser(
        "view",
        help=HELP["view"],
        description="Start the Foxglove bridge: the gyro trace, trial events, periods, parameters, eigen sweep "
        "and diagnostics of the running graph, served over Foxglove's WebSocket protocol. Open the printed "
        "address in Foxglove (Open connection > Foxglove WebSocket) and import the printed layout file. Clients "
        "of either protocol name are served: foxglove.sdk.v1 (Foxglove) and foxglove.websocket.v1 (Lichtblick, "
        "@foxglove/ws-protocol). With no bike_rig graph on the domain it says so after a few seconds.",
    )
    q.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help=f"WebSocket port (default {DEFAULT_PORT}, Foxglove's; 0: a free one)",
    )
    q.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this computer only; 0.0.0.0: every interface)",
    )
    q.add_argument(
        "--domain-id",
        metavar="N",
        help="ROS_DOMAIN_ID of the graph to show, 0..101 (default: the environment's, else 0); "
        "bike-rig run prints its own",
    )
    q.set_defaults(func=run)


def _domain_id(given: str | None) -> int:
    from ..ros.env import check_domain_id

    if given is not None:
        return check_domain_id(given, "--domain-id")
    inherited = os.environ.get("ROS_DOMAIN_ID", "").strip()
    return check_domain_id(inherited, "ROS_DOMAIN_ID", " in the environment") if inherited else 0


def _watch_graph(bridge: FoxgloveBridge, domain_id: int) -> None:
    """Print, each time it changes, whether a bike_rig graph is on the domain (a 1 s timer of the bridge node)."""
    from ..ros.liveview import GraphPresence

    presence = GraphPresence(domain_id)
    t0 = time.monotonic()

    def check() -> None:
        line = presence.update(time.monotonic() - t0, *bridge.rig_publishers())
        if line is not None:
            print(line, flush=True)

    bridge.node.create_timer(1.0, check)


def run(args: argparse.Namespace) -> int:
    """Check the arguments, start the bridge node and serve until Ctrl-C; returns the exit status."""
    if not 0 <= args.port <= 65535:
        raise ViewUsageError(f"--port must be within 0..65535, got {args.port}")
    os.environ["ROS_DOMAIN_ID"] = str(_domain_id(args.domain_id))
    from ..config.paths import config_dir
    from ..ros.liveview import LAYOUT_FILE
    from ..ros.nodes.foxglove_bridge import main

    layout = config_dir() / LAYOUT_FILE

    def started(bridge: FoxgloveBridge) -> None:
        print(f"serving ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']} to Foxglove on {bridge.url}", flush=True)
        print("  in Foxglove: Open connection > Foxglove WebSocket > this address", flush=True)
        print(f"  layout: Layouts > Import from file > {layout}", flush=True)
        for name, why in bridge.skipped.items():
            print(f"  not served: {name} ({why})", flush=True)
        print("Ctrl-C stops", flush=True)
        _watch_graph(bridge, int(os.environ["ROS_DOMAIN_ID"]))

    ros_args = ["bike-rig view", "--ros-args", "-p", f"port:={args.port}", "-p", f"host:={args.host}"]
    # (a mistake, e.g. the port taken, is printed by the node runner as one line: status 2)
    return main(ros_args, on_started=started)
