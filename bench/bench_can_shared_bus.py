"""The CAN source on a shared bus: polls needed to take a gyro's frames among other devices'.

A gyro's frames (4 int16 samples each) on python-can's ``virtual`` bus (which filters in
software, as ``slcan`` and ``serial`` do) with ``foreign`` frames of another device after each
one, all waiting before the first poll. Printed per case: the polls the CAN source needs to
take every gyro sample, and the wall time of one draining poll per 1,000 frames on the bus; and
for comparison the polls a bus opened with python-can's receive filter on the gyro's id needs
(python-can's non-blocking receive returns nothing at a foreign frame there: one gyro frame per
poll at best).
"""

from __future__ import annotations

import time
import uuid

import can
import numpy as np

from bike_rig.sources import SampleBlock, TrialRequest, open_source
from bike_rig.sources.can import CanSource

GYRO_FRAMES = (1_000, 4_000)
FOREIGN_PER_GYRO = (1, 3)


def _send(sender: can.BusABC, gyro_id: int, frames: int, foreign: int) -> None:
    data = np.arange(4, dtype="<i2").tobytes()
    for _ in range(frames):
        sender.send(can.Message(arbitration_id=gyro_id, data=data, is_extended_id=False))
        for k in range(foreign):
            sender.send(can.Message(arbitration_id=0x700 + k, data=bytes(8), is_extended_id=False))


def source_polls(frames: int, foreign: int) -> tuple[int, float]:
    """Polls of the CAN source to take ``frames`` gyro frames, and the seconds they took."""
    name = f"bench-{uuid.uuid4().hex[:8]}"
    source = open_source("can", can_interface="virtual", can_channel=name)
    assert isinstance(source, CanSource)
    sender = can.Bus(interface="virtual", channel=name)
    try:
        source.start_trial(TrialRequest("frame", "compound"))
        _send(sender, 0x100, frames, foreign)
        taken = polls = 0
        t0 = time.perf_counter()
        while taken < 4 * frames:
            taken += sum(e.rates.size for e in source.poll() if isinstance(e, SampleBlock))
            polls += 1
        return polls, time.perf_counter() - t0
    finally:
        sender.shutdown()
        source.close()


def filtered_polls(frames: int, foreign: int) -> int:
    """Polls of a reader draining a bus opened with python-can's filter on the gyro's id until recv returns None."""
    name = f"bench-{uuid.uuid4().hex[:8]}"
    bus = can.Bus(interface="virtual", channel=name, can_filters=[{"can_id": 0x100, "can_mask": 0x7FF}])
    sender = can.Bus(interface="virtual", channel=name)
    try:
        _send(sender, 0x100, frames, foreign)
        taken = polls = 0
        while taken < frames:
            polls += 1
            while bus.recv(timeout=0.0) is not None:
                taken += 1
        return polls
    finally:
        sender.shutdown()
        bus.shutdown()


def main() -> None:
    print(
        f"{'gyro frames':>11} {'foreign/gyro':>12} {'source polls':>12} {'ms per 1000 frames':>18} "
        f"{'filtered-bus polls':>18}"
    )
    for frames in GYRO_FRAMES:
        for foreign in FOREIGN_PER_GYRO:
            polls, seconds = source_polls(frames, foreign)
            per_k = 1e3 * seconds / (frames * (1 + foreign) / 1000)
            print(f"{frames:>11} {foreign:>12} {polls:>12} {per_k:>18.2f} {filtered_polls(frames, foreign):>18}")


if __name__ == "__main__":
    main()
