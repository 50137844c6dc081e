"""The CAN source on python-can's virtual bus, and playing log files written by python-can.

Fed by a simulated CAN gyro in this process (the virtual bus does not cross processes): frame
layouts, trials on request, and the period of a simulated trial recovered within 3σ; bad
configurations give one clear error. On a shared bus (the gyro's frames among other devices')
one poll takes every gyro frame waiting; python-can's configuration names the bus when the
parameters do not, and the default virtual bus is warned of; the stamps' clock is checked;
candump, ASC, BLF, TRC and CSV logs replay bit-exact, trial after trial, paced by their
timestamps or as fast as read.
"""

from __future__ import annotations

import math
import re
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
    SourceIOError,
    SourceUnavailableError,
    TrialRequest,
    TrialRequestError,
    TrialStarted,
    TrialStopped,
    open_source,
)
from bike_rig.sources.can import CanFrameLayout, CanSource, SimulatedCanGyro, array_samples, damped_samples
from test.support.canlog import write_can_log
from test.support.small_sessions import small_session

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
    [
        ("int16", "little", 4, False),
        ("int16", "big", 4, False),
        ("int32", "big", 2, False),
        ("float32", "little", 2, False),
        ("float32", "big", 16, True),
        ("int16", "little", 32, True),
    ],
)
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
        "can",
        can_interface="virtual",
        can_channel=name,
        can_id=0x2A,
        sample_format="int16",
        byte_order="big",
        samples_per_frame=4,
        scale=1e-5,
        sample_rate_hz=RATE,
    )
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
    first = [
        e
        for e in events
        if getattr(e, "trial_id", None) == info.trial_id
        or (isinstance(e, TrialStarted) and e.info.trial_id == info.trial_id)
    ]
    n = sum(e.rates.size for e in first if isinstance(e, SampleBlock))
    assert n == stopped.sample_count > 0
    assert isinstance(events[-1], TrialStopped) and events[-1].sample_count == 100 and not events[-1].aborted


@pytest.mark.parametrize(
    ("parameters", "error", "pattern"),
    [
        (
            {"can_interface": "nope"},
            SourceConfigError,
            r"^can source: parameter 'can_interface' = 'nope': unknown python-can interface; expected one of ",
        ),
        ({"can_interface": "udp_multicast"}, SourceConfigError, r"'udp_multicast': refused: it multicasts"),
        (
            {"samples_per_frame": 5},
            SourceConfigError,
            r"^can source: parameter 'samples_per_frame' = 5: 10 bytes of int16 exceed a classic frame's 8 "
            r"\(set can_fd\)$",
        ),
        ({"samples_per_frame": 5, "can_fd": True}, SourceConfigError, r"10 bytes is not a CAN FD data length"),
        ({"can_id": 0x800}, SourceConfigError, r"'can_id' = 2048: must be an 11-bit .* id, 0..0x7FF$"),
        (
            {"sample_format": "int8"},
            SourceConfigError,
            r"'sample_format' = 'int8': expected one of int16, int32, float32$",
        ),
        ({"scale": 0.0}, SourceConfigError, r"'scale' = 0.0: must be a finite, non-zero number"),
        ({"sample_rate_hz": -1.0}, SourceConfigError, r"'sample_rate_hz' = -1.0: must be >= 0.001$"),
        (
            {"can_interface": "socketcan", "can_channel": "can_nonexistent0"},
            SourceUnavailableError,
            r"^can source: parameter 'can_interface' = 'socketcan': cannot open channel 'can_nonexistent0': ",
        ),
        (
            {"can_interface": "socketcan", "can_simulated_gyro_period_s": 1.0},
            SourceConfigError,
            r"simulated gyro runs on the 'virtual' interface only",
        ),
    ],
)
def test_bad_configuration_is_one_clear_error(
    parameters: dict[str, object], error: type[Exception], pattern: str
) -> None:
    with pytest.raises(error, match=pattern) as info:
        open_source("can", {"can_channel": channel(), **parameters}).close()
    assert "\n" not in str(info.value)


def _send_interleaved(sender: can.BusABC, layout: CanFrameLayout, n: int) -> np.ndarray:
    """Send ``n`` gyro frames among other devices' frames; returns the gyro's rates as sent.

    After each gyro frame an 11-bit neighbour's; after every tenth also the gyro's number as a
    29-bit id and an error frame.
    """
    rates = np.round(np.sin(np.arange(n * layout.samples_per_frame) / 7.0), 4)
    for i in range(n):
        chunk = rates[i * layout.samples_per_frame : (i + 1) * layout.samples_per_frame]
        sender.send(can.Message(arbitration_id=layout.can_id, data=layout.encode(chunk), is_extended_id=False))
        sender.send(can.Message(arbitration_id=0x7F, data=bytes(8), is_extended_id=False))
        if i % 10 == 0:
            sender.send(can.Message(arbitration_id=layout.can_id, data=bytes(8), is_extended_id=True))
            sender.send(can.Message(arbitration_id=layout.can_id, is_error_frame=True, is_extended_id=False))
    return rates


def test_a_shared_bus_is_drained_in_one_poll() -> None:
    # 1,000 gyro frames among 1,200 foreign ones, all waiting: one poll takes every gyro sample
    name = channel()
    source = open_source("can", can_interface="virtual", can_channel=name, samples_per_frame=4, scale=1e-4)
    assert isinstance(source, CanSource)
    sender = can.Bus(interface="virtual", channel=name)
    try:
        info = source.start_trial(TrialRequest("frame", "compound"))
        sent = _send_interleaved(sender, source.layout, 1000)
        first = source.poll()
        source.stop_trial(info.trial_id)
        rest = source.poll()
    finally:
        sender.shutdown()
        source.close()
    got = np.concatenate([e.rates for e in first if isinstance(e, SampleBlock)])
    assert got.size == 4000 and np.max(np.abs(got - sent)) <= 0.5e-4
    assert source.reads == 2200
    assert not [e for e in rest if isinstance(e, SampleBlock)]
    assert isinstance(rest[-1], TrialStopped) and rest[-1].sample_count == 4000


@pytest.fixture
def no_python_can_config(monkeypatch: pytest.MonkeyPatch) -> None:
    """python-can's configuration emptied: no can.rc, no CAN_* variables, no configuration file."""
    for var in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(can, "rc", {})
    monkeypatch.setattr(can.util, "CONFIG_FILES", [])


def _gyro_reaches(source: CanSource, name: str) -> bool:
    sender = can.Bus(interface="virtual", channel=name)
    try:
        info = source.start_trial(TrialRequest("frame", "compound"))
        sender.send(can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False))
        got = [e for e in source.poll() if isinstance(e, SampleBlock)]
        source.stop_trial(info.trial_id)
        return bool(got)
    finally:
        sender.shutdown()


@pytest.mark.usefixtures("no_python_can_config")
def test_with_nothing_named_it_listens_on_the_virtual_bus_and_says_so() -> None:
    source = open_source("can")
    assert isinstance(source, CanSource)
    try:
        assert source.describe().startswith("can: VIRTUAL bus, no hardware: virtual:bike_rig (default) id 0x100 ")
        ((warning, notice),) = source.notices()
        assert warning and notice.startswith("listening on python-can's VIRTUAL bus 'bike_rig' (nothing names a bus): ")
        assert "CAN_INTERFACE" in notice and source.notices() == []
        assert "this is python-can's VIRTUAL bus, which no hardware reaches" in source.silence_hint()
    finally:
        source.close()


@pytest.mark.usefixtures("no_python_can_config")
def test_python_cans_configuration_names_the_bus(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    name = channel()
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", name)
    source = open_source("can")
    assert isinstance(source, CanSource)
    try:
        assert f"virtual:{name} (python-can's CAN_INTERFACE) id 0x100" in source.describe()
        assert _gyro_reaches(source, name)
    finally:
        source.close()
    # its configuration file, when the environment names nothing; the parameters win over both
    monkeypatch.delenv("CAN_INTERFACE")
    monkeypatch.delenv("CAN_CHANNEL")
    rc = tmp_path / "canrc"
    rc.write_text(f"[default]\ninterface = virtual\nchannel = {name}-file\n", encoding="utf-8")
    monkeypatch.setattr(can.util, "CONFIG_FILES", [str(rc)])
    for parameters, described in [
        ({}, f"virtual:{name}-file (python-can's config file {rc})"),
        ({"can_channel": f"{name}-mine"}, f"virtual:{name}-mine (python-can's config file {rc})"),
        ({"can_interface": "virtual", "can_channel": f"{name}-named"}, f"virtual:{name}-named (can_interface)"),
    ]:
        source = open_source("can", parameters)
        assert isinstance(source, CanSource)
        try:
            assert described in source.describe(), source.describe()
            assert _gyro_reaches(source, described.split()[0].split(":")[1])
        finally:
            source.close()


@pytest.mark.usefixtures("no_python_can_config")
def test_a_configured_interface_python_can_does_not_know_is_one_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CAN_INTERFACE", "nope")
    with pytest.raises(
        SourceConfigError,
        match=r"^can source: parameter 'can_interface': not given, and python-can's CAN_INTERFACE names one "
        r"that python-can refuses: Unknown interface type \"nope\"$",
    ):
        open_source("can")
    monkeypatch.setenv("CAN_INTERFACE", "udp_multicast")
    with pytest.raises(SourceConfigError, match=r"'udp_multicast': refused: it multicasts"):
        open_source("can")


def test_stamps_follow_the_clock_checked_on_the_first_frames() -> None:
    # the virtual bus stamps in epoch time: the frame's own stamp is used
    name = channel()
    source = open_source("can", can_interface="virtual", can_channel=name)
    assert isinstance(source, CanSource)
    sender = can.Bus(interface="virtual", channel=name)
    listener = can.Bus(interface="virtual", channel=name)
    try:
        source.start_trial(TrialRequest("frame", "compound"))
        sender.send(can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False))
        started = next(e for e in source.poll() if isinstance(e, TrialStarted))
        seen = listener.recv(timeout=5.0)
        assert seen is not None and source.clock.source == "interface"
        assert started.stamp_ns == round((seen.timestamp - 3 / 1000.0) * 1e9)
        assert "stamps: the interface's timestamps (epoch time, checked" in source.describe()
        # said in the log, and a warning when the clock falls back
        assert (False, f"can source ({source.label}): {source.clock.notice}") in source.notices()
    finally:
        sender.shutdown()
        listener.shutdown()
        source.close()
    # an interface that stamps on a monotonic clock: the receive clock, said
    name = channel()
    source = open_source("can", can_interface="virtual", can_channel=name)
    assert isinstance(source, CanSource)
    sender = can.Bus(interface="virtual", channel=name, preserve_timestamps=True)
    try:
        source.start_trial(TrialRequest("frame", "compound"))
        for _ in range(5):
            sender.send(
                can.Message(timestamp=time.monotonic(), arbitration_id=0x100, data=bytes(8), is_extended_id=False)
            )
        before = time.time_ns()
        started = next(e for e in source.poll() if isinstance(e, TrialStarted))
        after = time.time_ns()
        assert source.clock.source == "receive"
        assert before - round(19 / 1000 * 1e9) <= started.stamp_ns <= after  # 20 samples, the last just read
        assert "stamps: the receive clock (the interface's timestamps are not epoch time" in source.describe()
        assert (True, f"can source ({source.label}): {source.clock.notice}") in source.notices()
    finally:
        sender.shutdown()
        source.close()


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc", ".csv"])
def test_a_log_file_replays_bit_exact_trial_after_trial(tmp_path: Path, suffix: str) -> None:
    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    path = tmp_path / f"gyro{suffix}"
    rates, first_stamp = write_can_log(path, layout, 300, t0=1_790_000_000.0)
    source = open_source("can", can_log_file=str(path), can_log_speed=0.0)
    assert isinstance(source, CanSource)
    try:
        assert not source.finished
        assert source.poll() == []  # as fast as read: nothing plays while no trial records
        one = source.start_trial(TrialRequest("frame", "compound", duration_s=0.5))
        events = collect(source)
        two = source.start_trial(TrialRequest("frame", "compound", duration_s=10.0))  # more than is left
        events += collect(source)
        notices = source.notices()
        finished = source.finished
    finally:
        source.close()
    got = {
        t: np.concatenate([e.rates for e in events if isinstance(e, SampleBlock) and e.trial_id == t])
        for t in (one.trial_id, two.trial_id)
    }
    codes = np.rint(rates / 1e-4)
    assert np.array_equal(np.rint(got[one.trial_id] / 1e-4), codes[:500])  # the first 125 frames, bit-exact
    assert np.array_equal(np.rint(got[two.trial_id] / 1e-4), codes[500:])  # the next: the log's rest
    stops = [e for e in events if isinstance(e, TrialStopped)]
    assert [(s.sample_count, s.aborted) for s in stops] == [(500, False), (700, True)]
    assert (
        True,
        f"can source: the log file ended during trial {two.trial_id} after 700 of 10000 samples: aborted",
    ) in notices
    assert finished
    started = next(e for e in events if isinstance(e, TrialStarted))
    if first_stamp > 1e9:  # the format keeps epoch stamps: the log's own
        assert source.clock.source == "interface" and started.stamp_ns == round((first_stamp - 3 / 1000) * 1e9)
    else:  # .asc: stamps relative to its start
        assert source.clock.source == "receive" and "not epoch time" in source.describe()


def test_a_log_file_is_paced_by_its_timestamps(tmp_path: Path) -> None:
    from bike_rig.sources.can_bus import LogBus

    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    path = tmp_path / "gyro.log"
    write_can_log(path, layout, 100, t0=1_790_000_000.0)  # gyro frames every 4 ms, a foreign one 1 ms after each
    now = [100.0]
    bus = LogBus(path, speed=2.0, clock=lambda: now[0])

    def due() -> int:
        n = 0
        while bus.recv(timeout=0.0) is not None:
            n += 1
        return n

    try:
        assert due() == 1  # the first frame at once
        now[0] += 0.002  # 4 ms of the log at twice real time: up to the second gyro frame
        assert due() == 2
        now[0] += 1.0  # the rest (0.4 s of log)
        assert due() == 197 and bus.exhausted and bus.frames == 200
    finally:
        bus.shutdown()


@pytest.mark.parametrize(
    ("name", "pattern"),
    [
        ("missing.log", r"'can_log_file' = '.*missing\.log': no such file$"),
        ("gyro.xyz", r"'can_log_file' = '.*gyro\.xyz': not a python-can log file: "),
    ],
)
def test_a_bad_log_file_is_one_clear_error(tmp_path: Path, name: str, pattern: str) -> None:
    if name.endswith(".xyz"):
        (tmp_path / name).write_text("1 2 3\n", encoding="utf-8")
    with pytest.raises(SourceConfigError, match=pattern) as info:
        open_source("can", can_log_file=str(tmp_path / name))
    assert "\n" not in str(info.value)


def test_a_trial_that_takes_the_logs_last_frame_leaves_the_source_finished(tmp_path: Path) -> None:
    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    path = tmp_path / "gyro.blf"
    write_can_log(path, layout, 100, t0=1_790_000_000.0)
    source = open_source("can", can_log_file=str(path), can_log_speed=0.0)
    assert isinstance(source, CanSource)
    try:
        source.start_trial(TrialRequest("frame", "compound", duration_s=0.4))  # 400 samples: the whole log
        events = collect(source)
        assert source.finished
    finally:
        source.close()
    stop = events[-1]
    assert isinstance(stop, TrialStopped) and (stop.sample_count, stop.aborted) == (400, False)


def test_a_log_that_ends_an_until_stopped_trial_stops_it(tmp_path: Path) -> None:
    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    path = tmp_path / "gyro.log"
    write_can_log(path, layout, 100, t0=1_790_000_000.0)
    source = open_source("can", can_log_file=str(path), can_log_speed=0.0)
    assert isinstance(source, CanSource)
    try:
        source.start_trial(TrialRequest("frame", "compound"))
        events = collect(source)
        assert source.finished and source.notices() == [(False, f"can source ({source.label}): {source.clock.notice}")]
    finally:
        source.close()
    stop = events[-1]
    assert isinstance(stop, TrialStopped) and (stop.sample_count, stop.aborted) == (400, False)


def test_a_damaged_log_record_is_one_read_error(tmp_path: Path) -> None:
    layout = CanFrameLayout(0x100, samples_per_frame=4, scale=1e-4)
    path = tmp_path / "gyro.log"
    write_can_log(path, layout, 10, t0=1_790_000_000.0)
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join([*lines[:6], "(1790000000.030000) can0 100#ZZZZ R", *lines[6:]]) + "\n", encoding="utf-8")
    source = open_source("can", can_log_file=str(path), can_log_speed=0.0)
    assert isinstance(source, CanSource)
    try:
        source.start_trial(TrialRequest("frame", "compound"))
        with pytest.raises(SourceIOError, match=rf"^can source: {re.escape(str(path))}: frame 7: invalid literal"):
            source.poll()
    finally:
        source.close()
