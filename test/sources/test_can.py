"""The CAN source on python-can's virtual bus.

Fed by a simulated CAN gyro in this process (the virtual bus does not cross processes): frame
layouts, trials on request, and the period of a simulated trial recovered within 3σ; bad
configurations give one clear error.
"""

from __future__ import annotations

import math
import time
import uuid
from pathlib import Path

import can
import numpy as np
import pytest

from bike_rig.core.period import fit_period
from bike_rig.sources import (
    SampleBlock,
    SourceConfigError,
    SourceEvent,
    SourceUnavailableError,
    TrialRequest,
    TrialRequestError,
    TrialStarted,
    TrialStopped,
    open_source,
)
from bike_rig.sources.can import CanFrameLayout, CanSource, SimulatedCanGyro, array_samples, damped_samples, open_bus
from test.sources.support import small_session

RATE = 1000.0


def channel() -> str:
    """A virtual bus of this test only."""
    return f"test-{uuid.uuid4().hex[:8]}"


def collect(source: CanSource, until_stopped: bool = True, timeout: float = 30.0) -> list[SourceEvent]:
    """Poll until a trial has stopped (or, with ``until_stopped`` False, for ``timeout``)."""
    events: list[SourceEvent] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        events += source.poll()
        if until_stopped and events and isinstance(events[-1], TrialStopped):
            return events
        time.sleep(0.002)
    if not until_stopped:
        return events
    raise AssertionError(f"no STOP within {timeout} s: {len(events)} events")


@pytest.mark.parametrize(
    ("fmt", "order", "spf", "fd"),
    [("int16", "little", 4, False), ("int16", "big", 4, False), ("int32", "big", 2, False),
     ("float32", "little", 2, False), ("float32", "big", 16, True), ("int16", "little", 32, True)],
)  # fmt: skip
def test_frame_layout_round_trip(fmt: str, order: str, spf: int, fd: bool) -> None:
    layout = CanFrameLayout(0x123, sample_format=fmt, byte_order=order, samples_per_frame=spf, scale=1e-4, fd=fd)
    assert layout.problems() == []
    rates = np.linspace(-0.5, 0.5, spf)
    data = layout.encode(rates)
    assert len(data) == layout.frame_bytes
    decoded = layout.decode(data)
    tolerance = 1e-7 if fmt == "float32" else 0.5e-4
    assert np.max(np.abs(decoded - rates)) <= tolerance
    # the byte order is the one asked for: int16 0x0102 is 02 01 (little) or 01 02 (big)
    one = CanFrameLayout(1, sample_format="int16", byte_order=order, samples_per_frame=1, scale=1.0)
    assert one.encode(np.array([258.0])) == (b"\x02\x01" if order == "little" else b"\x01\x02")


def test_integer_samples_saturate() -> None:
    layout = CanFrameLayout(1, samples_per_frame=2, scale=1e-4)
    assert np.array_equal(layout.decode(layout.encode(np.array([10.0, -10.0]))), [32767e-4, -32768e-4])


def test_simulated_trial_through_the_virtual_bus_gives_its_period_within_3_sigma(tmp_path: Path) -> None:
    session, _ = small_session(tmp_path)
    trial = session.trials_of("TtH1")[0]  # fork, torsional, orientation 1: about 0.6 s
    name = channel()
    source = open_source(
        "can", can_interface="virtual", can_channel=name, can_id=0x2A, sample_format="int16",
        byte_order="big", samples_per_frame=4, scale=1e-5, sample_rate_hz=RATE,
    )  # fmt: skip
    assert isinstance(source, CanSource)
    gyro = SimulatedCanGyro(source.layout, name, array_samples(trial.rate), RATE, time_scale=math.inf)
    try:
        info = source.start_trial(TrialRequest("fork", "torsional", 1, duration_s=trial.rate.size / RATE))
        assert (info.trial_id, info.measurement_key, info.orientation) == ("fork_torsional_o1_t1", "TtH1", 1)
        gyro.start()
        assert gyro.wait(30.0) and gyro.error is None
        events = collect(source)
    finally:
        gyro.stop()
        source.close()
    assert isinstance(events[0], TrialStarted) and events[0].info == info
    blocks = [e for e in events if isinstance(e, SampleBlock)]
    assert [b.first_index for b in blocks] == list(np.cumsum([0] + [b.rates.size for b in blocks[:-1]]))
    rates = np.concatenate([b.rates for b in blocks])
    stop = events[-1]
    assert isinstance(stop, TrialStopped) and stop.sample_count == rates.size == trial.rate.size
    assert np.max(np.abs(rates - trial.rate)) <= 0.5e-5 + 1e-12  # int16 counts of 1e-5 rad/s
    fit = fit_period(rates, sample_rate_hz=RATE)
    truth = trial.modes[0].damped_period
    assert fit.valid
    assert abs(fit.period - truth) < 3 * fit.period_sigma, (fit.period, truth, fit.period_sigma)


def test_trials_on_request_start_and_stop() -> None:
    name = channel()
    source = open_source("can", can_interface="virtual", can_channel=name, samples_per_frame=4, scale=1e-4)
    assert isinstance(source, CanSource)
    gyro = SimulatedCanGyro(source.layout, name, damped_samples(1.0, RATE), RATE, time_scale=20.0).start()
    noise = can.Bus(interface="virtual", channel=name)
    try:
        with pytest.raises(TrialRequestError, match="no trial is running"):
            source.stop_trial()
        with pytest.raises(TrialRequestError, match="unknown part"):
            source.start_trial(TrialRequest("saddle", "compound"))
        with pytest.raises(TrialRequestError, match="needs its orientation"):
            source.start_trial(TrialRequest("frame", "torsional"))
        info = source.start_trial(TrialRequest("frame", "compound"))  # until stopped
        with pytest.raises(TrialRequestError, match="frame_compound_t1 is running"):
            source.start_trial(TrialRequest("rear_wheel", "compound"))
        # frames of another id are ignored, frames of the gyro's id with a wrong length dropped
        noise.send(can.Message(arbitration_id=0x7F, data=bytes(8), is_extended_id=False))
        noise.send(can.Message(arbitration_id=0x100, data=bytes(3), is_extended_id=False))
        events = collect(source, until_stopped=False, timeout=0.3)
        with pytest.raises(TrialRequestError, match="'other' is not running"):
            source.stop_trial("other")
        stopped = source.stop_trial(info.trial_id, abort=True)
        events += source.poll()
        again = source.start_trial(TrialRequest("frame", "compound", duration_s=0.1))
        events += collect(source)
    finally:
        gyro.stop()
        noise.shutdown()
        source.close()
    assert stopped.aborted and stopped.trial_id == "frame_compound_t1"
    assert again.trial_id == "frame_compound_t2" and again.repeat == 2
    assert source.malformed_frames == 1
    first = [e for e in events if getattr(e, "trial_id", None) == info.trial_id or
             (isinstance(e, TrialStarted) and e.info.trial_id == info.trial_id)]  # fmt: skip
    n = sum(e.rates.size for e in first if isinstance(e, SampleBlock))
    assert n == stopped.sample_count > 0
    assert isinstance(events[-1], TrialStopped) and events[-1].sample_count == 100 and not events[-1].aborted


@pytest.mark.parametrize(
    ("parameters", "error", "pattern"),
    [
        ({"can_interface": "nope"}, SourceConfigError,
         r"^can source: parameter 'can_interface' = 'nope': unknown python-can interface; expected one of "),
        ({"can_interface": "udp_multicast"}, SourceConfigError, r"'udp_multicast': refused: it multicasts"),
        ({"samples_per_frame": 5}, SourceConfigError,
         r"^can source: parameter 'samples_per_frame' = 5: 10 bytes of int16 exceed a classic frame's 8 "
         r"\(set can_fd\)$"),
        ({"samples_per_frame": 5, "can_fd": True}, SourceConfigError, r"10 bytes is not a CAN FD data length"),
        ({"can_id": 0x800}, SourceConfigError, r"'can_id' = 2048: must be an 11-bit .* id, 0..0x7FF$"),
        ({"sample_format": "int8"}, SourceConfigError,
         r"'sample_format' = 'int8': expected one of int16, int32, float32$"),
        ({"scale": 0.0}, SourceConfigError, r"'scale' = 0.0: must be a finite, non-zero number"),
        ({"sample_rate_hz": -1.0}, SourceConfigError, r"'sample_rate_hz' = -1.0: must be >= 0.001$"),
        ({"can_interface": "socketcan", "can_channel": "can_nonexistent0"}, SourceUnavailableError,
         r"^can source: parameter 'can_interface' = 'socketcan': cannot open channel 'can_nonexistent0': "),
        ({"can_interface": "socketcan", "can_simulated_gyro_period_s": 1.0}, SourceConfigError,
         r"simulated gyro runs on the 'virtual' interface only"),
    ],
)  # fmt: skip
def test_bad_configuration_is_one_clear_error(
    parameters: dict[str, object], error: type[Exception], pattern: str
) -> None:
    with pytest.raises(error, match=pattern) as info:
        open_source("can", {"can_channel": channel(), **parameters}).close()
    assert "\n" not in str(info.value)


def test_open_bus_filters_on_the_gyro_id() -> None:
    name = channel()
    layout = CanFrameLayout(0x1ABCDEF, extended_id=True, samples_per_frame=2)
    bus = open_bus("virtual", name, layout)
    sender = can.Bus(interface="virtual", channel=name)
    try:
        sender.send(can.Message(arbitration_id=0xDEF, data=bytes(4), is_extended_id=False))
        sender.send(can.Message(arbitration_id=0x1ABCDEF, data=bytes(4), is_extended_id=True))
        got = bus.recv(timeout=1.0)
        assert got is not None and got.arbitration_id == 0x1ABCDEF
        assert bus.recv(timeout=0.0) is None
    finally:
        sender.shutdown()
        bus.shutdown()
