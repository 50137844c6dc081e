"""MCAP files that are not ROS 2 bags of CDR messages, refused in one line.

Another tool's MCAP (Foxglove's JSON or Protobuf channels, a schemaless channel, a ``ros2idl``
or other profile) is named with the first reason found, channels first: ``not a ROS 2 CDR bag:
channel /x has message encoding 'json'``. A ROS 2 bag's channels carry ``cdr`` messages and a
``ros2msg`` or ``ros2idl`` schema, and its header the profile ``ros2``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from .errors import NotABagError
from .schemas import SCHEMA_ENCODINGS

__all__ = ["ChannelShape", "check_ros2_cdr", "foreign_reason", "mcap_shape", "not_ros2_error"]

#: The message encoding of ROS 2 messages in MCAP.
CDR = "cdr"
#: The MCAP profile of rosbag2.
PROFILE = "ros2"


@dataclass(frozen=True)
class ChannelShape:
    """What makes a channel ROS 2: its topic, message encoding, and its schema's name and encoding.

    ``schema_encoding`` is None for a channel without a schema.
    """

    topic: str
    message_encoding: str
    schema_name: str
    schema_encoding: str | None


def foreign_reason(profile: str | None, channels: Iterable[ChannelShape]) -> str:
    """Why an MCAP file is not a ROS 2 CDR bag ("" when it is one; ``profile`` None: not known)."""
    for ch in channels:
        if ch.message_encoding != CDR:
            return f"channel {ch.topic} has message encoding {ch.message_encoding!r}"
        if ch.schema_encoding is None:
            return f"channel {ch.topic} has no schema"
        if ch.schema_encoding not in SCHEMA_ENCODINGS:
            return f"channel {ch.topic}: its schema {ch.schema_name} has encoding {ch.schema_encoding!r}"
    if profile is not None and profile != PROFILE:
        return f"MCAP profile {profile!r} is not {PROFILE!r}"
    return ""


def not_ros2_error(path: Path, shown: str, reason: str) -> NotABagError:
    """The error for file ``path`` of the bag ``shown``: ``[<file>: ]not a ROS 2 CDR bag: <reason>``."""
    where = "" if Path(shown).name == path.name else f"{path.name}: "
    return NotABagError(shown, f"{where}not a ROS 2 CDR bag: {reason}")


def mcap_shape(path: Path) -> tuple[str, list[ChannelShape]] | None:
    """An MCAP file's profile and channels, read with the mcap library (None when it cannot read them).

    The summary section when there is one, else every record front to back.
    """
    from mcap.reader import make_reader
    from mcap.records import Channel, Schema
    from mcap.stream_reader import StreamReader

    try:
        with path.open("rb") as f:
            reader = make_reader(f)
            profile = reader.get_header().profile
            summary = reader.get_summary()
            if summary is not None and summary.channels:
                schemas, channels = summary.schemas, summary.channels
            else:
                f.seek(0)
                schemas, channels = {}, {}
                for record in StreamReader(f).records:
                    if isinstance(record, Schema):
                        schemas.setdefault(record.id, record)
                    elif isinstance(record, Channel):
                        channels.setdefault(record.id, record)
    except (GeneratorExit, KeyboardInterrupt):
        raise
    except Exception:  # the mcap library's own errors, a damaged file: the reader says what is wrong
        return None
    out = []
    for cid in sorted(channels):
        ch = channels[cid]
        schema = schemas.get(ch.schema_id) if ch.schema_id else None
        out.append(
            ChannelShape(
                ch.topic, ch.message_encoding, schema.name if schema else "", schema.encoding if schema else None
            )
        )
    return profile, out


def check_ros2_cdr(path: Path, shown: str) -> None:
    """Refuse an MCAP file that is not a ROS 2 CDR bag (nothing said when the mcap library cannot read it).

    Raises:
        NotABagError: ``not a ROS 2 CDR bag: <reason>`` (see :func:`foreign_reason`).
    """
    shape = mcap_shape(path)
    if shape is None:
        return
    reason = foreign_reason(*shape)
    if reason:
        raise not_ros2_error(path, shown, reason)
