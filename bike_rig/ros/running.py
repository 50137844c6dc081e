"""A started graph: the node processes of :mod:`bike_rig.ros.launch`'s :class:`Graph`.

Each node runs in its own process group (a Ctrl-C in the terminal reaches the launcher only,
which stops the nodes in order), and gets SIGTERM from the kernel when the launcher dies
however it dies (``PR_SET_PDEATHSIG``: a killed console or ``bike-rig run`` leaves no node
running; the recorder closes its bag on SIGTERM, so nothing recorded is lost). Before the
nodes stop, the recorder is asked to match every publisher of the others
(:meth:`RunningGraph.sync_recorder`): what a publisher holds goes with its process.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO

from .env import ros_environment
from .launch import Graph, LaunchError, NodeSpec

__all__ = ["RECORDER_MODULE", "SYNC_WAIT_S", "RunningGraph"]

#: The recorder node's module (synced before the others stop: :meth:`RunningGraph.sync_recorder`).
RECORDER_MODULE = "bike_rig.ros.nodes.recorder"
#: Longest wait for the recorder's sync, s (its own limit, 10 s, plus its drain).
SYNC_WAIT_S = 15.0

#: prctl(2) option: the signal the kernel sends a process when its parent (thread) ends.
_PR_SET_PDEATHSIG = 1


def _node_process_setup(launcher_pid: int) -> None:
    """In a node's child process, before exec: end with the launcher (see the module docstring).

    A launcher that died between fork and this call is not there to signal the child: the
    child then ends itself at once.
    """
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != launcher_pid:
        os.kill(os.getpid(), signal.SIGTERM)


def _popen_node(command: Sequence[str], out: IO[bytes], env: Mapping[str, str]) -> subprocess.Popen[bytes]:
    """Start one node process: own process group, output to ``out``, ended with the launcher."""
    launcher = os.getpid()
    return subprocess.Popen(
        list(command),
        stdout=out,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        env=dict(env),
        start_new_session=True,
        preexec_fn=lambda: _node_process_setup(launcher),
    )


@dataclass
class _Process:
    spec: NodeSpec
    popen: subprocess.Popen[bytes]
    log: Path


class RunningGraph:
    """The processes of a started graph; a context manager that always stops them.

    Args:
        graph: What to start.
        log_dir: Where each node's stdout/stderr go (``<name>.log``).
        domain_id: The run's ROS_DOMAIN_ID (default: allocated by :mod:`bike_rig.ros.env`).
        env: Extra environment for every node.
        static_peers: The other host's addresses when the graph is split over two hosts
            (``ROS_STATIC_PEERS``, see :func:`bike_rig.ros.env.ros_environment`).
    """

    def __init__(
        self,
        graph: Graph,
        log_dir: Path,
        domain_id: int | None = None,
        env: Mapping[str, str] | None = None,
        static_peers: Sequence[str] = (),
    ) -> None:
        """Keep the graph and log directory and build the nodes' environment; nothing is started yet."""
        self.graph = graph
        self.log_dir = log_dir
        base = dict(os.environ)
        base.update(env or {})
        self.env = ros_environment(base, domain_id=domain_id, static_peers=static_peers)
        self.processes: list[_Process] = []

    @property
    def domain_id(self) -> int:
        """The ROS_DOMAIN_ID every node of the run uses."""
        return int(self.env["ROS_DOMAIN_ID"])

    def start(self) -> RunningGraph:
        """Check the graph (:meth:`Graph.checked`), then start every node (each in its own process group).

        A recorder gets a ``sync_file`` in the log folder (see :meth:`stop`).

        Raises:
            LaunchError: A parameter override or file parameter is wrong (nothing is started).
        """
        self.graph = self.graph.checked()
        self.log_dir.mkdir(parents=True, exist_ok=True)
        for spec in self.graph.nodes:
            log = self.log_dir / f"{spec.name}.log"
            if spec.module == RECORDER_MODULE and not spec.parameters.get("sync_file"):
                sync = str((self.log_dir / f"{spec.name}.sync").absolute())
                spec = replace(spec, parameters={**spec.parameters, "sync_file": sync})
            with log.open("wb") as out:
                popen = _popen_node(spec.command(), out, self.env)
            self.processes.append(_Process(spec, popen, log))
        return self

    def __enter__(self) -> RunningGraph:
        """Start every node (:meth:`start`) and return the running graph."""
        return self.start()

    def __exit__(self, *exc: object) -> None:
        """Stop every node, however the block ended."""
        self.stop()

    def dead(self) -> list[tuple[str, int, str]]:
        """Nodes that have exited: (name, exit status, last lines of their log)."""
        out = []
        for p in self.processes:
            code = p.popen.poll()
            if code is not None:
                out.append((p.spec.name, code, _tail(p.log)))
        return out

    def pid(self, name: str) -> int:
        """The process id of node ``name``."""
        return next(p.popen.pid for p in self.processes if p.spec.name == name)

    def _index(self, name: str) -> int:
        """Where node ``name`` is in :attr:`processes`.

        Raises:
            LaunchError: No such node.
        """
        for i, p in enumerate(self.processes):
            if p.spec.name == name:
                return i
        raise LaunchError(f"no node named '{name}'")

    def restart(self, name: str) -> None:
        """Start node ``name`` again (after it died or was killed)."""
        i = self._index(name)
        p = self.processes[i]
        if p.popen.poll() is None:
            raise LaunchError(f"node '{name}' is still running (pid {p.popen.pid})")
        with p.log.open("ab") as out:
            popen = _popen_node(p.spec.command(), out, self.env)
        self.processes[i] = _Process(p.spec, popen, p.log)

    def stop_node(self, name: str, timeout_s: float = 15.0) -> int:
        """Stop node ``name`` (SIGINT, then SIGTERM, then SIGKILL) and return its exit status.

        Raises:
            LaunchError: No such node.
        """
        return _stop(self.processes[self._index(name)].popen, timeout_s)

    def interrupt(self, name: str) -> None:
        """Send node ``name`` a SIGINT (a clean stop) without waiting; :meth:`stop_node` waits.

        Raises:
            LaunchError: No such node.
        """
        popen = self.processes[self._index(name)].popen
        if popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                popen.send_signal(signal.SIGINT)

    def log(self, name: str) -> Path:
        """The log file of node ``name``.

        Raises:
            LaunchError: No such node.
        """
        return self.processes[self._index(name)].log

    def stop(self, timeout_s: float = 15.0) -> dict[str, int]:
        """Stop every node: SIGINT, then SIGTERM, then SIGKILL, each node's exit waited for.

        First the recorder syncs (:meth:`sync_recorder`). Then in reverse start order, in three
        steps: the last started (the source) alone, then the nodes between together, then the
        first started (the recorder) alone, so that what the source sent last is still taken in
        and everything published is recorded.

        Returns:
            Exit status per node name, in stop order.
        """
        self.sync_recorder()
        procs = list(reversed(self.processes))
        steps = [procs[:1], procs[1:-1], procs[-1:]] if len(procs) > 2 else [[p] for p in procs]
        status: dict[str, int] = {}
        for step in steps:
            codes = _stop_together([p.popen for p in step], timeout_s)
            status.update({p.spec.name: c for p, c in zip(step, codes, strict=True)})
        return status

    def sync_recorder(self, timeout_s: float = SYNC_WAIT_S) -> bool:
        """Have the recorder match every other running node's publishers and take what they hold.

        A publisher the recorder has not matched yet (discovery is slow on a loaded machine)
        keeps its transient-local history only while its process lives. The recorder (started
        first) is given the other running nodes' names in its ``sync_file`` and a SIGUSR1; it
        removes the file when it is done (or gave up after its own limit). Nothing happens
        unless the recorder has started recording (its signal handler is in place).

        Returns:
            Whether the recorder answered within ``timeout_s``.
        """
        if not self.processes or self.processes[0].spec.module != RECORDER_MODULE:
            return False
        recorder = self.processes[0]
        sync = recorder.spec.parameters.get("sync_file")
        if not sync or recorder.popen.poll() is not None or "recording " not in _text(recorder.log):
            return False
        path = Path(str(sync))
        names = [p.spec.name for p in self.processes[1:] if p.popen.poll() is None]
        path.write_text("".join(f"{n}\n" for n in names), encoding="utf-8")
        with contextlib.suppress(ProcessLookupError):
            recorder.popen.send_signal(signal.SIGUSR1)
        deadline = time.monotonic() + timeout_s
        while path.exists() and recorder.popen.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        return not path.exists()


def _stop_together(popens: Sequence[subprocess.Popen[bytes]], timeout_s: float) -> list[int]:
    """Signal every process (SIGINT, then SIGTERM, then SIGKILL to those still running) and wait for them all."""
    for sig, wait in ((signal.SIGINT, timeout_s), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        running = [p for p in popens if p.poll() is None]
        if not running:
            break
        for p in running:
            with contextlib.suppress(ProcessLookupError):
                p.send_signal(sig)
        deadline = time.monotonic() + wait
        for p in running:
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.wait(max(0.0, deadline - time.monotonic()))
    return [p.wait() for p in popens]


def _stop(popen: subprocess.Popen[bytes], timeout_s: float) -> int:
    return _stop_together([popen], timeout_s)[0]


def _text(path: Path) -> str:
    """A log file's text ("" when it cannot be read)."""
    try:
        return path.read_text(errors="replace")
    except OSError:
        return ""


def _tail(path: Path, lines: int = 5) -> str:
    return "\n".join(_text(path).splitlines()[-lines:])
