"""The console's health line and log with a stalled node, headless (textual's pilot; no ROS)."""

from __future__ import annotations

import asyncio

from textual.widgets import RichLog, Static

from bike_rig.config.paths import config_file
from bike_rig.console.app import SessionApp
from bike_rig.core.sim import load_rig
from bike_rig.pipeline.diagnostics import Level, Status, StatusReport
from bike_rig.session.setup import build_controller
from test.support.fakelink import FakeLink


def test_a_stalled_node_is_on_the_health_line_and_said_once_in_the_log() -> None:
    link = FakeLink()
    ctl = build_controller(load_rig(config_file("rig.yaml")), "Browser", link)
    t = [0.0]
    ctl.clock = lambda: t[0]

    async def scenario() -> tuple[str, list[str], str]:
        app = SessionApp(ctl)
        async with app.run_test(size=(80, 24)) as pilot:
            for node in ("driver", "fitter"):
                link.events_out.append(StatusReport((Status.of(node, "fits", Level.OK, "fine"),)))
            await pilot.pause(0.2)
            t[0] += 10.0  # the fitter (and the driver) silent for 10 s
            await pilot.pause(0.3)
            stalled = str(app.query_one("#health", Static).render())
            log = [str(line.text) for line in app.query_one("#log", RichLog).lines]
            link.events_out.append(StatusReport((Status.of("fitter", "fits", Level.OK, "fine"),)))
            t[0] += 1.0
            await pilot.pause(0.2)
            back = str(app.query_one("#health", Static).render())
            app.exit(0)
        return stalled, log, back

    stalled, log, back = asyncio.run(scenario())
    assert "fitter SILENT" in stalled and "driver SILENT" in stalled, stalled
    said = [line for line in log if "silent for" in line]
    assert said == [
        "driver silent for 10 s (stalled?): results will follow",
        "fitter silent for 10 s (stalled?): results will follow",
    ], log
    assert "fitter SILENT" in back  # back, but not on time for long enough yet
