"""The order in which the live graph published a topic's messages, read from a bag.

Which parameter set (or model, or static readings) the live graph published last cannot be
told by the log time, which is the recorder's wall clock: it steps back with the system clock
(an NTP correction, a manual reset), and so does every other stamp the messages carry (the
``BenchmarkParameters`` header stamp is the parameter node's clock, the MCAP publish time the
publisher's). Nor by the order metadata.yaml lists the storage files in. The key used instead:

1. **The publication sequence number.** bike_rig's recorder stores each message's DDS
   publication sequence number (rclpy's ``publication_sequence_number``) in the MCAP record's
   ``sequence``: its publisher counts its messages from 1, whatever the clocks do.
2. **A publisher started again** (a node restarted by the graph watch) counts from 1 again. A
   message whose sequence is not above the first of the run before it begins a new run, and
   runs follow each other in the recorder's order of storage: the storage files by the split
   index in their names (the recorder numbers them as it writes them), then each record's
   place in its file (the recorder writes in the order it takes the messages).
3. Messages **without a sequence** (0: a simulated bag, another recorder's) are taken in that
   order of storage.

The order is ``(run, sequence)``, ties kept in the order of storage. It holds for a topic with
one publisher at a time (the parameter, model and fitter nodes' topics).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import PurePath

__all__ = ["publication_order", "split_order"]


def split_order(path: PurePath) -> tuple[str, int, str]:
    """Sort key of a storage file: a split bag's ``NAME_2.mcap`` before ``NAME_10.mcap``.

    (The recorder and rosbag2 number a bag's files in the order they write them.)
    """
    stem, _, index = path.stem.rpartition("_")
    return (stem, int(index), "") if index.isdigit() else (path.stem, -1, path.name)


def publication_order(sequence: Sequence[int], stream: Sequence[int]) -> list[int]:
    """The indices of one topic's messages in the order they were published.

    Args:
        sequence: Each message's publication sequence number (0: not recorded).
        stream: Each message's rank in the recorder's order of storage.

    Returns:
        The indices, first published first (see the module docstring).
    """
    stored = sorted(range(len(stream)), key=lambda i: stream[i])
    if any(sequence[i] <= 0 for i in stored):
        return stored
    keys: dict[int, tuple[int, int]] = {}
    run, first = 0, None
    for i in stored:
        if first is not None and sequence[i] <= first:
            run, first = run + 1, sequence[i]  # the publisher counts from 1 again: started anew
        elif first is None:
            first = sequence[i]
        keys[i] = (run, sequence[i])
    return sorted(stored, key=lambda i: keys[i])
