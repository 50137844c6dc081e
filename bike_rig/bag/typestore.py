"""A rosbags typestore that knows bike_rig's messages.

With it, bags can be read, written and replayed with no ROS runtime.

It is ``get_typestore(Stores.ROS2_KILTED)`` (the standard messages of the ROS distribution the
rig runs on) plus every ``bike_rig_msgs/msg/*.msg``, parsed with ``get_types_from_msg``. The
``.msg`` files come from the installed interface package (``<prefix>/share/bike_rig_msgs/msg``:
exactly what the running nodes were built from) or, when that is absent, from the source tree.
The type hashes (RIHS01) it computes equal rosidl's ``share/bike_rig_msgs/msg/*.json``.
"""

from __future__ import annotations

import os
import sys
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from .errors import BagError

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = [
    "MSG_PACKAGE",
    "find_msg_dir",
    "message_definition",
    "msg_dir_candidates",
    "new_message",
    "rig_typestore",
    "type_hash",
]

MSG_PACKAGE = "bike_rig_msgs"


def msg_dir_candidates() -> list[Path]:
    """Where the ``.msg`` files are looked for, in order of preference.

    The running interpreter's prefix, every ``AMENT_PREFIX_PATH`` entry (the ROS convention),
    then the source tree beside the ``bike_rig`` package.
    """
    prefixes = [Path(sys.prefix)]
    prefixes += [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    out = [p / "share" / MSG_PACKAGE / "msg" for p in prefixes]
    out.append(Path(__file__).resolve().parents[2] / MSG_PACKAGE / "msg")
    return list(dict.fromkeys(out))


def find_msg_dir() -> Path:
    """The first candidate directory that holds ``.msg`` files.

    Raises:
        BagError: None holds any (the interface package is neither installed nor beside us).
    """
    for d in msg_dir_candidates():
        if d.is_dir() and any(d.glob("*.msg")):
            return d
    tried = ", ".join(str(d) for d in msg_dir_candidates())
    raise BagError(MSG_PACKAGE, f"no .msg files found (looked in {tried})")


@lru_cache(maxsize=1)
def rig_typestore() -> Typestore:
    """The typestore: ROS 2 Kilted's standard types plus ``bike_rig_msgs/msg/*`` (cached).

    Raises:
        BagError: The ``.msg`` files cannot be found or parsed.
    """
    msg_dir = find_msg_dir()
    store = get_typestore(Stores.ROS2_KILTED)
    types = {}
    for path in sorted(msg_dir.glob("*.msg")):
        try:
            types.update(get_types_from_msg(path.read_text(encoding="utf-8"), f"{MSG_PACKAGE}/msg/{path.stem}"))
        except Exception as exc:  # rosbags raises several kinds for a bad definition
            raise BagError(str(path), f"cannot parse the message definition ({exc})") from None
    store.register(types)
    return store


def type_hash(msgtype: str) -> str:
    """The RIHS01 type hash of a type, as rosidl writes it (``RIHS01_<64 hex>``)."""
    return str(rig_typestore().hash_rihs01(msgtype))


def message_definition(msgtype: str) -> str:
    """The ``ros2msg`` schema text of a type.

    Its definition followed by every dependency (``====`` separator, ``MSG: pkg/Type``), as
    rosbag2 stores it in MCAP schemas.
    """
    text, _ = rig_typestore().generate_msgdef(msgtype, ros_version=2)
    return str(text)


_NUMPY_TYPES = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}  # fmt: skip


def _default(nodetype: int, spec: Any) -> Any:
    if nodetype == 1:  # a base type
        name = spec[0]
        if name == "string" or name == "wstring":
            return ""
        if name == "bool":
            return False
        return 0.0 if name.startswith("float") else 0
    if nodetype == 2:  # a message
        return new_message(spec)
    (inner_type, inner_spec), length = spec
    n = length if nodetype == 3 else 0  # fixed array or sequence
    if inner_type == 1 and inner_spec[0] in _NUMPY_TYPES:
        return np.zeros(n, dtype=_NUMPY_TYPES[inner_spec[0]])
    return [_default(inner_type, inner_spec) for _ in range(n)]


def new_message(msgtype: str, **fields: Any) -> Any:
    """A message of the rig's typestore with every field at its default, then ``fields`` set.

    The defaults are zeros, empty strings and sequences, nested messages likewise.
    """
    store = rig_typestore()
    _, defs = store.fielddefs[msgtype]
    values = {name: _default(nodetype, spec) for name, (nodetype, spec) in defs}
    values.update(fields)
    return store.types[msgtype](**values)
