"""An in-process stand-in for the live graph: the offline stages behind the GraphLink protocol.

A started trial is simulated with the rig's physics (bike_rig.core.sim) and fitted with the
trial fitter (bike_rig.pipeline.fit) when the test "finishes" it; readings and periods are
assembled with the parameter stage and the model computed as the nodes do. No ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bike_rig.config.paths import config_file
from bike_rig.core.measurements import Measurements
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.assemble import SessionAssembly
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.model import compute_model
from bike_rig.pipeline.offline import DEFAULT_SPEEDS
from bike_rig.pipeline.readings import ReadingEntry, apply_entries
from bike_rig.session.controller import GraphEvent, StartReply
from bike_rig.session.plan import TrialItem


@dataclass
class FakeLink:
    """Answers starts and stops, turns readings and fitted periods into results."""

    bicycle: str = "Browser"
    refuse: str = ""
    events_out: list[GraphEvent] = field(default_factory=list)
    started: list[tuple[str, TrialItem]] = field(default_factory=list)
    stopped: list[tuple[str, bool]] = field(default_factory=list)
    entries: list[ReadingEntry] = field(default_factory=list)
    fits: list[TrialFit] = field(default_factory=list)

    def start_trial(self, item: TrialItem, duration_s: float) -> StartReply:
        if self.refuse:
            return StartReply(False, "", self.refuse)
        trial_id = f"{item.measurement.trial_name(item.repeat)}_{len(self.started)}"
        self.started.append((trial_id, item))
        self.events_out.append(
            TrialEventRecord(TrialEventKind.START, trial_id, item.key, repeat=item.repeat, sample_rate_hz=1000.0)
        )
        return StartReply(True, trial_id, f"recording trial {trial_id}")

    def stop_trial(self, trial_id: str, abort: bool) -> tuple[bool, str]:
        self.stopped.append((trial_id, abort))
        kind = TrialEventKind.ABORT if abort else TrialEventKind.STOP
        self.events_out.append(TrialEventRecord(kind, trial_id, sample_rate_hz=1000.0))
        return True, f"trial {trial_id} {'aborted' if abort else 'stopped'}"

    def send_reading(self, entry: ReadingEntry) -> None:
        self.entries.append(entry)
        self.events_out.append(entry)
        self._results()

    def events(self) -> list[GraphEvent]:
        out, self.events_out = self.events_out, []
        return out

    # ---------------------------------------------------------------- test controls
    def samples(self, trial_id: str, rates: Any, first: int = 0) -> None:
        self.events_out.append(SampleBatch(trial_id, first, 1000.0, np.asarray(rates, dtype=np.float64)))

    def period(self, trial_id: str, key: str, period: float, sigma: float, flags: tuple[str, ...] = ()) -> None:
        reasons = tuple(f"{c} reason" for c in flags)
        fit = TrialFit.from_period(trial_id, key, period, sigma, True, flags, reasons, r2=0.9999, window=(0, 30000))
        self.fits.append(fit)
        self.events_out.append(TrialEventRecord(TrialEventKind.STOP, trial_id, key, sample_rate_hz=1000.0))
        self.events_out.append(fit)
        self._results()

    def _results(self) -> None:
        static = apply_entries(Measurements(self.bicycle, {}), self.entries)
        assembly = SessionAssembly(static, partial=True)
        for f in self.fits:
            assembly.add(f)
        result = assembly.result()
        self.events_out.append(result)
        if result.complete:
            _, sweep = compute_model(result.complete_parameters(), DEFAULT_SPEEDS)
            self.events_out.append(sweep)


def browser_truth() -> tuple[Any, Any]:
    """The simulated Browser session on the paper's rig (seed 3): its readings and trials."""
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    return rig, simulate_session(truth, rig, 3, name)


def is_close(a: float, b: float, rel: float = 1e-12) -> bool:
    return math.isclose(a, b, rel_tol=rel)
