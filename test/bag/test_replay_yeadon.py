"""``replay --rider RIDER.yaml``: a recorded session's model with a Yeadon rider (issue 13, section 2)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.rider import RiderError, resolve_rider
from bike_rig.core.rider_yeadon import RIDER_GEOMETRY_KEYS
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline.replay import ReplaySettings, replay_bag
from bike_rig.pipeline.model import compute_model
from test.support.paper import shared_dir

BP = shared_dir() / "data" / "bicycleparameters"
JASON = BP / "riders" / "Jason" / "RawData"


def test_replay_with_a_yeadon_rider(session: SimulatedSession, tmp_path: Path) -> None:
    bag = write_simulated_bag(tmp_path / "raw", session, pause_s=2.0)
    raw = read_bp_measured(BP / "Browser" / "RawData" / "BrowserMeasured.txt").extras
    rider = tmp_path / "jason.yaml"
    rider.write_text(
        f"name: Jason\nyeadon_measurements: {JASON / 'JasonYeadonMeas.txt'}\n"
        f"yeadon_configuration: {JASON / 'JasonBrowserYeadonCFG.txt'}\nbicycle_geometry:\n"
        + "".join(f"  {k}: {raw[k]}\n" for k in RIDER_GEOMETRY_KEYS),
        encoding="utf-8",
    )
    bare = replay_bag(bag)
    ridden = replay_bag(bag, ReplaySettings(rider=str(rider)))
    assert ridden.rider == str(rider) and ridden.parameters is not None
    assert resolve_rider(str(rider)) is not None
    assert ridden.stability is not None and ridden.stability.weave is not None
    _, want = compute_model(ridden.parameters, ridden.stability.sweep.speeds, str(rider), files=True)
    assert want.weave is not None
    assert ridden.stability.weave.speed == want.weave.speed and ridden.stability.weave.sigma == want.weave.sigma
    assert bare.stability is not None and bare.stability.weave is not None
    assert ridden.stability.weave.speed > bare.stability.weave.speed + 0.5  # the rider raises the weave speed
    with pytest.raises(RiderError, match="nowhere"):
        replay_bag(bag, ReplaySettings(rider=str(tmp_path / "nowhere.yaml")))
