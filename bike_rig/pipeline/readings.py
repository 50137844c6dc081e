"""Static readings entered during a session: the entry record, its checks, and applying entries.

Each reading the operator enters (a correction is a newer entry of the same key) is a
:class:`ReadingEntry` (the ``bike_rig_msgs/ReadingEntry`` record). :func:`apply_entries` puts
them on top of the measurement file's readings: the newest entry of a key wins (by stamp, then
arrival), every entry is kept. Keys are the static flat keys of ``docs/formats.md`` (periods
come from trials); SI, degrees only in ``gamma`` and ``alpha*``, σ in the key's unit.
:func:`canonical_order` orders merged readings as a measurement file is read, so parameters
from entered readings are bit-identical to those from a file holding the same readings.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from ..core.errors import MeasurementError
from ..core.measurements import SURFACE_PLATE_KEYS, Measurements, Origin, Reading, check_reading, is_period_key
from .errors import PipelineError

__all__ = [
    "REFINED_STATIC_KEYS",
    "STATIC_KEYS",
    "ImpossibleReadingError",
    "NegativeSigmaError",
    "NonFiniteReadingError",
    "ReadingEntry",
    "ReadingEntryError",
    "UnknownReadingKeyError",
    "apply_entries",
    "canonical_order",
    "check_entry",
    "is_static_key",
]

#: The static keys that are not per hanging orientation, in the order of a measurement file.
STATIC_KEYS: tuple[str, ...] = (
    "g",
    "w",
    "gamma",
    "f",
    "mP",
    "lP",
    "dP",
    "mR",
    "nR",
    "dR",
    "lR",
    "mF",
    "nF",
    "dF",
    "lF",
    "mB",
    "mH",
)
#: The refined method's static keys (surface plate, handlebar reference, split fork masses);
#: ``mD``, the front wheel weighed with a flywheel in it, is one too.
REFINED_STATIC_KEYS: tuple[str, ...] = SURFACE_PLATE_KEYS + ("h6", "h7", "d5", "d6", "l", "mS", "mG")
#: Every static key in the order of a measurement file (as :mod:`bike_rig.core.io_yaml` reads one).
_ORDER: tuple[str, ...] = STATIC_KEYS[:4] + REFINED_STATIC_KEYS[:-2] + ("mD",) + STATIC_KEYS[4:] + ("mS", "mG")
_ORIENTATION_KEY = re.compile(r"^(alpha|a)([BHSG])([1-9]\d*)$")
#: Each part's hanging orientations follow its mass in a measurement file.
_PART_RANK = {part: _ORDER.index(f"m{part}") for part in "BHSG"}


@dataclass(frozen=True)
class ReadingEntry:
    """One static reading as the operator entered it.

    Attributes:
        key: Flat BicycleParameters key, e.g. ``"mR"``, ``"gamma"``, ``"alphaB1"``.
        value: The value in the key's unit (SI; degrees only for ``gamma`` and ``alpha*``).
        sigma: Its standard uncertainty, same unit (0 for an exact count).
        stamp_ns: Wall time of the entry, ns since the epoch (orders the entries of a key).
        note: Free text from the operator, e.g. ``"correction"``.
    """

    key: str
    value: float
    sigma: float
    stamp_ns: int = 0
    note: str = ""

    def reading(self, origin: str = "reading entry") -> Reading:
        """The entry as a :class:`Reading` whose origin is ``origin`` and the key."""
        return Reading(float(self.value), float(self.sigma), Origin(origin, self.key))

    def describe(self) -> str:
        """``key = value ± sigma`` as entered, for messages."""
        return f"{self.key} = {self.value:g} ± {self.sigma:g}"


class ReadingEntryError(PipelineError):
    """An entered reading that cannot be used; the message names the entry and the reason.

    Args:
        entry: The entry.
        reason: Why it cannot be used.
    """

    def __init__(self, entry: ReadingEntry, reason: str):
        """Keep the entry and the reason; the message is ``reading entry <key = v ± s>: <reason>``."""
        self.entry = entry
        self.reason = reason
        super().__init__(f"reading entry {entry.describe()}: {reason}")


class UnknownReadingKeyError(ReadingEntryError):
    """The key is not a static reading (a typo, or a pendulum period, which trials provide)."""


class NonFiniteReadingError(ReadingEntryError):
    """The value or σ is NaN or infinite."""


class NegativeSigmaError(ReadingEntryError):
    """σ is negative."""


class ImpossibleReadingError(ReadingEntryError):
    """The value is physically impossible for its key (e.g. a negative mass, a head-tube angle over 90°)."""


def is_static_key(key: str) -> bool:
    """Whether ``key`` names a static reading an entry may give (see the module docstring)."""
    return key in _ORDER or _ORIENTATION_KEY.match(key) is not None


def canonical_order(key: str) -> tuple[int, int, int]:
    """Sort key of a static reading: the order of a ``bike_rig-measurements/1`` file.

    Gravity, geometry, the calibration rod, the rear and front wheels, then the frame's mass
    and its orientations (``alphaB1, aB1, alphaB2, ...``) and the same for the fork. Keys that
    are not static readings sort last.
    """
    if key in _ORDER:
        return (_ORDER.index(key), 0, 0)
    m = _ORIENTATION_KEY.match(key)
    if m is None:
        return (len(_ORDER), 0, 0)
    return (_PART_RANK[m.group(2)], int(m.group(3)), 0 if m.group(1) == "alpha" else 1)


def check_entry(entry: ReadingEntry) -> None:
    """Check one entry on its own: a static key, a finite value and σ, σ ≥ 0, physically possible.

    Raises:
        UnknownReadingKeyError: Not a static reading's key.
        NonFiniteReadingError: The value or σ is not finite.
        NegativeSigmaError: σ < 0.
        ImpossibleReadingError: The value is impossible for its key (as a measurement file's
            reading would be refused).
    """
    if is_period_key(entry.key):
        raise UnknownReadingKeyError(entry, f"'{entry.key}' is a pendulum period: periods come from trials")
    if not is_static_key(entry.key):
        raise UnknownReadingKeyError(
            entry,
            f"unknown key '{entry.key}'; expected one of {', '.join(_ORDER)} or alpha<part><i>, "
            "a<part><i> (part B frame, H fork, or S fork and G handlebar hung separately; orientation "
            "i = 1, 2, ...)",
        )
    if not (math.isfinite(entry.value) and math.isfinite(entry.sigma)):
        raise NonFiniteReadingError(entry, "value and sigma must be finite numbers")
    if entry.sigma < 0:
        raise NegativeSigmaError(entry, f"sigma must be >= 0, got {entry.sigma:g}")
    try:
        check_reading(entry.key, entry.reading())
    except MeasurementError as exc:
        raise ImpossibleReadingError(entry, exc.reason) from None


def _ordered(readings: Mapping[str, Reading]) -> dict[str, Reading]:
    """The readings in canonical order (static keys first; any other keys after, as they were)."""
    return {k: readings[k] for k in sorted(readings, key=canonical_order)}


def _source(path: str, n: int) -> str:
    count = f"{n} reading entr{'y' if n == 1 else 'ies'}"
    return f"{path} + {count}" if path else count


def apply_entries(static: Measurements, entries: Iterable[ReadingEntry], origin: str = "reading entry") -> Measurements:
    """The static readings with the entries applied on top.

    Each entry sets its key's reading; of several entries of one key the newest wins, by
    ``stamp_ns`` and then by position in ``entries`` (the order of arrival). Without entries
    ``static`` is returned as it is. Otherwise the readings are in canonical order
    (:func:`canonical_order`) and ``path`` says where they came from: ``"<static.path> + N
    reading entries"`` (``"N reading entries"`` when ``static.path`` is empty). Checks are
    per entry (:func:`check_entry`); whether the readings are complete, and whether the
    hanging orientations are usable together, is for the assembly
    (:class:`bike_rig.pipeline.assemble.SessionAssembly`).

    Args:
        static: The readings to start from (a measurement file's static readings, or none).
        entries: The entries, in the order received.
        origin: Named as each entered reading's origin in error messages.

    Raises:
        ReadingEntryError: The first entry that cannot be used (one of its subclasses).
    """
    ordered = sorted(enumerate(entries), key=lambda ie: (ie[1].stamp_ns, ie[0]))
    if not ordered:
        return static
    readings = dict(static.readings)
    for _, entry in ordered:
        check_entry(entry)
        readings[entry.key] = entry.reading(origin)
    return Measurements(static.bicycle, _ordered(readings), _source(static.path, len(ordered)), static.extras)
