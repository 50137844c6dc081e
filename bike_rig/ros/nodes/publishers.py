"""Which process published a message: its DDS participant, from rclpy's message info or the graph.

Every publisher of one process (one rclpy context) shares the first 12 bytes of its GUID (the
participant's GUID prefix). The fitter keys trials by it; the run monitor checks it against the
graph's record of which node publishes from it.
"""

from __future__ import annotations

from typing import Any

__all__ = ["participant", "publisher_source"]


def participant(gid: Any) -> str:
    """The DDS participant (process) of a publisher GUID: its first 12 bytes, hex ("" if unknown).

    Args:
        gid: rclpy's ``publisher_gid`` (a dict with ``data``), or the GUID's bytes (e.g. a
            graph endpoint's ``endpoint_gid``), or None.
    """
    data = gid.get("data") if isinstance(gid, dict) else gid
    return bytes(data[:12]).hex() if data else ""


def publisher_source(info: Any) -> str:
    """The participant that published a message, from rclpy's message info ("" when it does not say)."""
    return participant(info.get("publisher_gid") if isinstance(info, dict) else None)
