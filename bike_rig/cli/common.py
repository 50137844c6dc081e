"""What several ``bike-rig`` commands share: writing their output, and reading a rider."""

from __future__ import annotations

import math
from pathlib import Path

from ..core.errors import BikeRigError, InputFileError
from ..core.io_yaml import load_yaml_document
from ..core.rider import PAPER_RIDER, Rider

__all__ = ["UsageError", "emit", "rider_from_spec"]


class UsageError(BikeRigError):
    """A command-line argument is invalid."""


def emit(text: str, output: str | None) -> None:
    """Print ``text``, or write it (with a final newline) to the file ``output``.

    Raises:
        InputFileError: ``output`` cannot be written.
    """
    if output:
        try:
            Path(output).write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise InputFileError(output, f"cannot write ({exc.strerror})") from None
    else:
        print(text)


def rider_from_spec(spec: str | None) -> Rider | None:
    """The rider named on the command line: None, ``none``, ``paper`` (Table 1) or a rider YAML file
    (a mapping of ``mass, x, z, Ixx, Iyy, Izz, Ixz`` in kg, m and kg m², benchmark frame).

    Raises:
        InputFileError: The rider file is missing, unreadable or lacks a number.
    """
    if spec is None or spec == "none":
        return None
    if spec == "paper":
        return PAPER_RIDER
    data, lines = load_yaml_document(spec)
    keys = ("mass", "x", "z", "Ixx", "Iyy", "Izz", "Ixz")
    if not isinstance(data, dict):
        raise InputFileError(spec, f"a rider file is a mapping of {', '.join(keys)}")
    values = {}
    for k in keys:
        v = data.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputFileError(spec, f"needs a number ({v!r} given)", key=k, line=lines.get((k,)))
        values[k] = float(v)
    if values["mass"] <= 0:
        raise InputFileError(spec, "rider mass must be positive", key="mass", line=lines.get(("mass",)))
    return Rider(name=str(data.get("name", Path(spec).stem)), **values)
