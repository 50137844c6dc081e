"""The environment of every ROS 2 process that bike_rig starts.

One place decides how a node, a test helper or a demo process talks DDS:

* ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, always. With the default range (SUBNET) Fast DDS
  multicasts discovery on every interface; our processes must never send traffic off
  loopback. (``ROS_LOCALHOST_ONLY`` is gone in Kilted and is silently ignored.)
* a ``ROS_DOMAIN_ID`` unique to the run, so concurrent runs on one machine do not cross-talk.
  :func:`unique_domain_id` reserves one through ``domain_coordinator`` (a bind on local TCP
  port 32768 + id, no traffic) and falls back to a pid-based id.
* ``RMW_IMPLEMENTATION=rmw_fastrtps_cpp``, the only rmw the PyPI wheels ship.

Two hosts (the driver beside the rig, the analysis at the desk) keep the LOCALHOST range and
name each other as static peers (:func:`static_peers_value`, ``ROS_STATIC_PEERS``): Fast DDS
then sends discovery by unicast to those addresses only, nothing is multicast.

It also removes stale Fast DDS shared-memory segments (:func:`remove_stale_fastdds_segments`):
segments left by killed processes can delay the next discovery by about 2.7 s.
"""

from __future__ import annotations

import atexit
import contextlib
import ipaddress
import logging
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..core.errors import BikeRigError

__all__ = [
    "DISCOVERY_RANGE",
    "MAX_DOMAIN_ID",
    "DomainIdError",
    "check_domain_id",
    "RMW_IMPLEMENTATION",
    "StaticPeerError",
    "fallback_domain_id",
    "process_domain_id",
    "remove_stale_fastdds_segments",
    "ros_environment",
    "static_peers_value",
    "unique_domain_id",
]

_log = logging.getLogger(__name__)

DISCOVERY_RANGE = "LOCALHOST"
"""Value forced for ``ROS_AUTOMATIC_DISCOVERY_RANGE``."""

RMW_IMPLEMENTATION = "rmw_fastrtps_cpp"
#: Fast DDS's default profile file (its participant lease outlasts a stalled process), in the
#: config folder; an inherited ``FASTDDS_DEFAULT_PROFILES_FILE`` is kept.
FASTDDS_PROFILES = "dds/fastdds.xml"
FASTDDS_PROFILES_VARIABLE = "FASTDDS_DEFAULT_PROFILES_FILE"
"""The ROS middleware every process uses."""

MAX_DOMAIN_ID = 101
"""Largest domain id that is safe on Linux with the default DDS port mapping.

Fast DDS maps domain d to UDP ports 7400 + 250 d and up; above 101 they run into Linux's
ephemeral port range (32768-60999), which ROS 2 documents as unsafe.
"""


class DomainIdError(BikeRigError, ValueError):
    """A ROS_DOMAIN_ID that is not an integer in 0..:data:`MAX_DOMAIN_ID` (one-line message)."""


def check_domain_id(value: object, name: str = "ROS_DOMAIN_ID", where: str = "") -> int:
    """A domain id, checked: an integer in 0..:data:`MAX_DOMAIN_ID`.

    Args:
        value: The id given (an int, or text such as an environment variable's).
        name: What it was given as, for the message (``ROS_DOMAIN_ID``, ``--domain-id``).
        where: Where, for the message (e.g. `` in the environment``).

    Returns:
        The id.

    Raises:
        DomainIdError: Not an integer, or outside 0..101, in one line such as
            ``ROS_DOMAIN_ID=150 in the environment is outside 0..101, the domain ids Fast DDS
            supports on Linux``.
    """
    allowed = f"0..{MAX_DOMAIN_ID}, the domain ids Fast DDS supports on Linux"
    number: int | None = None
    if isinstance(value, int) and not isinstance(value, bool):
        number = value
    else:
        text = str(value).strip()
        try:
            number = int(text)
        except ValueError:
            raise DomainIdError(f"{name}={text!r}{where} is not an integer in {allowed}") from None
    if not 0 <= number <= MAX_DOMAIN_ID:
        raise DomainIdError(f"{name}={number}{where} is outside {allowed}")
    return number


class StaticPeerError(BikeRigError, ValueError):
    """A static peer that is not an IP address (one-line message)."""


def static_peers_value(peers: Sequence[str]) -> str:
    """The ``ROS_STATIC_PEERS`` value for the other hosts' addresses.

    Args:
        peers: IPv4 or IPv6 addresses of the other hosts (e.g. ``10.0.0.2``).

    Returns:
        The addresses, ``;``-separated, as ROS 2 reads the variable.

    Raises:
        StaticPeerError: An entry is not an IP address (a host name is refused: resolving it
            could send a DNS query off the machine).
    """
    checked = []
    for peer in peers:
        try:
            checked.append(str(ipaddress.ip_address(peer.strip())))
        except ValueError:
            raise StaticPeerError(f"static peer {peer!r} is not an IP address (e.g. 10.0.0.2)") from None
    return ";".join(checked)


_REMOVED_VARIABLES = (
    # ignored by Kilted; dropped so that nobody reads it as being in force
    "ROS_LOCALHOST_ONLY",
    # static peers would be contacted even with a LOCALHOST discovery range
    "ROS_STATIC_PEERS",
)

_process_domain: int | None = None
_process_domain_stack: contextlib.ExitStack | None = None


def fallback_domain_id(pid: int | None = None) -> int:
    """A domain id in 1..100 derived from a process id, for when no coordinator is available.

    Args:
        pid: The process id to derive it from; the current process if None.

    Returns:
        ``pid % 100 + 1``.
    """
    return (os.getpid() if pid is None else pid) % 100 + 1


@contextlib.contextmanager
def unique_domain_id() -> Iterator[int]:
    """Reserve a ROS domain id, unique on this machine, for the duration of the context.

    The id comes from ``domain_coordinator.domain_id()`` (1..100), which holds a bind on local
    TCP port 32768 + id as a lock until the context exits; no packet is sent. If the
    coordinator is missing or cannot find a free id, a pid-based id is used instead (unique
    between concurrent processes in most cases, but not guaranteed) and a warning is logged.

    Yields:
        The domain id, 1..100.
    """
    reservation: contextlib.AbstractContextManager[Any] | None = None
    try:
        from domain_coordinator import domain_id

        reservation = domain_id()
        value = int(reservation.__enter__())
    except (ImportError, RuntimeError, OSError) as exc:
        reservation = None
        value = fallback_domain_id()
        _log.warning("domain_coordinator failed (%s); using pid-based ROS_DOMAIN_ID %d", exc, value)
    try:
        yield value
    finally:
        # Never pass the body's exception on: domain_coordinator's generator swallows an
        # OSError thrown into it and would then fail with "generator didn't stop".
        if reservation is not None:
            reservation.__exit__(None, None, None)


def process_domain_id() -> int:
    """The domain id reserved for this process, allocated on first use and held until exit."""
    global _process_domain, _process_domain_stack
    if _process_domain is None:
        stack = contextlib.ExitStack()
        _process_domain = stack.enter_context(unique_domain_id())
        _process_domain_stack = stack
        atexit.register(stack.close)
    return _process_domain


def ros_environment(
    base: Mapping[str, str] | None = None, domain_id: int | None = None, static_peers: Sequence[str] = ()
) -> dict[str, str]:
    """The environment for a ROS 2 process that bike_rig starts.

    Args:
        base: The environment to start from (not modified); ``os.environ`` if None.
        domain_id: The ``ROS_DOMAIN_ID`` to use. If None, the base's ``ROS_DOMAIN_ID`` is kept
            when it is set (a parent process, a test fixture or the user chose it); otherwise
            this process's reserved id (:func:`process_domain_id`) is used.
        static_peers: The other hosts' addresses (:func:`static_peers_value`); empty: none,
            and an inherited ``ROS_STATIC_PEERS`` is removed.

    Returns:
        A new dict: a copy of ``base`` with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``,
        ``ROS_DOMAIN_ID`` and ``RMW_IMPLEMENTATION=rmw_fastrtps_cpp`` set, and
        ``ROS_LOCALHOST_ONLY`` removed and ``ROS_STATIC_PEERS`` set to ``static_peers`` (or
        removed when there are none); ``FASTDDS_DEFAULT_PROFILES_FILE`` names
        ``config/dds/fastdds.xml`` unless ``base`` names a profile file already.

    Raises:
        DomainIdError: If the domain id (given or inherited) is not an integer in 0..101 (a
            :class:`ValueError` and a :class:`~bike_rig.core.errors.BikeRigError`: the command
            line prints it as one line).
        StaticPeerError: A static peer is not an IP address.
    """
    peers = static_peers_value(static_peers) if static_peers else ""
    env = dict(os.environ if base is None else base)
    if domain_id is None:
        inherited = env.get("ROS_DOMAIN_ID", "").strip()
        if inherited:
            domain_id = check_domain_id(inherited, "ROS_DOMAIN_ID", " in the environment")
        else:
            domain_id = process_domain_id()
    else:
        domain_id = check_domain_id(domain_id, "ROS_DOMAIN_ID")
    for name in _REMOVED_VARIABLES:
        env.pop(name, None)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = DISCOVERY_RANGE
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["RMW_IMPLEMENTATION"] = RMW_IMPLEMENTATION
    if not env.get(FASTDDS_PROFILES_VARIABLE):
        from ..config.paths import config_file

        env[FASTDDS_PROFILES_VARIABLE] = str(config_file(FASTDDS_PROFILES))
    if peers:
        env["ROS_STATIC_PEERS"] = peers
    return env


def _paths_in_use(proc: Path) -> set[str]:
    """Every file that a process has mapped (``/proc/*/maps``) or open (``/proc/*/fd``)."""
    used: set[str] = set()
    for pid_dir in proc.iterdir():
        if not pid_dir.name.isdigit():
            continue
        with contextlib.suppress(OSError):
            for line in (pid_dir / "maps").read_text().splitlines():
                parts = line.split(maxsplit=5)
                if len(parts) == 6:
                    used.add(parts[5].removesuffix(" (deleted)"))
        with contextlib.suppress(OSError):
            for fd in (pid_dir / "fd").iterdir():
                with contextlib.suppress(OSError):
                    used.add(os.readlink(fd))
    return used


def _segment_group(name: str) -> str:
    """The Fast DDS object a shared-memory file belongs to.

    ``fastdds_port7411`` (segment), ``fastdds_port7411_el`` (lock file, held open, not mapped)
    and ``sem.fastdds_port7411_mutex`` (named mutex, open only while a port is being opened)
    all map to ``fastdds_port7411``.
    """
    name = name.removeprefix("sem.")
    for suffix in ("_mutex", "_el", "_sl"):
        name = name.removesuffix(suffix)
    return name


def remove_stale_fastdds_segments(
    shm_dir: Path = Path("/dev/shm"),
    min_age_s: float = 10.0,
    proc: Path = Path("/proc"),
) -> list[Path]:
    """Delete Fast DDS shared-memory files that no process uses any more.

    A Fast DDS process killed with SIGKILL (or by ``timeout``) leaves its ``fastdds_*``
    segments, lock files and ``sem.fastdds_*`` mutexes behind; the next process then may take
    about 2.7 s to discover its peers. Files are grouped by the object they belong to (see
    ``_segment_group``); a group is removed only if no process has any of its files mapped
    (``/proc/<pid>/maps``) or open (``/proc/<pid>/fd``: lock files are held open, not mapped)
    and none of its files was modified in the last ``min_age_s`` seconds (so a segment being
    created right now is left alone). Files that cannot be inspected or removed are skipped.

    Args:
        shm_dir: The shared-memory directory.
        min_age_s: Minimum age, in seconds since the last modification, of every file of a
            removed group.
        proc: The procfs mount point.

    Returns:
        The files removed.
    """
    groups: dict[str, list[Path]] = {}
    for path in sorted([*shm_dir.glob("fastdds_*"), *shm_dir.glob("sem.fastdds_*")]):
        groups.setdefault(_segment_group(path.name), []).append(path)
    if not groups:
        return []
    used = _paths_in_use(proc)
    now = time.time()
    removed: list[Path] = []
    for paths in groups.values():
        try:
            if any(str(p) in used or now - p.stat().st_mtime < min_age_s for p in paths):
                continue
        except OSError:
            continue
        for path in paths:
            try:
                path.unlink()
            except OSError:
                continue
            removed.append(path)
    if removed:
        _log.info("removed %d stale Fast DDS shared-memory files from %s", len(removed), shm_dir)
    return removed
