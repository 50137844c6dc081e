"""Errors of the bag tools: every one names the bag (or file) and says why, in one line.

They derive from :class:`bike_rig.core.errors.InputFileError`, so the command line prints
them as ``bike-rig <command>: error: <path>: <reason>`` with exit status 2.
"""

from __future__ import annotations

from ..core.errors import InputFileError

__all__ = [
    "BagError",
    "BagExistsError",
    "BagReadError",
    "IncompleteBagError",
    "NoRigTopicsError",
    "NotABagError",
    "ReplayError",
]


class BagError(InputFileError):
    """A bag cannot be written, read or used.

    Args:
        path: The bag (directory or storage file), as the user gave it.
        reason: Why.
    """

    def __init__(self, path: str, reason: str) -> None:
        """Keep the bag and the reason as an :class:`InputFileError`'s path and reason."""
        super().__init__(str(path), reason)


class NotABagError(BagError):
    """The path is not a rosbag2 bag (no metadata.yaml and no MCAP file, or not MCAP)."""


class IncompleteBagError(BagError):
    """The recording did not end cleanly (no metadata.yaml, or an MCAP file without its summary and footer).

    ``bike-rig bag recover`` makes it readable.
    """


class BagReadError(BagError):
    """The bag's files are unreadable or corrupt."""


class BagExistsError(BagError):
    """The recorder or ``bag recover`` would overwrite an existing bag."""


class NoRigTopicsError(BagError):
    """The bag holds none of the topics a command needs."""


class ReplayError(BagError):
    """The bag's contents cannot be replayed.

    E.g. no static readings, a type recorded with another definition.
    """
