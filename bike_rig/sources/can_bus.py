"""Which CAN bus the CAN source reads, and the clock its frames are stamped with.

:func:`choose_bus`: the interface and channel named, else python-can's own configuration (the
environment's ``CAN_INTERFACE``... or its configuration files, read as ``can.Bus()`` does), else
the ``virtual`` bus ``bike_rig`` with a warning. :class:`LogBus`: a python-can log file played
as a bus at ``speed`` times real time (0: as fast as read). :class:`FrameClock`: frames stamped
within :data:`EPOCH_TOLERANCE_S` of ``time.time()`` keep their stamps; otherwise samples get the
receive clock, said once.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can

from .errors import SourceConfigError, SourceIOError, SourceUnavailableError

__all__ = [
    "DEFAULT_VIRTUAL_CHANNEL",
    "EPOCH_TOLERANCE_S",
    "BusChoice",
    "FrameClock",
    "LogBus",
    "check_interface",
    "choose_bus",
]

#: The virtual bus read when nothing names an interface (the simulated gyro's).
DEFAULT_VIRTUAL_CHANNEL = "bike_rig"
#: Largest difference from ``time.time()`` of a fresh frame's stamp for it to count as epoch time, s.
EPOCH_TOLERANCE_S = 2.0
#: Interfaces refused whatever the kernel: they send traffic off the machine.
_REFUSED = {"udp_multicast": "it multicasts on the network; no traffic may leave the machine"}
#: Earliest plausible epoch stamp of a logged frame (2000-01-01), s.
_EPOCH_2000_S = 946_684_800.0


@dataclass(frozen=True)
class BusChoice:
    """The bus to open.

    Attributes:
        interface: python-can interface name.
        channel: Its channel.
        options: Further ``can.Bus`` arguments (bit rate, and those of python-can's configuration).
        origin: Where the interface was named: ``can_interface``, python-can's configuration
            (and which part), or the default.
    """

    interface: str
    channel: str
    options: dict[str, Any] = field(default_factory=dict)
    origin: str = "can_interface"

    @property
    def defaulted(self) -> bool:
        """True when nothing named a bus: the virtual bus of the simulated gyro."""
        return self.origin == "default"

    def describe(self) -> str:
        """``interface:channel`` and where it was named."""
        return f"{self.interface}:{self.channel} ({self.origin})"


def check_interface(interface: str, parameter: str) -> None:
    """Refuse an interface python-can does not know, or one that sends traffic off the machine.

    Raises:
        SourceConfigError: Unknown or refused.
    """
    if interface in _REFUSED:
        raise SourceConfigError("can", parameter, f"refused: {_REFUSED[interface]}", interface)
    if interface not in can.interfaces.VALID_INTERFACES:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        raise SourceConfigError("can", parameter, f"unknown python-can interface; expected one of {known}", interface)


def _configured_origin() -> str | None:
    """Where python-can's configuration names an interface, or None when it names none."""
    util = can.util
    rc: dict[str, Any] = can.rc
    if rc.get("interface") or rc.get("bustype"):
        return "python-can's can.rc"
    env = util.load_environment_config()
    if env.get("interface") or env.get("bustype"):
        return "python-can's " + ("CAN_INTERFACE" if "CAN_INTERFACE" in os.environ else "CAN_CONFIG")
    files = [p for p in (Path(f).expanduser() for f in util.CONFIG_FILES) if p.is_file()]
    found = util.load_file_config()
    if found.get("interface") or found.get("bustype"):
        return "python-can's config file " + ", ".join(str(p) for p in files)
    return None


def choose_bus(interface: str, channel: str, bitrate: int) -> BusChoice:
    """The bus the parameters name, else python-can's configured one, else the default virtual bus.

    Args:
        interface: ``can_interface`` ("": python-can's configuration).
        channel: ``can_channel`` ("": the configuration's, or ``bike_rig`` on the virtual bus).
        bitrate: ``can_bitrate``, bit/s (0: the configuration's or the interface's).

    Raises:
        SourceConfigError: An unknown or refused interface (named or configured), or no channel.
    """
    given: dict[str, Any] = {"bitrate": bitrate} if bitrate > 0 else {}
    if interface:
        check_interface(interface, "can_interface")
        if not channel and interface == "virtual":
            channel = DEFAULT_VIRTUAL_CHANNEL
        if not channel:
            raise SourceConfigError("can", "can_channel", f"needed with can_interface {interface!r} (e.g. can0)", "")
        return BusChoice(interface, channel, given, "can_interface")
    origin = _configured_origin()
    if origin is None:
        return BusChoice("virtual", channel or DEFAULT_VIRTUAL_CHANNEL, given, "default")
    if channel:
        given["channel"] = channel
    try:
        config = dict(can.util.load_config(config=given))
    except (can.CanInterfaceNotImplementedError, ValueError, TypeError) as exc:
        reason = f"not given, and {origin} names one that python-can refuses: {exc}"
        raise SourceConfigError("can", "can_interface", reason) from None
    name = str(config.pop("interface"))
    check_interface(name, "can_interface")
    found = config.pop("channel", None)
    if found is None or found == "":
        raise SourceConfigError("can", "can_channel", f"not given, and {origin} names no channel", "")
    return BusChoice(name, str(found), config, origin)


class FrameClock:
    """Checks, on the first frames, whether their timestamps are epoch time (see the module docstring).

    Attributes:
        source: ``None`` until checked; then ``"interface"`` (the frames' own stamps) or
            ``"receive"`` (``time.time()`` when read).
        notice: What was decided, one line (for the log).
    """

    def __init__(self, what: str = "the interface's", epoch_window_s: float = EPOCH_TOLERANCE_S) -> None:
        """A clock not yet checked; ``what`` names whose timestamps they are (for the notice).

        Args:
            what: Whose stamps (``the interface's``, ``the log's``).
            epoch_window_s: How far from now a stamp may be and count as epoch time, s
                (``math.inf``: any stamp after 2000 and before tomorrow, for a log).
        """
        self.what = what
        self.epoch_window_s = epoch_window_s
        self.source: str | None = None
        self.notice = ""

    def check(self, stamp_s: float, now_s: float) -> None:
        """Decide from the newest frame's stamp, once."""
        if self.source is not None:
            return
        if math.isinf(self.epoch_window_s):
            epoch = _EPOCH_2000_S <= stamp_s <= now_s + 86_400.0
        else:
            epoch = abs(now_s - stamp_s) <= self.epoch_window_s
        if epoch:
            self.source = "interface"
            self.notice = f"stamps: {self.what} timestamps (epoch time, checked against this computer's clock)"
        else:
            self.source = "receive"
            self.notice = (
                f"stamps: the receive clock ({self.what} timestamps are not epoch time: {stamp_s:.6g} s "
                f"against {now_s:.6f} s now)"
            )

    def first_ns(self, first_stamp_s: float, earlier_samples: int, rate_hz: float, read_ns: int, n: int) -> int:
        """Epoch time of the first of ``n`` samples read now, ns.

        Args:
            first_stamp_s: The stamp of the frame holding the first sample, s.
            earlier_samples: Samples before the first in that frame.
            rate_hz: Sample rate, Hz.
            read_ns: ``time.time_ns()`` when they were read.
            n: Samples read now (the last one taken as just received on the receive clock).
        """
        if self.source == "interface":
            return round((first_stamp_s - earlier_samples / rate_hz) * 1e9)
        return read_ns - round((n - 1) / rate_hz * 1e9)


class LogBus(can.BusABC):
    """A python-can log file as a receive-only bus, paced by its timestamps (see the module docstring).

    Args:
        path: The log file.
        speed: Times real time (1: as recorded); 0: as fast as it is read.
        clock: Monotonic seconds (the pace's clock).

    Attributes:
        frames: Frames read so far.
        exhausted: True once the reader has no frame left (see :meth:`at_end`).

    Raises:
        SourceConfigError: No such file, or not a log python-can reads.
        SourceUnavailableError: The library of that format is missing.
    """

    def __init__(self, path: str | Path, speed: float, clock: Callable[[], float] = time.monotonic) -> None:
        """Open the log; nothing is read until the first :meth:`recv`."""
        self.path = Path(path)
        self._reader = _log_reader(self.path)
        super().__init__(channel=str(self.path))
        self.channel_info = f"log file {self.path}"
        self.speed = speed
        self.frames = 0
        self.exhausted = False
        self._messages: Iterator[can.Message] = iter(self._reader)
        self._next: can.Message | None = None
        self._clock = clock
        self._t0: tuple[float, float] | None = None

    def at_end(self) -> bool:
        """True when every frame has been read (looks one frame ahead).

        Raises:
            SourceIOError: The next record is damaged.
        """
        if self._next is None and not self.exhausted:
            try:
                self._next = next(self._messages)
            except StopIteration:
                self.exhausted = True
            except Exception as exc:  # a damaged record: each reader has its own error types
                raise SourceIOError(f"can source: {self.path}: frame {self.frames + 1}: {exc}") from None
        return self.exhausted

    def peek(self) -> can.Message | None:
        """The next frame, not taken (None at the end)."""
        self.at_end()
        return self._next

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        """The next frame if it is due (never waits: the source polls)."""
        self.at_end()
        msg = self._next
        if msg is None:
            return None, True
        if self.speed > 0:
            now = self._clock()
            if self._t0 is None:
                self._t0 = (now, float(msg.timestamp))
            if (float(msg.timestamp) - self._t0[1]) / self.speed > now - self._t0[0]:
                return None, True  # not due yet
        self._next = None
        self.frames += 1
        return msg, False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Refused: a log file is read, not written."""
        raise can.CanOperationError(f"{self.path} is a log file: it is read, not sent to")

    def shutdown(self) -> None:
        """Close the file."""
        stop = getattr(self._reader, "stop", None)
        if stop is not None:
            stop()
        super().shutdown()


def _log_reader(path: Path) -> Any:
    if not path.is_file():
        raise SourceConfigError("can", "can_log_file", "no such file", str(path))
    try:
        return can.LogReader(path)
    except ValueError as exc:  # an unknown suffix
        raise SourceConfigError("can", "can_log_file", f"not a python-can log file: {exc}", str(path)) from None
    except (OSError, ImportError) as exc:
        raise SourceUnavailableError("can", "can_log_file", f"cannot be read: {exc}", str(path)) from None
