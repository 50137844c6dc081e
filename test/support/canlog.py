"""python-can log files of a gyro among another device's frames, written by python-can's own writers."""

from __future__ import annotations

from pathlib import Path

import can
import numpy as np

from bike_rig.sources.can import CanFrameLayout


def write_can_log(path: Path, layout: CanFrameLayout, frames: int, t0: float) -> tuple[np.ndarray, float]:
    """Write ``frames`` gyro frames at 250 frames/s among foreign ones with python-can's writer for the suffix.

    Returns the rates and the first gyro frame's stamp as python-can reads it back.
    """
    rates = np.round(np.cos(np.arange(frames * layout.samples_per_frame) / 11.0), 4)
    with can.Logger(path) as writer:
        for i in range(frames):
            chunk = rates[i * layout.samples_per_frame : (i + 1) * layout.samples_per_frame]
            t = t0 + i * 0.004
            writer.on_message_received(
                can.Message(
                    timestamp=t,
                    arbitration_id=layout.can_id,
                    data=layout.encode(chunk),
                    is_extended_id=False,
                    channel=0,
                )
            )
            writer.on_message_received(
                can.Message(timestamp=t + 0.001, arbitration_id=0x3F0, data=bytes(6), is_extended_id=False, channel=0)
            )
    with can.LogReader(path) as reader:
        first = next(m for m in reader if m.arbitration_id == layout.can_id)
    return rates, float(first.timestamp)
