"""The driver's memory of the batches it sent, so a subscriber that lost some can ask again.

DDS delivers a reliable writer's samples in order, but a reader can still lose them: one that
falls more than its history depth behind, or a process stopped while the writer's history
moved on. The driver keeps every batch it published (:class:`SentBatches`, bounded by a sample
budget, oldest trials forgotten first) and answers a request for a trial's range of samples
with the batches that overlap it (the ``ResendSamples`` service). An index the driver never had
(a gap at the source) is in none of them, so the asker can tell a lost batch from a real gap.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

from .acquire import SampleBatch

__all__ = [
    "DEFAULT_HISTORY_SAMPLES",
    "MAX_RESEND_SAMPLES",
    "Resent",
    "SentBatches",
    "batch_samples",
    "history_depth",
]

#: Samples the driver keeps for resending: 42 min of 1 kHz trials (~20 MB of rates).
DEFAULT_HISTORY_SAMPLES = 2_500_000
#: Most samples in one answer (the asker asks again for the rest), ~1.6 MB of rates.
MAX_RESEND_SAMPLES = 200_000
#: Largest batch the driver sends when it scales batches with the time scale (the fitter's
#: default ``max_batch_samples``).
MAX_SCALED_BATCH = 10_000


def batch_samples(samples_per_batch: int, time_scale: float) -> int:
    """Samples per batch at ``time_scale`` rig seconds per wall second.

    A faster-than-real-time source sends proportionally larger batches, so the messages per
    wall second stay those of real time: the subscribers' cost is per message, and a graph
    streaming thousands of small messages a second falls behind on a busy machine.

    Args:
        samples_per_batch: Samples per batch at real time.
        time_scale: Rig seconds per wall second (1 for hardware).

    Returns:
        ``samples_per_batch × ceil(time_scale)``, at most :data:`MAX_SCALED_BATCH` (never
        below ``samples_per_batch``).
    """
    scale = math.ceil(time_scale) if time_scale > 1 else 1
    return max(samples_per_batch, min(samples_per_batch * scale, MAX_SCALED_BATCH))


def history_depth(history_samples: int, batch: int) -> int:
    """The gyro topic's history depth, batches, that holds ``history_samples`` samples of ``batch``-sample batches.

    So larger batches (a faster source) hold no more samples than real-time ones: at 50 samples a
    batch, the default 2.5 million samples are the topic's 50,000 batches.
    """
    return max(1, -(-history_samples // batch))


@dataclass(frozen=True)
class Resent:
    """An answer to a resend request.

    Attributes:
        held: The driver holds this trial (False: never had it, or forgot it).
        complete: Every batch it has of the range is in ``batches`` (False: cut at
            :data:`MAX_RESEND_SAMPLES`).
        batches: The batches overlapping the range, oldest first.
        message: One line for the asker's log.
    """

    held: bool
    complete: bool
    batches: tuple[SampleBatch, ...]
    message: str


class SentBatches:
    """Every batch published, per trial, within a sample budget (see the module docstring).

    Args:
        max_samples: Samples kept; beyond it the oldest trials are forgotten whole.
    """

    def __init__(self, max_samples: int = DEFAULT_HISTORY_SAMPLES) -> None:
        """Start empty."""
        self.max_samples = max_samples
        self._trials: OrderedDict[str, list[SampleBatch]] = OrderedDict()
        self.samples = 0
        #: Trials forgotten to stay within the budget.
        self.forgotten = 0

    def add(self, batch: SampleBatch) -> None:
        """Remember a published batch (its trial becomes the newest)."""
        batches = self._trials.get(batch.trial_id)
        if batches is None:
            batches = self._trials[batch.trial_id] = []
        batches.append(batch)
        self.samples += len(batch.rates)
        while self.samples > self.max_samples and len(self._trials) > 1:
            _, old = self._trials.popitem(last=False)
            self.samples -= sum(len(b.rates) for b in old)
            self.forgotten += 1

    def resend(self, trial_id: str, first_index: int, count: int, limit: int = MAX_RESEND_SAMPLES) -> Resent:
        """The batches of ``trial_id`` overlapping ``[first_index, first_index + count)``.

        Args:
            trial_id: The trial.
            first_index: First sample index wanted.
            count: Samples wanted (0: to the trial's end).
            limit: Most samples in the answer (at least one batch is always given).
        """
        batches = self._trials.get(trial_id)
        if batches is None:
            return Resent(False, True, (), f"trial {trial_id!r} is not held (never sent, or forgotten)")
        end = first_index + count if count > 0 else None
        out: list[SampleBatch] = []
        taken = 0
        for b in batches:
            a, z = b.first_index, b.first_index + len(b.rates)
            if z <= first_index or (end is not None and a >= end):
                continue
            if out and taken + len(b.rates) > limit:
                return Resent(True, False, tuple(out), f"{taken} samples of trial {trial_id} (more to ask for)")
            out.append(b)
            taken += len(b.rates)
        return Resent(True, True, tuple(out), f"{taken} samples of trial {trial_id}")
