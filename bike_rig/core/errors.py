"""Exception family of the science core.

Every error a user can cause carries what went wrong, where (file, key, line) and why, so
the CLI can print one line without a traceback.
"""

from __future__ import annotations

__all__ = [
    "BikeRigError",
    "InputFileError",
    "MeasurementError",
    "GeometryError",
    "ModelError",
    "one_line",
    "short_repr",
]


class BikeRigError(Exception):
    """Base class of every error bike_rig raises on purpose."""


class InputFileError(BikeRigError):
    """A file could not be read or has the wrong format.

    Args:
        path: The file, as given by the user.
        reason: Why it could not be used.
        key: The offending key, if there is one.
        line: The 1-based line number, if known.
    """

    def __init__(self, path: str, reason: str, key: str | None = None, line: int | None = None):
        """Keep the file, reason, key and line, and build the message ``<path>[:<line>][: key '<key>']: <reason>``."""
        self.path = path
        self.reason = reason
        self.key = key
        self.line = line
        where = path
        if line is not None:
            where += f":{line}"
        if key is not None:
            where += f": key '{key}'"
        super().__init__(f"{where}: {reason}")


class MeasurementError(InputFileError):
    """A measurement value is missing, malformed or physically impossible."""


class GeometryError(BikeRigError):
    """The measured geometry cannot determine a result (e.g. parallel hanging lines)."""


class ModelError(BikeRigError):
    """The Whipple model cannot be evaluated for the given parameters or speeds."""


def one_line(text: str) -> str:
    """``text`` on one line (each run of whitespace, newlines included, as one space).

    For a foreign library's message quoted in an error: bike_rig prints each error as one line.
    """
    return " ".join(text.split())


def short_repr(value: object, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (a 1 MB string quoted in an error stays short).

    An integer too long to write (``repr`` refuses 4,300 digits and more) is described instead.
    """
    if isinstance(value, int) and value.bit_length() > 3 * limit:
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
    try:
        text = repr(value)
    except ValueError:  # a list or mapping holding such an integer
        return f"a {type(value).__name__} holding an integer too long to write"
    return text if len(text) <= limit else text[: limit - 3] + "..."
