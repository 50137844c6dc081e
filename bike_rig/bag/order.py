"""The order in which the live graph published a topic's messages, read from a bag.

Log time (the recorder's wall clock) and the messages' own stamps step back with the system
clock, and metadata.yaml's file order proves nothing, so the key is ``(run, sequence)``: the DDS
publication sequence number bike_rig's recorder stores in each MCAP record's ``sequence``
(counting from 1 per publisher), a new run whenever a sequence is not above its run's first (a
restarted node), runs and ties in the order of storage (split index, then place in the file).
Messages without a sequence (0) keep the order of storage. Valid for a topic with one publisher
at a time (the parameter, model and fitter topics).
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
        The indices, first published first, by ``(run, sequence)`` as the module says.
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
