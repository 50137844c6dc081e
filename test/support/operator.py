"""The operator's side of the driver's services in a node test: StartTrial, StopTrial, what was seen."""

from __future__ import annotations

from typing import Any

from bike_rig.config.topics import GYRO, START_TRIAL, STOP_TRIAL, TRIAL_EVENTS
from test.support.probe import STEP_TIMEOUT_S, Probe, msgs, srvs
from test.support.processes import RosProcess


class Operator:
    """StartTrial and StopTrial calls, and the trial events and gyro batches seen."""

    def __init__(self, probe: Probe, driver: RosProcess | None = None):
        self.probe = probe
        self.driver = driver
        self.events = probe.subscribe(TRIAL_EVENTS, msgs.TrialEvent)
        self.batches = probe.subscribe(GYRO, msgs.GyroBatch)
        self.start_client = probe.node.create_client(srvs.StartTrial, START_TRIAL)
        self.stop_client = probe.node.create_client(srvs.StopTrial, STOP_TRIAL)

    def start(self, part: str, pendulum: str, orientation: int = 0, **fields: Any) -> Any:
        request = srvs.StartTrial.Request(part=part, pendulum=pendulum, orientation=orientation, **fields)
        return self.probe.call(self.start_client, request)

    def stop(self, trial_id: str = "", abort: bool = False) -> Any:
        return self.probe.call(self.stop_client, srvs.StopTrial.Request(trial_id=trial_id, abort=abort))

    def event(self, kind: int, trial_id: str) -> Any:
        """Wait for the event ``kind`` of ``trial_id``."""

        def found() -> Any:
            return next((e for e in self.events if e.kind == kind and e.trial_id == trial_id), None)

        describe = self.driver.describe if self.driver is not None else (lambda: "")
        self.probe.spin_until(lambda: found() is not None, STEP_TIMEOUT_S, f"event {kind} of {trial_id}", describe)
        return found()

    def samples(self, trial_id: str) -> int:
        return sum(len(b.rates) for b in self.batches if b.trial_id == trial_id)
