"""The model node with a Yeadon rider file as its ``rider`` parameter (issue 13, section 2)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bike_rig.config import topics
from bike_rig.core.benchmark import ComMethod
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.rider import add_rider, resolve_rider
from bike_rig.core.rider_yeadon import RIDER_GEOMETRY_KEYS
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from test.support.nodes import (
    STAMP_NS,
    node_environment,
    offline_set,
    publish_set,
    stamp_of,
    start_node,
    state_space_request,
)
from test.support.paper import shared_dir
from test.support.probe import Probe

pytestmark = pytest.mark.ros

BP = shared_dir() / "data" / "bicycleparameters"
JASON = BP / "riders" / "Jason" / "RawData"


def _rider_file(tmp_path: Path) -> str:
    """Jason with the Browser's rider geometry in the file: sets on the topic carry none."""
    raw = read_bp_measured(BP / "Browser" / "RawData" / "BrowserMeasured.txt").extras
    geometry = "".join(f"  {k}: {raw[k]}\n" for k in RIDER_GEOMETRY_KEYS)
    path = tmp_path / "jason.yaml"
    path.write_text(
        f"name: Jason\nyeadon_measurements: {JASON / 'JasonYeadonMeas.txt'}\n"
        f"yeadon_configuration: {JASON / 'JasonBrowserYeadonCFG.txt'}\nbicycle_geometry:\n{geometry}",
        encoding="utf-8",
    )
    return str(path)


def test_model_node_with_a_yeadon_rider(probe: Probe, ros_env: dict[str, str], tmp_path: Path) -> None:
    from bike_rig_msgs.msg import CanonicalMatrices
    from bike_rig_msgs.srv import StateSpace

    rider = _rider_file(tmp_path)
    probe.listen(topics.MATRICES, CanonicalMatrices)
    args = ("-p", f"rider:={rider}", "-p", "speed_max:=5.0", "-p", "speed_count:=11")
    with start_node("model", "model_yeadon", node_environment(ros_env), tmp_path, *args) as node:
        publish_set(probe, ComMethod.CENTROID, STAMP_NS)
        matrices = probe.wait_message(topics.MATRICES, lambda m: stamp_of(m) == STAMP_NS, "matrices", [node])
        chosen = resolve_rider(rider)
        assert chosen is not None
        ms = canonical_with_sigma(add_rider(offline_set(), chosen))
        assert matrices.rider == rider
        for field, name in (("m", "M"), ("c1", "C1"), ("k0", "K0"), ("k2", "K2")):
            np.testing.assert_allclose(
                np.asarray(getattr(matrices, field)), getattr(ms.matrices, name).ravel(), rtol=1e-12
            )
            got_sigma = np.asarray(getattr(matrices, f"{field}_sigma"))
            np.testing.assert_allclose(got_sigma, getattr(ms.sigma, name).ravel(), rtol=1e-9, atol=1e-15)
        own = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(2.0, ""))
        assert own.ok, own.message
        # a request may name only '', none or paper: no file is read on a client's word
        refused = probe.call(StateSpace, topics.STATE_SPACE, state_space_request(2.0, rider + ".other.yaml"))
        assert not refused.ok and "unknown rider" in refused.message
        code = node.stop()
    assert code == 0, node.describe()


def test_bad_rider_file_parameter_is_one_error_line_and_status_2(ros_env: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("yeadon_measurements: nowhere.txt\nyeadon_configuration: nowhere.txt\n", encoding="utf-8")
    argv = [sys.executable, "-m", "bike_rig.ros.nodes.model", "--ros-args", "-p", f"rider:={bad}"]
    done = subprocess.run(argv, env=node_environment(ros_env), capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "rider" in lines[0] and "nowhere.txt" in lines[0], done.stderr
