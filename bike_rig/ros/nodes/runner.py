"""One way to run a node process, for every bike_rig node's ``main``.

rclpy set-up, the ROS environment, spinning, and a clean stop on SIGINT/SIGTERM.

The process environment always gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (and keeps a
``ROS_DOMAIN_ID`` given by the launcher or the caller), so a node started by hand is safe too.
A user mistake (a :class:`bike_rig.core.errors.BikeRigError` while building the node, e.g. a
bad parameter or measurement file, or a ``ROS_DOMAIN_ID`` outside 0..101) ends the process with
one log line and exit status 2.

Stopping: SIGINT and SIGTERM only set a flag (rclpy's own signal handlers are not installed, so
the context stays valid); the spin loop ends, then the node's ``close()`` runs while it can
still publish (the driver sends ABORT for a trial in progress there), then the node is
destroyed; a teardown still running :data:`TEARDOWN_S` later is cut short (``os._exit(0)``).
"""

from __future__ import annotations

import faulthandler
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from types import FrameType

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from ...core.errors import BikeRigError
from ...core.textfmt import terminal_safe
from ..env import ros_environment

__all__ = ["EXIT_USER_ERROR", "run_node"]

EXIT_USER_ERROR = 2


#: Seconds the middleware's teardown (destroying the node, shutting rclpy down) may take after
#: the node closed; a process still there then exits (status 0: everything was written).
TEARDOWN_S = 10.0

#: A stop still not done this long after it was asked for leaves every thread's stack on stderr
#: (the node's log), so that a hang shows where it is, s (the launcher waits 15 s, then SIGTERM).
STUCK_DUMP_S = 12.0


def _exit_if_stuck(seconds: float) -> None:
    """End the process after ``seconds`` unless it has ended by then.

    The node's own ``close()`` has run (a bag is closed, an ABORT sent): what is left is the
    middleware's teardown, which Fast DDS has been seen to block in for more than 30 s on a
    loaded machine, keeping a node alive after its launcher asked it to stop.
    """
    timer = threading.Timer(seconds, os._exit, args=(0,))
    timer.daemon = True
    timer.start()


def _prepare_environment() -> None:
    env = ros_environment(os.environ)
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
        os.environ[key] = env[key]


def run_node(factory: Callable[[], Node], args: Sequence[str] | None = None, name: str = "bike_rig node") -> int:
    """Create the node with ``factory`` and spin it until SIGINT/SIGTERM or rclpy shutdown.

    Args:
        factory: Builds the node (after ``rclpy.init``); may raise BikeRigError for user
            mistakes.
        args: Command-line arguments (``--ros-args ...`` are passed to rclpy).
        name: The node's name for an error raised before the node exists.

    Returns:
        The process exit status: 0 on a clean stop, 2 on a user mistake.
    """
    try:
        _prepare_environment()
    except BikeRigError as exc:
        print(f"{name}: error: {terminal_safe(str(exc), keep='')}", file=sys.stderr)
        return EXIT_USER_ERROR
    argv = list(sys.argv if args is None else args)
    # our own handlers (rclpy's would shut the context down before close() could publish)
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    stop = {"requested": False}

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        if not stop["requested"]:
            faulthandler.dump_traceback_later(STUCK_DUMP_S, exit=False)
        stop["requested"] = True

    signal.signal(signal.SIGTERM, request_stop)
    signal.signal(signal.SIGINT, request_stop)
    node: Node | None = None
    try:
        node = factory()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while rclpy.ok() and not stop["requested"] and not getattr(node, "finished", False):
            executor.spin_once(timeout_sec=0.1)
        closer = getattr(node, "close", None)
        if callable(closer):
            closer()
        _exit_if_stuck(TEARDOWN_S)
        return 0
    except BikeRigError as exc:
        label = node.get_name() if node is not None else name
        print(f"{label}: error: {terminal_safe(str(exc), keep='')}", file=sys.stderr)
        return EXIT_USER_ERROR
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
