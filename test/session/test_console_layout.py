"""The console headless (textual's pilot; no ROS): the plan follows the item, a held reading stays, quitting asks."""

from __future__ import annotations

import asyncio

from textual.widgets import DataTable, RichLog, Static

from bike_rig.config.paths import config_file
from bike_rig.console.app import SessionApp
from bike_rig.core.sim import load_rig
from bike_rig.session.controller import SessionController
from bike_rig.session.setup import build_controller
from test.support.fakelink import FakeLink


def _controller() -> tuple[SessionController, FakeLink]:
    link = FakeLink()
    ctl = build_controller(load_rig(config_file("rig.yaml")), "Browser", link)
    ctl.clock = lambda: 0.0
    return ctl, link


def test_the_plan_follows_the_item_to_redo_far_down() -> None:
    ctl, link = _controller()
    late = ctl.session.plan.trials[-2]

    async def scenario() -> tuple[int, int, int, str]:
        app = SessionApp(ctl)
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause(0.1)
            table = app.query_one("#plan", DataTable)
            first = table.scroll_y
            ctl.execute(f"start {late.item_id}")
            await pilot.pause(0.2)
            recording = table.cursor_row
            link.period(link.started[-1][0], late.key, 1.2, 1e-4, flags=("too_few_cycles",))
            await pilot.pause(0.3)
            visible = table.scroll_y
            rows = [str(r) for r in app.query_one("#next", Static).render().plain.splitlines()]  # type: ignore[attr-defined]
            app.exit(0)
        return first, recording, visible, " ".join(rows)

    first, recording, visible, side = asyncio.run(scenario())
    row = list(ctl.session.plan.items).index(late)
    assert first == 0 and recording == row  # the recording item, then ...
    assert visible > 0 and visible <= row  # ... scrolled into sight (80×24 shows about 11 rows of 68)
    assert side.startswith("REDO: ") and late.instruction.split()[0] in side


def test_a_held_reading_stays_in_sight_and_quitting_asks() -> None:
    ctl, link = _controller()

    async def scenario() -> tuple[str, str, str, bool, bool]:
        app = SessionApp(ctl)
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause(0.1)
            await pilot.press(*"reading gamma 1.2 0.01", "enter")
            for _ in range(40):  # a screenful of other lines: the warning scrolls out of the log, not out of sight
                app.query_one("#log", RichLog).write("another line")
            await pilot.pause(0.2)
            held = app.query_one("#next", Static).render().plain  # type: ignore[attr-defined]
            await pilot.press("f10")
            await pilot.pause(0.1)
            asked = app.query_one("#next", Static).render().plain  # type: ignore[attr-defined]
            await pilot.press(*"status", "enter")  # any command stays
            await pilot.pause(0.1)
            stayed = not ctl.quit_requested
            await pilot.press(*"reading gamma 68.9 0.1", "enter")
            await pilot.pause(0.2)
            answered = app.query_one("#next", Static).render().plain  # type: ignore[attr-defined]
            await pilot.press("ctrl+c")
            await pilot.press("ctrl+c")
            await pilot.pause(0.2)
        return held, asked, answered, stayed, ctl.quit_requested

    held, asked, answered, stayed, quit_requested = asyncio.run(scenario())
    assert "radians" in held and "'keep'" in held
    assert asked.startswith("Quit?") and stayed
    assert "radians" not in answered and ctl.session.reading("gamma").value == 68.9  # type: ignore[union-attr]
    assert quit_requested  # Ctrl-C twice: asked, then quit
