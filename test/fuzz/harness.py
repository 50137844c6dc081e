"""Run a file reader on one input with a time limit and a peak-memory measure, and classify the outcome.

An outcome is one of:

* ``ok``: the reader returned (``flagged`` when it left a remark for the user);
* ``clean``: it raised a :class:`~bike_rig.core.errors.BikeRigError` whose message is one line
  (what the CLI prints as ``bike-rig CMD: error: ...``, exit status 2);
* ``crash``: any other exception, a message of several lines, or a warning on the way (it
  would print before the error line) other than a one-line
  :class:`~bike_rig.core.reading_ranges.UnitMistakeWarning` (a value a wrong unit explains:
  a remark, so an ``ok`` input with one is ``flagged``);
* ``hang``: it ran past the time limit of CPU time (stopped by ``SIGPROF``, so only in the main
  thread). CPU time, not wall time: a busy machine slows a call without making it a hang. The
  inputs are regular files, so a reader cannot block without spending CPU time.

Memory is tracemalloc's peak over the call [bytes] (numpy's buffers included) when traced;
the process's peak resident set size (children included) is always kept, which bounds every
call's at no cost.
"""

from __future__ import annotations

import resource
import signal
import time
import tracemalloc
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType

from bike_rig.core.errors import BikeRigError
from bike_rig.core.reading_ranges import UnitMistakeWarning

__all__ = ["Outcome", "Tally", "run_reader"]

KINDS = ("ok", "clean", "crash", "hang")


class _Hang(BaseException):
    """Raised by the alarm inside a reader that ran past its limit (a BaseException, so no reader catches it)."""


@dataclass(frozen=True)
class Outcome:
    """What one reader made of one input.

    Attributes:
        kind: ``ok``, ``clean``, ``crash`` or ``hang``.
        seconds: Wall time of the call [s].
        peak_bytes: tracemalloc's peak during the call [bytes], 0 when not measured.
        peak_rss_bytes: The process's (and its children's) peak resident set size after the call [bytes].
        message: The error (``Type: message``) or the reason of a crash; "" when ok.
        flagged: The reader returned with a remark for the user.
    """

    kind: str
    seconds: float
    peak_bytes: int
    message: str = ""
    flagged: bool = False
    peak_rss_bytes: int = 0


def _remarks(result: object) -> bool:
    return bool(getattr(result, "remarks", ()))


def _classify(call: Callable[[], object]) -> tuple[str, str, bool]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = call()
        except BikeRigError as exc:
            text = str(exc)
            if "\n" in text:
                return "crash", f"{type(exc).__name__} on several lines: {text!r}", False
            kind, message, flagged = "clean", f"{type(exc).__name__}: {text}", False
        except (_Hang, KeyboardInterrupt):
            raise
        except BaseException as exc:
            return "crash", f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}", False
        else:
            kind, message, flagged = "ok", "", _remarks(result)
    units = [w for w in caught if issubclass(w.category, UnitMistakeWarning)]  # a remark for the user, one line
    others = [w for w in caught if w not in units]
    if others:
        w = others[0]
        return "crash", f"{w.category.__name__} printed: {w.message}", False
    if any("\n" in str(w.message) for w in units):
        return "crash", f"a unit warning on several lines: {units[0].message!s:.300}", False
    return kind, message, flagged or (kind == "ok" and bool(units))


def run_reader(
    reader: Callable[[Path], object], path: Path, time_limit_s: float = 5.0, measure_memory: bool = True
) -> Outcome:
    """Run ``reader(path)`` once and classify it (see the module).

    Args:
        reader: The file reader under test.
        path: The input file.
        time_limit_s: CPU time of the process (user and system) after which the call is a hang [s].
        measure_memory: Trace allocations for the peak (slows the call about twofold).
    """

    def alarm(_signum: int, _frame: FrameType | None) -> None:
        raise _Hang

    previous = signal.signal(signal.SIGPROF, alarm)
    if measure_memory:
        tracemalloc.start()
    start = time.perf_counter()
    signal.setitimer(signal.ITIMER_PROF, time_limit_s)
    try:
        kind, message, flagged = _classify(lambda: reader(path))
    except _Hang:
        kind, message, flagged = "hang", f"still running after {time_limit_s:g} s of CPU time", False
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, previous)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1] if measure_memory else 0
        if measure_memory:
            tracemalloc.stop()
    return Outcome(kind, seconds, peak, message, flagged, peak_rss())


def peak_rss() -> int:
    """The largest resident set size of this process or of any of its finished children so far [bytes]."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) * 1024  # Linux reports KiB


@dataclass
class Tally:
    """The counts of a campaign on one reader, and the worst input of each kind.

    Attributes:
        reader: The reader's name.
        counts: Inputs per outcome kind.
        flags: Inputs read with a remark.
        worst_seconds: The longest call [s].
        peak_bytes: The largest traced peak memory of a call [bytes] (0 untraced).
        peak_rss_bytes: The process's peak resident set size by the end [bytes].
        failures: (input label, outcome) of every crash and hang.
    """

    reader: str
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(KINDS, 0))
    flags: int = 0
    worst_seconds: float = 0.0
    peak_bytes: int = 0
    peak_rss_bytes: int = 0
    failures: list[tuple[str, Outcome]] = field(default_factory=list)

    @property
    def inputs(self) -> int:
        """Inputs tried."""
        return sum(self.counts.values())

    def add(self, label: str, outcome: Outcome) -> None:
        """Count one outcome (``label`` names the input, to reproduce a failure)."""
        self.counts[outcome.kind] += 1
        self.flags += outcome.flagged
        self.worst_seconds = max(self.worst_seconds, outcome.seconds)
        self.peak_bytes = max(self.peak_bytes, outcome.peak_bytes)
        self.peak_rss_bytes = max(self.peak_rss_bytes, outcome.peak_rss_bytes)
        if outcome.kind in ("crash", "hang"):
            self.failures.append((label, outcome))

    def line(self) -> str:
        """One row of the campaign's table."""
        c = self.counts
        traced = f"{self.peak_bytes / 1e6:.1f}" if self.peak_bytes else "-"
        return (
            f"{self.reader:<14} {self.inputs:>7} {c['clean']:>7} {c['ok']:>6} {self.flags:>6} {c['crash']:>7} "
            f"{c['hang']:>6} {self.worst_seconds * 1000:>9.0f} {traced:>8} "
            f"{self.peak_rss_bytes / 1e6:>7.0f}"
        )

    HEADER = (
        f"{'reader':<14} {'inputs':>7} {'clean':>7} {'ok':>6} {'flags':>6} {'crashes':>7} {'hangs':>6} "
        f"{'worst ms':>9} {'peak MB':>8} {'RSS MB':>7}"
    )
