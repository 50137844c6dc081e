"""Parameter sets for the model-node tests, and a stand-in for the parameter node's process.

The model node takes parameter sets only from the process of the node named ``parameter``
(:mod:`bike_rig.ros.nodes.owners`). :class:`ParameterStandIn` is such a node inside the test's own
process (the probe's rclpy context): a set published through it is the parameter node's.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

import numpy as np
import rclpy

from bike_rig.config import topics
from bike_rig.core.benchmark import ComMethod, ParameterSet
from bike_rig.core.uncertainty.uncertain import UncertainVector
from bike_rig.messages import fill_benchmark_parameters, set_stamp
from bike_rig.pipeline.assemble import SessionParameters
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")

#: The stamp of the rogue process's parameter set (test/nodes/rogue_parameters.py), ns.
ROGUE_STAMP_NS = 1_700_000_777_000_000_001


def parameter_message(
    ps: ParameterSet, stamp_ns: int, bicycle: str | None = None, changes: Mapping[str, float] | None = None
) -> Any:
    """A complete ``BenchmarkParameters`` of ``ps``, some values changed (the covariance kept)."""
    values = np.array(ps.parameters.values, dtype=float)
    for name, value in (changes or {}).items():
        values[ps.parameters.index(name)] = value
    vector = UncertainVector(ps.parameters.names, values, np.asarray(ps.parameters.covariance))
    changed = ParameterSet(bicycle or ps.bicycle, vector, ps.source)
    msg = fill_benchmark_parameters(
        msgs.BenchmarkParameters(), SessionParameters(changed.bicycle, ComMethod.CENTROID, (), (), changed)
    )
    set_stamp(msg, stamp_ns)
    return msg


class ParameterStandIn:
    """A node named ``parameter`` in the probe's process, publishing on ``/bike_rig/parameters``.

    Args:
        context: The probe's rclpy context (``Probe.context``).
    """

    def __init__(self, context: Any) -> None:
        self.node = rclpy.create_node("parameter", context=context)
        self.publisher = self.node.create_publisher(
            msgs.BenchmarkParameters, topics.PARAMETERS.name, profile(topics.PARAMETERS)
        )

    def matched(self) -> bool:
        """Whether a reader (the model node) has matched."""
        return bool(self.publisher.get_subscription_count() > 0)

    def publish(self, msg: Any) -> None:
        self.publisher.publish(msg)

    def close(self) -> None:
        self.node.destroy_node()

    def __enter__(self) -> ParameterStandIn:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
