"""The DAQ source against a stand-in for the nidaqmx task API.

A fake module injected as ``nidaqmx``: the task it configures, volts to rad/s, trials on request; and the errors when
nidaqmx or the NI driver is missing.
"""

from __future__ import annotations

import sys
import types
from enum import Enum
from typing import Any

import numpy as np
import pytest

from bike_rig.sources import (
    SampleBlock,
    SourceConfigError,
    SourceUnavailableError,
    TrialRequest,
    TrialStarted,
    TrialStopped,
    open_source,
)
from bike_rig.sources.daq import DaqSource

RATE = 1000.0
SCALE = 1.1459156
ZERO = 2.5


class FakeTask:
    """Records what the source asks of it; ``read`` returns what the test queued."""

    instances: list[FakeTask] = []
    fail_on_create: Exception | None = None

    def __init__(self) -> None:
        if FakeTask.fail_on_create is not None:
            raise FakeTask.fail_on_create
        self.calls: list[tuple[str, Any]] = []
        self.queue: list[float] = []
        self.closed = False
        task = self

        class Channels:
            def add_ai_voltage_chan(self, physical_channel: str, **kw: Any) -> None:
                task.calls.append(("add_ai_voltage_chan", (physical_channel, kw)))

        class Timing:
            def cfg_samp_clk_timing(self, rate: float, **kw: Any) -> None:
                task.calls.append(("cfg_samp_clk_timing", (rate, kw)))

        self.ai_channels = Channels()
        self.timing = Timing()
        FakeTask.instances.append(self)

    def start(self) -> None:
        self.calls.append(("start", None))

    def read(self, number_of_samples_per_channel: int = 1, timeout: float = 10.0) -> list[float]:
        assert number_of_samples_per_channel == -1 and timeout == 0.0
        out, self.queue = self.queue, []
        return out

    def stop(self) -> None:
        self.calls.append(("stop", None))

    def close(self) -> None:
        self.closed = True


@pytest.fixture
def fake_nidaqmx(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    module = types.ModuleType("nidaqmx")
    constants = types.ModuleType("nidaqmx.constants")
    constants.AcquisitionType = Enum("AcquisitionType", "FINITE CONTINUOUS")  # type: ignore[attr-defined]
    constants.TerminalConfiguration = Enum("TerminalConfiguration", "DEFAULT RSE NRSE DIFF PSEUDO_DIFF")  # type: ignore[attr-defined]
    constants.READ_ALL_AVAILABLE = -1  # type: ignore[attr-defined]
    module.constants = constants  # type: ignore[attr-defined]
    module.Task = FakeTask  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "nidaqmx", module)
    monkeypatch.setitem(sys.modules, "nidaqmx.constants", constants)
    FakeTask.instances = []
    FakeTask.fail_on_create = None
    return module


def test_configures_a_continuous_voltage_task(fake_nidaqmx: types.ModuleType) -> None:
    source = open_source(
        "daq",
        daq_channel="Dev2/ai1",
        daq_terminal="differential",
        daq_min_v=-10.0,
        daq_max_v=10.0,
        sample_rate_hz=RATE,
        daq_buffer_s=5.0,
    )
    task = FakeTask.instances[-1]
    constants: Any = fake_nidaqmx.constants
    assert task.calls == [
        (
            "add_ai_voltage_chan",
            ("Dev2/ai1", {"terminal_config": constants.TerminalConfiguration.DIFF, "min_val": -10.0, "max_val": 10.0}),
        ),
        ("cfg_samp_clk_timing", (RATE, {"sample_mode": constants.AcquisitionType.CONTINUOUS, "samps_per_chan": 5000})),
        ("start", None),
    ]
    source.close()
    assert task.calls[-1] == ("stop", None) and task.closed


def test_records_trials_on_request_in_rad_per_s(fake_nidaqmx: types.ModuleType) -> None:
    source = open_source("daq", daq_scale_v_per_rad_s=SCALE, daq_zero_rate_v=ZERO, sample_rate_hz=RATE)
    assert isinstance(source, DaqSource)
    task = FakeTask.instances[-1]
    rates = 0.1 * np.sin(np.arange(250) / 20)
    volts = ZERO + SCALE * rates
    task.queue = [9.0] * 7  # before the request: not part of the trial
    info = source.start_trial(TrialRequest("rear_wheel", "torsional", duration_s=0.2))
    assert (info.trial_id, info.measurement_key) == ("rear_wheel_torsional_t1", "TtR1")
    events = []
    for chunk in np.array_split(volts, 5):
        task.queue = list(chunk)
        events += source.poll()
    assert isinstance(events[0], TrialStarted) and events[0].info == info
    blocks = [e for e in events if isinstance(e, SampleBlock)]
    got = np.concatenate([b.rates for b in blocks])
    assert got.size == 200  # 0.2 s at 1 kHz, the rest is after the trial
    np.testing.assert_allclose(got, rates[:200], rtol=0, atol=1e-15)
    assert np.array_equal(np.concatenate([b.raw_volts for b in blocks if b.raw_volts is not None]), volts[:200])
    assert isinstance(events[-1], TrialStopped) and events[-1].sample_count == 200
    source.close()


def test_missing_nidaqmx_is_one_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "nidaqmx", None)  # import nidaqmx -> ImportError
    with pytest.raises(SourceUnavailableError) as info:
        open_source("daq", {})
    message = str(info.value)
    assert message.startswith("daq source: parameter 'source' = 'daq': the daq source needs the 'nidaqmx' package")
    assert "pip install nidaqmx" in message and "\n" not in message


def test_missing_ni_driver_is_one_clear_error(fake_nidaqmx: types.ModuleType) -> None:
    FakeTask.fail_on_create = OSError("libnidaqmx.so: cannot open shared object file")
    pattern = (
        r"^daq source: parameter 'daq_channel' = 'Dev1/ai0': cannot create an NI-DAQmx task "
        r"\(OSError: libnidaqmx.so: .*is NI's NI-DAQmx driver installed\?$"
    )
    with pytest.raises(SourceUnavailableError, match=pattern):
        open_source("daq", {})


@pytest.mark.parametrize(
    ("parameters", "pattern"),
    [
        ({"daq_min_v": 5.0, "daq_max_v": 1.0}, r"^daq source: parameter 'daq_max_v' = 1.0: must be above daq_min_v"),
        ({"daq_terminal": "single"}, r"'daq_terminal' = 'single': expected one of differential, rse, nrse"),
        ({"daq_scale_v_per_rad_s": 0.0}, r"'daq_scale_v_per_rad_s' = 0.0: must not be zero$"),
        ({"daq_channel": ""}, r"'daq_channel' = '': expected a physical channel"),
    ],
)
def test_bad_configuration_is_one_clear_error(
    fake_nidaqmx: types.ModuleType, parameters: dict[str, object], pattern: str
) -> None:
    with pytest.raises(SourceConfigError, match=pattern):
        open_source("daq", parameters)
