"""An analog rate gyro on an NI data-acquisition device (the paper's NI USB-6008), through NI-DAQmx.

A continuous voltage task on ``daq_channel`` (``Dev1/ai0``) at ``sample_rate_hz``; the rate is
``(V − daq_zero_rate_v) / daq_scale_v_per_rad_s`` rad/s, raw volts passed on. Trials on request;
each read's samples are stamped back from its wall time at the nominal rate (start good to about
one poll period). ``nidaqmx`` (optional extra, plus NI's driver) is imported when the source is
opened; when missing, the error says which.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Mapping
from types import ModuleType
from typing import Any

import numpy as np

from ..config.settings import ParamSpec
from ..pipeline.acquire import NS_PER_S
from .base import SAMPLE_RATE, FloatArray, Parameters, StreamingSource
from .errors import SourceConfigError, SourceIOError, SourceUnavailableError

__all__ = ["TERMINALS", "DaqSource", "import_nidaqmx"]

#: ``daq_terminal`` values and the ``nidaqmx.constants.TerminalConfiguration`` member names
#: (current name first, then the pre-0.6 spelling).
TERMINALS: dict[str, tuple[str, ...]] = {
    "differential": ("DIFF", "DIFFERENTIAL"),
    "rse": ("RSE",),
    "nrse": ("NRSE",),
    "pseudo_differential": ("PSEUDO_DIFF", "PSEUDODIFFERENTIAL"),
    "default": ("DEFAULT",),
}


def import_nidaqmx() -> ModuleType:
    """The ``nidaqmx`` module.

    Raises:
        SourceUnavailableError: It is not installed.
    """
    try:
        return importlib.import_module("nidaqmx")
    except ImportError as exc:
        raise SourceUnavailableError(
            "daq",
            "source",
            f"the daq source needs the 'nidaqmx' package and NI's NI-DAQmx driver ({exc}); "
            "install them (pip install nidaqmx) or choose another source",
            "daq",
        ) from None


def _constants(nidaqmx: ModuleType) -> Any:
    constants = getattr(nidaqmx, "constants", None)
    return constants if constants is not None else importlib.import_module("nidaqmx.constants")


class DaqSource(StreamingSource):
    """An NI-DAQmx analog input (see the module docstring).

    Args:
        task: A started continuous ``nidaqmx.Task`` with one voltage channel.
        sample_rate_hz: Its sample rate, Hz.
        scale_v_per_rad_s: The gyro's scale factor, V / (rad/s).
        zero_rate_v: Its output at zero rate, V.
        read_all: ``nidaqmx.constants.READ_ALL_AVAILABLE``.
        label: What it reads, for the log.
    """

    name = "daq"
    PARAMETERS = (
        ParamSpec("daq_channel", "Dev1/ai0", "daq: NI-DAQmx physical channel"),
        ParamSpec("daq_terminal", "differential", "daq: terminal configuration", choices=tuple(TERMINALS)),
        ParamSpec("daq_min_v", -5.0, "daq: input range low, V"),
        ParamSpec("daq_max_v", 5.0, "daq: input range high, V"),
        ParamSpec("daq_scale_v_per_rad_s", 1.1459156, "daq: gyro scale factor, V per rad/s"),
        ParamSpec("daq_zero_rate_v", 2.5, "daq: gyro output at zero rate, V"),
        ParamSpec("daq_buffer_s", 10.0, "daq: acquisition buffer, s", (0.01, 3600.0)),
        SAMPLE_RATE,
    )

    def __init__(
        self,
        task: Any,
        sample_rate_hz: float,
        scale_v_per_rad_s: float,
        zero_rate_v: float,
        read_all: int = -1,
        label: str = "NI-DAQmx",
    ):
        """Read the started ``task``; no trial is recorded until :meth:`start_trial`."""
        super().__init__(sample_rate_hz)
        self.task = task
        self.scale_v_per_rad_s = scale_v_per_rad_s
        self.zero_rate_v = zero_rate_v
        self.read_all = read_all
        self.label = label
        self._closed = False

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> DaqSource:
        """Create and start the voltage task the parameters describe (:attr:`PARAMETERS`).

        ``daq_channel``, ``daq_terminal``, ``daq_min_v``, ``daq_max_v``,
        ``daq_scale_v_per_rad_s``, ``daq_zero_rate_v``, ``daq_buffer_s``, ``sample_rate_hz``.

        Raises:
            SourceConfigError: A bad parameter, or NI-DAQmx refused the task.
            SourceUnavailableError: nidaqmx or NI's driver is missing.
        """
        p = Parameters(cls.name, parameters, cls.PARAMETERS)
        channel = p.text("daq_channel")
        if not channel:
            raise p.error("daq_channel", "expected a physical channel such as Dev1/ai0", channel)
        terminal = p.text("daq_terminal")
        low = p.number("daq_min_v")
        high = p.number("daq_max_v")
        if not low < high:
            raise p.error("daq_max_v", f"must be above daq_min_v ({low:g} V)", high)
        rate = p.number("sample_rate_hz")
        scale = p.number("daq_scale_v_per_rad_s")
        if scale == 0:
            raise p.error("daq_scale_v_per_rad_s", "must not be zero", scale)
        zero = p.number("daq_zero_rate_v")
        buffer_s = p.number("daq_buffer_s")
        nidaqmx = import_nidaqmx()
        constants = _constants(nidaqmx)
        names = TERMINALS[terminal]
        config = next(
            (getattr(constants.TerminalConfiguration, n) for n in names if hasattr(constants.TerminalConfiguration, n)),
            None,
        )
        if config is None:
            raise p.error("daq_terminal", "this nidaqmx has no such terminal configuration", terminal)
        try:
            task = nidaqmx.Task()
        except Exception as exc:  # DaqNotFoundError & co: the driver is missing
            raise SourceUnavailableError(
                "daq",
                "daq_channel",
                f"cannot create an NI-DAQmx task ({type(exc).__name__}: {exc}); is NI's NI-DAQmx driver installed?",
                channel,
            ) from None
        try:
            task.ai_channels.add_ai_voltage_chan(channel, terminal_config=config, min_val=low, max_val=high)
            task.timing.cfg_samp_clk_timing(
                rate, sample_mode=constants.AcquisitionType.CONTINUOUS, samps_per_chan=max(2, round(buffer_s * rate))
            )
            task.start()
        except Exception as exc:  # DaqError: no such device/channel, rate too high...
            task.close()
            raise SourceConfigError("daq", "daq_channel", f"NI-DAQmx refused the task: {exc}", channel) from None
        label = f"{channel} ({terminal}, {low:g}..{high:g} V)"
        return cls(task, rate, scale, zero, int(constants.READ_ALL_AVAILABLE), label)

    def describe(self) -> str:
        """The channel, terminal and input range, and the sample rate, for the log."""
        return f"daq: {self.label} at {self.sample_rate_hz:g} Hz"

    def silence_hint(self) -> str:
        """What to check when the task delivers no samples."""
        return f"check the wiring and the DAQ channel ({self.label})"

    def read_available(self) -> tuple[FloatArray, FloatArray | None, int]:
        """The samples acquired since the last call, stamped back from now at the nominal rate.

        Returns:
            (rates rad/s, raw volts V, epoch time of the first sample in ns).

        Raises:
            SourceIOError: The read failed (buffer overflow, device removed).
        """
        try:
            data = self.task.read(number_of_samples_per_channel=self.read_all, timeout=0.0)
        except Exception as exc:  # buffer overflow, device removed
            raise SourceIOError(f"daq source: reading {self.label} failed: {exc}") from None
        now_ns = time.time_ns()
        volts = np.asarray(data, dtype=np.float64).reshape(-1)
        if volts.size == 0:
            return np.empty(0), None, 0
        first_ns = now_ns - round((volts.size - 1) * NS_PER_S / self.sample_rate_hz)
        return (volts - self.zero_rate_v) / self.scale_v_per_rad_s, volts, first_ns

    def close(self) -> None:
        """Stop and close the task (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self.task.stop()
        finally:
            self.task.close()
