"""Which samples of a trial the period fit uses: an explicit, recorded window policy.

Users of BicycleParameters found that their periods moved with how the series was truncated
(its ``select_good_data`` cuts from the largest sample to the last sample above 10 % of it, so
the cut depends on noise). Here the window is chosen by a stated rule, which is stored with
every result (``PeriodFit.window_policy``) next to the sample indices actually used
(``PeriodFit.window``):

* ``lead_in`` (the default, ``lead_in_s = 1.0``): the whole record except its first second,
  where the operator's release transient lives. Times count from the first sample.
* ``span``: the samples with ``start_s <= t < stop_s`` (seconds from the first sample;
  ``stop_s = None`` means to the end).
* ``envelope``: BicycleParameters' rule, from the sample of largest deviation from the median
  to the last sample whose deviation still exceeds ``fraction`` of it.

Then, unless ``whole_cycles`` is off, the fitter shortens the window at its end to a whole
number of oscillation cycles (of the fitted period). A whole number of cycles keeps slow drift
from leaking into the frequency estimate and makes the σ estimate (see ``fit``) unbiased; the
samples dropped are the last, smallest ones.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import NDArray

__all__ = ["WindowKind", "WindowPolicy", "DEFAULT_WINDOW", "first_at_or_after", "select_window", "select_window_even"]


class WindowKind(str, Enum):
    """How the window's first and last samples are chosen."""

    LEAD_IN = "lead_in"
    SPAN = "span"
    ENVELOPE = "envelope"


@dataclass(frozen=True)
class WindowPolicy:
    """A rule for the samples the fit uses; construct with the class methods.

    Attributes:
        kind: Which rule.
        lead_in_s: ``lead_in``: seconds dropped at the start [s].
        start_s: ``span``: first time kept, from the first sample [s].
        stop_s: ``span``: end of the window (exclusive) [s], or None for the end of the record.
        fraction: ``envelope``: end where the deviation falls below this fraction of its peak.
        whole_cycles: Shorten the window to a whole number of fitted cycles.
    """

    kind: WindowKind = WindowKind.LEAD_IN
    lead_in_s: float = 1.0
    start_s: float = 0.0
    stop_s: float | None = None
    fraction: float = 0.1
    whole_cycles: bool = True

    def __post_init__(self) -> None:
        """Check the policy's numbers.

        Raises:
            ValueError: A negative or non-finite lead-in or start, a stop not after the start, or an
                envelope fraction outside (0, 1).
        """
        checks = (
            (math.isfinite(self.lead_in_s) and self.lead_in_s >= 0, f"lead-in must be >= 0 s, got {self.lead_in_s}"),
            (math.isfinite(self.start_s) and self.start_s >= 0, f"start must be >= 0 s, got {self.start_s}"),
            (
                self.stop_s is None or (math.isfinite(self.stop_s) and self.stop_s > self.start_s),
                f"stop ({self.stop_s} s) must be after start ({self.start_s} s)",
            ),
            (0 < self.fraction < 1, f"envelope fraction must be in (0, 1), got {self.fraction}"),
        )
        for ok, message in checks:
            if not ok:
                raise ValueError(message)

    @classmethod
    def lead_in(cls, seconds: float = 1.0, whole_cycles: bool = True) -> WindowPolicy:
        """The whole record minus its first ``seconds``."""
        return cls(WindowKind.LEAD_IN, lead_in_s=seconds, whole_cycles=whole_cycles)

    @classmethod
    def span(cls, start_s: float, stop_s: float | None = None, whole_cycles: bool = True) -> WindowPolicy:
        """The samples with ``start_s <= t < stop_s`` (seconds from the first sample)."""
        return cls(WindowKind.SPAN, start_s=start_s, stop_s=stop_s, whole_cycles=whole_cycles)

    @classmethod
    def envelope(cls, fraction: float = 0.1, whole_cycles: bool = True) -> WindowPolicy:
        """BicycleParameters' rule: from the largest deviation to where it decays to ``fraction``."""
        return cls(WindowKind.ENVELOPE, fraction=fraction, whole_cycles=whole_cycles)

    def describe(self) -> str:
        """One line for reports, e.g. ``lead-in 1 s, whole cycles``."""
        if self.kind is WindowKind.LEAD_IN:
            text = f"lead-in {self.lead_in_s:g} s"
        elif self.kind is WindowKind.SPAN:
            stop = "end" if self.stop_s is None else f"{self.stop_s:g} s"
            text = f"span {self.start_s:g} s to {stop}"
        else:
            text = f"envelope from its peak down to {self.fraction:g} of it"
        return text + (", whole cycles" if self.whole_cycles else "")


#: The default policy: the whole record minus a 1 s lead-in, trimmed to whole cycles.
DEFAULT_WINDOW = WindowPolicy()


def select_window(t: NDArray[np.float64], y: NDArray[np.float64], policy: WindowPolicy) -> tuple[int, int]:
    """The (start, stop) positions (stop exclusive) that ``policy`` keeps.

    Args:
        t: Sample times from the first sample (t[0] = 0), increasing [s].
        y: The samples (finite).
        policy: The rule.

    Returns:
        Positions into ``t``; ``start == stop`` when nothing is left.
    """
    return _select(lambda x: int(np.searchsorted(t, x, side="left")), y, policy)


def select_window_even(step: float, y: NDArray[np.float64], policy: WindowPolicy) -> tuple[int, int]:
    """:func:`select_window` for samples at the times ``k · step`` [s]."""
    return _select(lambda x: first_at_or_after(x, step, y.size), y, policy)


def first_at_or_after(x: float, step: float, n: int) -> int:
    """The first k in [0, n] with ``k · step >= x`` (``np.searchsorted`` on ``arange(n) * step``)."""
    if not x > 0:
        return 0
    k = min(n, max(0, math.ceil(x / step)))
    while k > 0 and (k - 1) * step >= x:
        k -= 1
    while k < n and k * step < x:
        k += 1
    return k


def _select(search: Callable[[float], int], y: NDArray[np.float64], policy: WindowPolicy) -> tuple[int, int]:
    n = y.size
    if policy.kind is WindowKind.LEAD_IN:
        return search(policy.lead_in_s), n
    if policy.kind is WindowKind.SPAN:
        start = search(policy.start_s)
        stop = n if policy.stop_s is None else search(policy.stop_s)
        return start, max(start, stop)
    if n == 0:
        return 0, 0
    deviation = y - np.median(y)
    peak = int(np.argmax(np.abs(deviation)))
    above = np.flatnonzero(np.abs(deviation[peak:]) > policy.fraction * abs(deviation[peak]))
    stop = peak + int(above[-1]) + 1 if above.size else peak + 1
    return peak, stop
