"""Where figures go: the output directory and the names of the files in it.

Shared by ``bike-rig plot`` (:mod:`bike_rig.cli.plot_cmd`, one file per figure) and the report
(:mod:`bike_rig.report.build`, one HTML page); each passes its own error class, so each command
keeps its own kind of error with the same text. No matplotlib here.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path

from ..core.errors import BikeRigError, InputFileError

__all__ = ["TRIAL_SUFFIXES", "check_out_dir", "slug", "trial_name", "unique_names"]

#: Extensions of trial files, dropped from a trial's id in its figure's file name.
TRIAL_SUFFIXES = (".npy", ".csv", ".mat", ".txt")


def check_out_dir(
    path: str | Path,
    error: Callable[[str, str], BikeRigError] = InputFileError,
    create: bool = True,
) -> Path:
    """Check that ``path`` can be an output directory, and create it (with its parents).

    Args:
        path: The directory, as given by the user.
        error: The error class to raise, called with the path (as given) and the reason.
        create: Create the directory if missing; False only checks that no file is in the way.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        BikeRigError: Of class ``error``: ``path`` exists and is not a directory, or cannot be
            created (the reason says why).
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise error(str(out), "exists and is not a directory")
    if create:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise error(str(out), f"cannot create the directory ({exc.strerror or exc})") from None
    return out


def slug(name: str) -> str:
    """``name`` in lower case with anything but letters, digits, ``-`` and ``.`` made ``-``.

    Args:
        name: A bicycle's or a trial's name.

    Returns:
        The file-name form (``bicycle`` for a name with nothing left).
    """
    s = re.sub(r"[^a-z0-9.\-]+", "-", name.lower()).strip("-")
    return s or "bicycle"


def trial_name(trial_id: str) -> str:
    """A trial's id without its file's extension (``frame_compound_t1.npy`` → ``frame_compound_t1``).

    Args:
        trial_id: The trial's id (a file name for trials read from files).

    Returns:
        The id without a :data:`TRIAL_SUFFIXES` extension.
    """
    p = Path(trial_id)
    return p.stem if p.suffix.lower() in TRIAL_SUFFIXES else trial_id


def unique_names(names: Sequence[str]) -> list[str]:
    """File-name forms (:func:`slug`) of ``names``, made distinct with ``-2``, ``-3``...

    Args:
        names: Names, in order; equal ones are numbered from their second occurrence.

    Returns:
        One distinct file-name form per name, in the same order.
    """
    out: list[str] = []
    for name in names:
        base = slug(name)
        name, k = base, 2
        while name in out:
            name, k = f"{base}-{k}", k + 1
        out.append(name)
    return out
