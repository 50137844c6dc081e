"""A CAN rate gyro as a gyro source, through python-can.

The gyro sends ``samples_per_frame`` samples a frame on one CAN id, as ``sample_format``
(``int16``, ``int32``, ``float32``) in ``byte_order``, oldest first; a sample is
``count * scale + offset`` rad/s. Classic frames carry up to 8 bytes, CAN FD (``can_fd``) a
valid FD length up to 64. The bus is chosen by :func:`bike_rig.sources.can_bus.choose_bus`;
``can_log_file`` plays a python-can log instead. :class:`SimulatedCanGyro` is a stand-in gyro
on a ``virtual`` bus (which connects buses of one process only).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config.settings import ParamSpec
from ..core.sim.gyro import Mode, angular_rate
from ..pipeline.acquire import NS_PER_S
from .base import SAMPLE_RATE, TIME_SCALE, FloatArray, Parameters, SourceEvent, StreamingSource
from .errors import SourceIOError, SourceUnavailableError

if TYPE_CHECKING:
    import can as can_module

    from .can_bus import FrameClock

__all__ = [
    "FD_LENGTHS",
    "CanFrameLayout",
    "CanSource",
    "SimulatedCanGyro",
    "array_samples",
    "damped_samples",
]

_log = logging.getLogger(__name__)

#: The data lengths a CAN FD frame can have, bytes.
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
_FORMATS = {"int16": "i2", "int32": "i4", "float32": "f4"}
#: Most frames read per poll, of any id (keeps the driver responsive if a bus floods it).
_MAX_FRAMES_PER_READ = 50_000


@dataclass(frozen=True)
class CanFrameLayout:
    """How the gyro packs its samples into frames.

    Attributes:
        can_id: Arbitration id of the gyro's frames.
        extended_id: 29-bit (True) or 11-bit id.
        sample_format: ``int16``, ``int32`` or ``float32``.
        byte_order: ``little`` or ``big``.
        samples_per_frame: Samples in each frame.
        scale: rad/s per count.
        offset: rad/s added after scaling.
        fd: CAN FD frames.
    """

    can_id: int
    extended_id: bool = False
    sample_format: str = "int16"
    byte_order: str = "little"
    samples_per_frame: int = 4
    scale: float = 1e-4
    offset: float = 0.0
    fd: bool = False

    @property
    def dtype(self) -> np.dtype[Any]:
        """The samples' numpy dtype, with its byte order."""
        return np.dtype(("<" if self.byte_order == "little" else ">") + _FORMATS[self.sample_format])

    @property
    def frame_bytes(self) -> int:
        """Data length of one frame, bytes."""
        return self.samples_per_frame * self.dtype.itemsize

    def problems(self) -> list[tuple[str, str, object]]:
        """What is wrong with the layout, as (parameter, reason, value)."""
        out: list[tuple[str, str, object]] = []
        if self.sample_format not in _FORMATS:
            out.append(("sample_format", f"expected one of {', '.join(_FORMATS)}", self.sample_format))
            return out
        if self.byte_order not in ("little", "big"):
            out.append(("byte_order", "expected little or big", self.byte_order))
        top = 0x1FFFFFFF if self.extended_id else 0x7FF
        if not 0 <= self.can_id <= top:
            kind = "a 29-bit" if self.extended_id else "an 11-bit (set can_extended_id for 29 bits)"
            out.append(("can_id", f"must be {kind} id, 0..0x{top:X}", self.can_id))
        n = self.frame_bytes
        if self.samples_per_frame < 1:
            out.append(("samples_per_frame", "must be >= 1", self.samples_per_frame))
        elif not self.fd and n > 8:
            out.append(
                (
                    "samples_per_frame",
                    f"{n} bytes of {self.sample_format} exceed a classic frame's 8 (set can_fd)",
                    self.samples_per_frame,
                )
            )
        elif self.fd and n not in FD_LENGTHS:
            out.append(
                (
                    "samples_per_frame",
                    f"{n} bytes is not a CAN FD data length ({', '.join(map(str, FD_LENGTHS))})",
                    self.samples_per_frame,
                )
            )
        if not (math.isfinite(self.scale) and self.scale != 0):
            out.append(("scale", "must be a finite, non-zero number of rad/s per count", self.scale))
        if not math.isfinite(self.offset):
            out.append(("offset", "must be finite", self.offset))
        return out

    def decode(self, data: bytes | bytearray) -> FloatArray:
        """The samples of one frame's data, rad/s."""
        counts = np.frombuffer(bytes(data), dtype=self.dtype)
        return counts.astype(np.float64) * self.scale + self.offset

    def encode(self, rates: FloatArray) -> bytes:
        """One frame's data for ``samples_per_frame`` rates (integers rounded and saturated)."""
        counts = (np.asarray(rates, dtype=np.float64) - self.offset) / self.scale
        if self.dtype.kind == "i":
            info = np.iinfo(self.dtype)
            counts = np.clip(np.rint(counts), info.min, info.max)
        return counts.astype(self.dtype).tobytes()


def layout_from_parameters(p: Parameters) -> CanFrameLayout:
    """The frame layout from the driver's parameters (read with :attr:`CanSource.PARAMETERS`).

    Raises:
        SourceConfigError: A layout parameter is wrong.
    """
    layout = CanFrameLayout(
        can_id=p.integer("can_id"),
        extended_id=p.flag("can_extended_id"),
        sample_format=p.text("sample_format"),
        byte_order=p.text("byte_order"),
        samples_per_frame=p.integer("samples_per_frame"),
        scale=p.number("scale"),
        offset=p.number("offset"),
        fd=p.flag("can_fd"),
    )
    for name, reason, value in layout.problems():
        raise p.error(name, reason, value)
    return layout


def _import_can() -> Any:
    """The python-can package.

    Raises:
        SourceUnavailableError: python-can is not installed.
    """
    try:
        import can
    except ImportError as exc:
        raise SourceUnavailableError(
            "can", "source", f"python-can is not installed ({exc}); install python-can", "can"
        ) from None
    return can


def open_bus(
    interface: str, channel: str, layout: CanFrameLayout, bitrate: int = 0, options: Mapping[str, Any] | None = None
) -> can_module.BusABC:
    """A python-can bus, unfiltered (the source keeps the gyro's frames by id).

    Args:
        interface: python-can interface.
        channel: Its channel.
        layout: The frame layout (CAN FD or not).
        bitrate: Bit rate, bit/s (0: the interface's or the configuration's).
        options: Further ``can.Bus`` arguments (python-can's configuration).

    Raises:
        SourceConfigError: An unknown or refused interface.
        SourceUnavailableError: The interface cannot be opened here (no kernel support, no
            device, missing vendor library).
    """
    can = _import_can()
    from .can_bus import check_interface

    check_interface(interface, "can_interface")
    kwargs: dict[str, Any] = {**(options or {}), "interface": interface, "channel": channel}
    kwargs["fd"] = layout.fd or bool(kwargs.get("fd", False))
    if bitrate > 0:
        kwargs["bitrate"] = bitrate
    try:
        return can.Bus(**kwargs)
    except (can.CanError, OSError, ValueError, ImportError, TypeError) as exc:
        hint = " (this kernel has no CAN support: use can_interface 'virtual')" if interface == "socketcan" else ""
        raise SourceUnavailableError(
            "can", "can_interface", f"cannot open channel {channel!r}: {exc}{hint}", interface
        ) from None


class CanSource(StreamingSource):
    """A CAN gyro; trials on request.

    Frames of other ids are ignored; a frame of the gyro's id with the wrong length is counted
    and dropped. The bus is read unfiltered and each poll drains every waiting frame (software
    filters make a non-blocking receive return nothing at another id's frame). A trial starts
    with the first sample after ``start_trial``, stamped from the first frame's own time minus
    its earlier samples when the interface stamps in epoch time, else from the receive clock;
    later samples at ``index / sample_rate_hz``. ``can_log_speed`` 0 plays a log as fast as it
    is read, only while a trial records.

    Args:
        bus: An open python-can bus (unfiltered, or filtered on the gyro's id), or a log
            file's (:class:`~bike_rig.sources.can_bus.LogBus`).
        layout: The frame layout.
        sample_rate_hz: The gyro's sample rate, Hz.
        label: What it reads, for the log.
        simulated_gyro: A stand-in gyro to stop on :meth:`close` (test and demo option).
        clock: The stamps' clock (default: the interface's, checked on the first frames).
        warning: A warning for the operator about the bus (e.g. the default virtual bus).
    """

    name = "can"
    PARAMETERS = (
        ParamSpec(
            "can_interface",
            "",
            "can: python-can interface; '' = python-can's configuration (CAN_INTERFACE, its config file), "
            "else the virtual bus",
        ),
        ParamSpec("can_channel", "", "can: channel (e.g. can0); '' = python-can's configuration's, or bike_rig"),
        ParamSpec("can_bitrate", 0, "can: bit rate, bit/s (0 = the interface's setting)", (0, 8_000_000)),
        ParamSpec("can_id", 0x100, "can: arbitration id of the gyro's frames", (0, 0x1FFFFFFF)),
        ParamSpec("can_extended_id", False, "can: 29-bit id"),
        ParamSpec("can_fd", False, "can: CAN FD frames (up to 64 bytes)"),
        ParamSpec("sample_format", "int16", "can: sample encoding", choices=tuple(_FORMATS)),
        ParamSpec("byte_order", "little", "can: byte order of the samples", choices=("little", "big")),
        ParamSpec("samples_per_frame", 4, "can: samples in each frame", (1, 64)),
        ParamSpec("scale", 1e-4, "can: rad/s per count"),
        ParamSpec("offset", 0.0, "can: rad/s added after scaling"),
        SAMPLE_RATE,
        ParamSpec(
            "can_log_file",
            "",
            "can: a python-can log file to play instead of a bus (candump .log, .asc, .blf, .trc...)",
        ),
        ParamSpec(
            "can_log_speed",
            1.0,
            "can: how fast can_log_file plays, times real time; 0 = as fast as read, while a trial records",
            (0.0, 1e6),
        ),
        ParamSpec(
            "can_simulated_gyro_period_s",
            0.0,
            "can, test/demo only: > 0 runs a simulated gyro of this period on the virtual bus in this process",
            (0.0, 1e3),
        ),
        TIME_SCALE,
    )

    def __init__(
        self,
        bus: can_module.BusABC,
        layout: CanFrameLayout,
        sample_rate_hz: float,
        label: str = "CAN gyro",
        simulated_gyro: SimulatedCanGyro | None = None,
        clock: FrameClock | None = None,
        warning: str = "",
    ):
        """Read ``bus``; no trial is recorded until :meth:`start_trial`."""
        from .can_bus import FrameClock

        super().__init__(sample_rate_hz)
        self.bus = bus
        self.layout = layout
        self.label = label
        self.simulated_gyro = simulated_gyro
        self.clock = clock if clock is not None else FrameClock()
        self.warning = warning
        self.malformed_frames = 0
        self.reads = 0  # bus receives, of any id
        self._notices: list[tuple[bool, str]] = [(True, warning)] if warning else []
        self._closed = False

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> CanSource:
        """Open the bus (or the log file) the parameters describe (:attr:`PARAMETERS`).

        ``can_interface``, ``can_channel``, ``can_bitrate``, ``can_id``, ``can_extended_id``,
        ``can_fd``, ``sample_format``, ``byte_order``, ``samples_per_frame``, ``scale``,
        ``offset``, ``sample_rate_hz``, ``can_log_file`` and ``can_log_speed``, and for tests and
        demos ``can_simulated_gyro_period_s`` (> 0: run a :class:`SimulatedCanGyro` of that
        period on the virtual bus, paced by ``time_scale``).

        Raises:
            SourceConfigError: A bad parameter or layout, a refused interface, a log file that
                cannot be read.
            SourceUnavailableError: python-can or the interface is not available here.
        """
        p = Parameters(cls.name, parameters, cls.PARAMETERS)
        rate = p.number("sample_rate_hz")
        layout = layout_from_parameters(p)
        ident = f"id 0x{layout.can_id:X} {layout.samples_per_frame}×{layout.sample_format}"
        _import_can()
        from .can_bus import FrameClock, LogBus, choose_bus

        log_file = p.text("can_log_file")
        if log_file:
            speed = p.number("can_log_speed")
            pace = "as fast as read, while a trial records" if speed == 0 else f"at {speed:g}× real time"
            return cls(
                LogBus(log_file, speed),
                layout,
                rate,
                f"log file {log_file} {ident}, played {pace}",
                clock=FrameClock("the log's", epoch_window_s=math.inf),
            )
        choice = choose_bus(p.text("can_interface"), p.text("can_channel"), p.integer("can_bitrate"))
        period = p.number("can_simulated_gyro_period_s")
        gyro = None
        if period > 0:
            if choice.interface != "virtual":
                reason = f"a simulated gyro runs on the 'virtual' interface only, not {choice.interface!r}"
                raise p.error("can_simulated_gyro_period_s", reason, period)
            time_scale = p.number("time_scale")
            gyro = SimulatedCanGyro(layout, choice.channel, damped_samples(period, rate), rate, time_scale=time_scale)
        bus = open_bus(choice.interface, choice.channel, layout, options=choice.options)
        label = f"{choice.describe()} {ident}"
        warning = ""
        if gyro is not None:
            gyro.start()
            label += f" (simulated gyro, period {period:g} s)"
        elif choice.interface == "virtual":
            how = "nothing names a bus" if choice.defaulted else f"named by {choice.origin}"
            warning = (
                f"listening on python-can's VIRTUAL bus {choice.channel!r} ({how}): no hardware reaches it. Name "
                "the gyro's bus with the driver parameters can_interface and can_channel, or python-can's "
                "CAN_INTERFACE and CAN_CHANNEL (or its configuration file)"
            )
        return cls(bus, layout, rate, label, gyro, warning=warning)

    def describe(self) -> str:
        """The bus, id, layout, sample rate and stamps' clock, one line (the virtual bus warned of)."""
        stamps = self.clock.notice or "stamps: not yet checked (no frame of the gyro yet)"
        head = "can: VIRTUAL bus, no hardware: " if self.warning else "can: "
        return f"{head}{self.label}; {self.sample_rate_hz:g} Hz; {stamps}"

    def notices(self) -> list[tuple[bool, str]]:
        """Since the last call, as (is a warning, text): the virtual bus, the stamps' clock, a log's end."""
        out, self._notices = self._notices, []
        return out

    def silence_hint(self) -> str:
        """What to check when no frame of the gyro's id arrives."""
        hint = f"check the bus/wiring and the CAN id (listening to {self.label})"
        if self.warning:
            hint += "; this is python-can's VIRTUAL bus, which no hardware reaches: name the gyro's (can_interface)"
        return hint

    @property
    def finished(self) -> bool:
        """True once a log file has played its last frame and no trial records."""
        return self.recording is None and self._log_at_end()

    def _frames_wanted(self) -> int:
        """Gyro frames to take now: a log played as fast as read gives a trial only the frames it asks for."""
        if getattr(self.bus, "speed", None) != 0:
            return _MAX_FRAMES_PER_READ
        rec = self._recording
        if rec is None:
            return 0
        if rec.target == 0:
            return _MAX_FRAMES_PER_READ
        return -(-(rec.target - rec.count) // self.layout.samples_per_frame)

    def read_available(self) -> tuple[FloatArray, FloatArray | None, int]:
        """The samples of the gyro's frames waiting on the bus, every one (at most 50,000 frames read).

        Returns:
            (rates rad/s, None, epoch time of the first sample in ns).

        Raises:
            SourceIOError: The bus (or the log file) failed.
        """
        chunks: list[FloatArray] = []
        first_stamp = newest_stamp = 0.0
        wanted = self._frames_wanted()
        expected = self.layout.frame_bytes
        for _ in range(_MAX_FRAMES_PER_READ if wanted else 0):
            try:
                msg = self.bus.recv(timeout=0.0)
            except SourceIOError:
                raise
            except Exception as exc:  # any backend failure is an I/O error here
                raise SourceIOError(f"can source: reading {self.label} failed: {exc}") from None
            if msg is None:
                break
            self.reads += 1
            if not self._is_gyro(msg):
                continue
            if len(msg.data) != expected:
                self._malformed(len(msg.data))
                continue
            if not chunks:
                first_stamp = float(msg.timestamp)
            newest_stamp = float(msg.timestamp)
            chunks.append(self.layout.decode(msg.data))
            if len(chunks) >= wanted:
                break
        if not chunks:
            return np.empty(0), None, 0
        read_ns = time.time_ns()
        self._check_clock(newest_stamp, read_ns)
        rates = np.concatenate(chunks)
        earlier = self.layout.samples_per_frame - 1
        return rates, None, self.clock.first_ns(first_stamp, earlier, self.sample_rate_hz, read_ns, rates.size)

    def _check_clock(self, newest_stamp_s: float, read_ns: int) -> None:
        """On the first frames: decide whether their stamps are epoch time (a warning when not)."""
        if self.clock.source is not None:
            return
        self.clock.check(newest_stamp_s, read_ns / NS_PER_S)
        self._notices.append((self.clock.source == "receive", f"can source ({self.label}): {self.clock.notice}"))

    def _malformed(self, length: int) -> None:
        self.malformed_frames += 1
        if self.malformed_frames in (1, 10, 100, 1000) or self.malformed_frames % 10000 == 0:
            _log.warning(
                "can source: %d malformed frame(s) of id 0x%X dropped (last: %d bytes, expected %d)",
                self.malformed_frames,
                self.layout.can_id,
                length,
                self.layout.frame_bytes,
            )

    def poll(self) -> list[SourceEvent]:
        """The events of the frames waiting (and of requests since); a log's end ends the trial recording."""
        events = super().poll()
        self._end_of_log()
        events += self._events
        self._events = []
        return events

    def _log_at_end(self) -> bool:
        """True when the bus is a log file with no frame of the gyro's id left (others are skipped to see)."""
        from .can_bus import LogBus

        bus = self.bus
        if not isinstance(bus, LogBus):
            return False
        while not bus.at_end():
            msg = bus.peek()
            if msg is not None and self._is_gyro(msg):
                return False
            if bus.recv(timeout=0.0) is None:  # not due yet (a paced log)
                return False
            self.reads += 1
        return True

    def _is_gyro(self, msg: can_module.Message) -> bool:
        """A data frame of the gyro's id (of any length)."""
        ours = msg.arbitration_id == self.layout.can_id and msg.is_extended_id == self.layout.extended_id
        return ours and not (msg.is_error_frame or msg.is_remote_frame)

    def _end_of_log(self) -> None:
        """A log file that has ended ends the trial recording: complete if until stopped, else aborted."""
        rec = self._recording
        if rec is None or (rec.target and rec.count >= rec.target) or not self._log_at_end():
            return
        if rec.target:
            ended = f"the log file ended during trial {rec.info.trial_id} after {rec.count} of {rec.target} samples"
            self._notices.append((True, f"can source: {ended}: aborted"))
        self._finish(aborted=bool(rec.target))

    def close(self) -> None:
        """Stop the simulated gyro, if any, and shut the bus down (idempotent)."""
        if self._closed:
            return
        self._closed = True
        if self.simulated_gyro is not None:
            self.simulated_gyro.stop()
        self.bus.shutdown()


SampleFunction = Callable[[int, int], FloatArray | None]


def array_samples(rates: FloatArray) -> SampleFunction:
    """A sample function that plays ``rates`` once, then ends."""
    data = np.asarray(rates, dtype=np.float64)

    def samples(start: int, n: int) -> FloatArray | None:
        return data[start : start + n] if start < data.size else None

    return samples


def damped_samples(
    period_s: float,
    sample_rate_hz: float,
    damping_ratio: float = 0.001,
    amplitude_rad: float = 0.01,
    noise_rad_s: float = 1e-4,
    seed: int = 0,
) -> SampleFunction:
    """An endless, lightly damped pendulum (Eq 23's motion) with white rate noise.

    Args:
        period_s: Undamped period of the pendulum, s (the observed one is
            ``period_s / sqrt(1 - damping_ratio**2)``).
        sample_rate_hz: Hz.
        damping_ratio: ζ.
        amplitude_rad: Initial angle amplitude, rad.
        noise_rad_s: Standard deviation of the white noise per sample, rad/s.
        seed: Seed of the noise.
    """
    mode = (Mode(period_s, damping_ratio, amplitude_rad, 0.3),)
    rng = np.random.default_rng(seed)

    def samples(start: int, n: int) -> FloatArray:
        t = np.arange(start, start + n, dtype=np.float64) / sample_rate_hz
        return angular_rate(t, mode) + noise_rad_s * rng.standard_normal(n)

    return samples


class SimulatedCanGyro:
    """A stand-in CAN gyro: a thread that sends samples in frames on a python-can bus.

    It sends ``samples`` in frames of ``layout`` on the bus (``virtual`` by default),
    ``time_scale`` times faster than real time (``math.inf``: as fast as it can).

    Args:
        layout: Frame layout (the reader's).
        channel: The bus channel.
        samples: ``samples(start, n)`` gives the rates of samples ``start`` to ``start + n``
            (None or fewer at the end of the signal).
        sample_rate_hz: Nominal rate, Hz.
        time_scale: Speed-up over real time.
        interface: python-can interface.
    """

    def __init__(
        self,
        layout: CanFrameLayout,
        channel: str,
        samples: SampleFunction,
        sample_rate_hz: float,
        *,
        time_scale: float = 1.0,
        interface: str = "virtual",
    ):
        """A gyro that has not started sending (see :meth:`start`)."""
        self.layout = layout
        self.channel = channel
        self.samples = samples
        self.sample_rate_hz = sample_rate_hz
        self.time_scale = time_scale
        self.interface = interface
        self.frames_sent = 0
        self.samples_sent = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="simulated-can-gyro", daemon=True)
        self._bus = open_bus(interface, channel, layout)

    def start(self) -> SimulatedCanGyro:
        """Start sending."""
        self._thread.start()
        return self

    @property
    def done(self) -> bool:
        """True once the signal has ended (or sending failed)."""
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until the signal has ended; True if it has."""
        return self._done.wait(timeout)

    def stop(self) -> None:
        """Stop sending and release the bus (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self._bus.shutdown()

    def _run(self) -> None:
        import can

        spf = self.layout.samples_per_frame
        frame_s = spf / self.sample_rate_hz / self.time_scale
        t0 = time.monotonic()
        try:
            while not self._stop.is_set():
                if math.isinf(self.time_scale):
                    due = self.frames_sent + 1000
                else:
                    due = int((time.monotonic() - t0) / frame_s) + 1
                while self.frames_sent < due and not self._stop.is_set():
                    rates = self.samples(self.samples_sent, spf)
                    if rates is None or len(rates) < spf:
                        return
                    msg = can.Message(
                        arbitration_id=self.layout.can_id,
                        is_extended_id=self.layout.extended_id,
                        is_fd=self.layout.fd,
                        data=self.layout.encode(rates),
                    )
                    self._bus.send(msg)
                    self.frames_sent += 1
                    self.samples_sent += spf
                if not math.isinf(self.time_scale):
                    self._stop.wait(min(0.002, frame_s))
        except BaseException as exc:  # reported through .error, never lost
            self.error = exc
        finally:
            self._done.set()
