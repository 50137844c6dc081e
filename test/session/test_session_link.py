"""The console's link to the driver says why a start or stop got no answer."""

from __future__ import annotations

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig
from bike_rig.ros.nodes import session_link
from bike_rig.session.plan import plan_from_rig


def test_a_driver_that_is_not_there_is_said_not_found(monkeypatch: pytest.MonkeyPatch, ros_env: dict[str, str]) -> None:
    # the run's own domain, where no driver runs: the services are never discovered
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
        monkeypatch.setenv(key, ros_env[key])
    monkeypatch.setattr(session_link, "DISCOVERY_TIMEOUT_S", 0.5)
    item = plan_from_rig(load_rig(config_file("rig.yaml"))).trials[0]
    link = session_link.SessionLink("session_link_test")
    try:
        started = link.start_trial(item, 5.0)
        stopped = link.stop_trial("no_such_trial", abort=False)
    finally:
        link.close()
    assert not started.accepted and started.trial_id == ""
    assert "/start_trial not found within 0.5 s (is it running?)" in started.message
    why = "the driver's service /bike_rig/driver/stop_trial not found within 0.5 s (is it running?)"
    assert stopped == (False, why)
