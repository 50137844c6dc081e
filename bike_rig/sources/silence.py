"""Which recording trials have gone silent: no samples for a while of wall time.

A silent CAN bus (a wrong id, an unplugged gyro), a DAQ channel with nothing wired, or a source
that has fallen behind leaves a trial recording with no samples. The driver asks a
:class:`SilenceWatch` on every timer tick and warns once per silence; a sample ends the
silence, so a later one is reported again.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["DEFAULT_SILENCE_S", "Silence", "SilenceWatch"]

#: Wall-clock seconds without samples after which a recording trial is reported, s.
DEFAULT_SILENCE_S = 1.0


@dataclass(frozen=True)
class Silence:
    """A recording trial that has had no samples for ``seconds`` of wall time.

    Attributes:
        trial_id: The trial.
        seconds: Wall-clock seconds since its request, its START or its last samples, s.
        any_samples: Whether it had any samples before the silence.
    """

    trial_id: str
    seconds: float
    any_samples: bool


@dataclass
class _Watched:
    since: float  # monotonic time of the request, the START or the last samples, s
    any_samples: bool = False
    reported: bool = False


class SilenceWatch:
    """The recording trials and when each last had samples (wall clock).

    Args:
        limit_s: Seconds without samples that make a silence, s (> 0).
        monotonic: The wall clock, s (tests pass a fake one).

    Raises:
        ValueError: ``limit_s`` is not > 0.
    """

    def __init__(self, limit_s: float = DEFAULT_SILENCE_S, monotonic: Callable[[], float] = time.monotonic):
        """Watch no trial yet."""
        if not limit_s > 0:
            raise ValueError(f"a silence lasts > 0 s, got {limit_s!r}")
        self.limit_s = limit_s
        self._monotonic = monotonic
        self._trials: dict[str, _Watched] = {}

    def started(self, trial_id: str) -> None:
        """Trial ``trial_id`` records from now (its request or its START; a second call changes nothing)."""
        self._trials.setdefault(trial_id, _Watched(self._monotonic()))

    def samples(self, trial_id: str) -> None:
        """Samples of ``trial_id`` arrived now: its silence, if any, is over."""
        watched = self._trials.get(trial_id)
        if watched is not None:
            watched.since = self._monotonic()
            watched.any_samples = True
            watched.reported = False

    def stopped(self, trial_id: str) -> None:
        """Trial ``trial_id`` has ended (STOP or ABORT): no longer watched."""
        self._trials.pop(trial_id, None)

    @property
    def watched(self) -> tuple[str, ...]:
        """The trials being watched."""
        return tuple(self._trials)

    def longest(self) -> float:
        """Wall seconds the most silent recording trial has had no samples (0 when none records), s."""
        now = self._monotonic()
        return max((now - w.since for w in self._trials.values()), default=0.0)

    def due(self) -> list[Silence]:
        """The trials that have gone silent since the last call (each silence once)."""
        now = self._monotonic()
        out = []
        for trial_id, watched in self._trials.items():
            silent = now - watched.since
            if not watched.reported and silent >= self.limit_s:
                watched.reported = True
                out.append(Silence(trial_id, silent, watched.any_samples))
        return out
