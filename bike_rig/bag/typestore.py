"""A rosbags typestore that knows bike_rig's messages, to read, write and replay bags without ROS.

:func:`rig_typestore` holds every ``bike_rig_msgs/msg/*.msg`` and the standard types they use,
parsed with ``get_types_from_msg``, from the installed interface packages
(``<prefix>/share/<package>/msg``, what the nodes were built from) or else the source tree; a
standard type not installed comes from rosbags' ROS 2 Kilted store. :func:`standard_typestore`
adds every standard Kilted message, loaded only when asked for. Type hashes (RIHS01) equal
rosidl's ``share/bike_rig_msgs/msg/*.json``.
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
    "standard_typestore",
    "store_for",
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


def _parse(text: str, msgtype: str, where: str) -> dict[str, Any]:
    try:
        return dict(get_types_from_msg(text, msgtype))
    except Exception as exc:  # rosbags raises several kinds for a bad definition
        raise BagError(where, f"cannot parse the message definition ({exc})") from None


def _installed_msg(msgtype: str, msg_dir: Path) -> Path | None:
    """The ``.msg`` file of a standard type (``pkg/msg/Name``) in the prefixes of :func:`msg_dir_candidates`."""
    pkg, _, name = msgtype.split("/")
    roots = [d.parents[2] for d in msg_dir_candidates()] + [msg_dir.parents[2]]
    for root in dict.fromkeys(roots):
        path = root / "share" / pkg / "msg" / f"{name}.msg"
        if path.is_file():
            return path
    return None


def _dependencies(types: dict[str, Any]) -> set[str]:
    """The message types the given definitions name (in fields, arrays and sequences)."""
    out = set()
    for _, fields in types.values():
        for _, (nodetype, spec) in fields:
            if nodetype == 2:  # a message
                out.add(spec)
            elif nodetype in (3, 4) and spec[0][0] == 2:  # an array or sequence of messages
                out.add(spec[0][1])
    return out


@lru_cache(maxsize=1)
def rig_typestore() -> Typestore:
    """The rig's typestore: ``bike_rig_msgs/msg/*`` and the standard types they use (cached).

    Raises:
        BagError: The ``.msg`` files cannot be found or parsed.
    """
    msg_dir = find_msg_dir()
    types: dict[str, Any] = {}
    for path in sorted(msg_dir.glob("*.msg")):
        types.update(_parse(path.read_text(encoding="utf-8"), f"{MSG_PACKAGE}/msg/{path.stem}", str(path)))
    missing = _dependencies(types) - set(types)
    while missing:
        msgtype = missing.pop()
        dep = _installed_msg(msgtype, msg_dir)
        if dep is None:  # not installed here: the distribution's own definitions
            store = get_typestore(Stores.ROS2_KILTED)
            store.register(types)
            return store
        types.update(_parse(dep.read_text(encoding="utf-8"), msgtype, str(dep)))
        missing = _dependencies(types) - set(types)
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store


@lru_cache(maxsize=1)
def standard_typestore() -> Typestore:
    """ROS 2 Kilted's standard types plus the rig's (cached; loaded on first use).

    Raises:
        BagError: The rig's ``.msg`` files cannot be found or parsed.
    """
    rig = rig_typestore()
    store = get_typestore(Stores.ROS2_KILTED)
    store.register({name: rig.fielddefs[name] for name in rig.fielddefs if name.startswith(f"{MSG_PACKAGE}/")})
    return store


def store_for(msgtype: str) -> Typestore:
    """The rig's typestore when it knows ``msgtype``, else the standard one."""
    rig = rig_typestore()
    return rig if msgtype in rig.fielddefs else standard_typestore()


def type_hash(msgtype: str) -> str:
    """The RIHS01 type hash of a type, as rosidl writes it (``RIHS01_<64 hex>``)."""
    return str(store_for(msgtype).hash_rihs01(msgtype))


_SEPARATOR = "=" * 80 + "\n"


def _msg_text(msgtype: str) -> str | None:
    """The ``.msg`` file of a type as written (comments and units included), None if not found."""
    pkg, _, name = msgtype.split("/")
    try:
        msg_dir = find_msg_dir()
    except BagError:
        return None
    path = msg_dir / f"{name}.msg" if pkg == MSG_PACKAGE else _installed_msg(msgtype, msg_dir)
    return path.read_text(encoding="utf-8") if path is not None and path.is_file() else None


def message_definition(msgtype: str) -> str:
    """The ``ros2msg`` schema text of a type, as rosbag2 stores it in MCAP schemas.

    Its ``.msg`` file verbatim (comments and units included) followed by every dependency's
    (``====`` separator, ``MSG: pkg/Type``); a definition whose file is not found is the one
    rosbags generates from the typestore.
    """
    text, _ = store_for(msgtype).generate_msgdef(msgtype, ros_version=2)
    sections = str(text).split(_SEPARATOR)
    out = []
    for k, section in enumerate(sections):
        name = msgtype if k == 0 else section.partition("\n")[0].removeprefix("MSG: ").strip()
        found = _msg_text(name if name.count("/") == 2 else name.replace("/", "/msg/", 1))
        body = section if found is None else found.rstrip("\n") + "\n"
        out.append(body if k == 0 else f"MSG: {name}\n{body}" if found is not None else section)
    return _SEPARATOR.join(out)


_NUMPY_TYPES = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}


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
    store = store_for(msgtype)
    _, defs = store.fielddefs[msgtype]
    values = {name: _default(nodetype, spec) for name, (nodetype, spec) in defs}
    values.update(fields)
    return store.types[msgtype](**values)
