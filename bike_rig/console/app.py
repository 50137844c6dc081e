"""The operator's console: a textual app over :class:`~bike_rig.session.controller.SessionController`.

Works in an 80×24 terminal (over SSH, under tmux). Layout: the plan with each item's state
(left), what to do next, the recording trial's live trace, amplitude and warnings, and the
nodes' health from ``/diagnostics`` (right: each node's worst level, or SILENT / BEHIND while it
is stalled or behind its input), the log of results and replies (a line whenever a node's health
level changes, and when it stalls, falls behind or catches up), and the command line. Keys:

* **F2** — do the next item: start the next trial to do or redo (or the redo just offered),
  or, when the next item is a reading, put ``reading KEY `` on the command line;
* **F3** — stop the recording trial; **F4** — abort it (ABORT is recorded);
* **F5** — the next item and the next-best measurement; **F10** — quit.

Every command of plain mode can be typed on the command line (``help`` lists them).
"""

from __future__ import annotations

import math

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.widgets import DataTable, Footer, Input, RichLog, Sparkline, Static

from ..diagnostics import Level, node_of
from ..pipeline.model import StabilitySweep
from ..session.controller import Reply, SessionController
from ..session.plan import ItemState, ReadingItem, TrialItem
from ..textfmt import format_speed, terminal_safe

__all__ = ["SessionApp", "run_console", "title_text"]

#: Screen refresh and graph polling period, s.
TICK_S = 0.05

_STATE_STYLE = {
    ItemState.TODO: "dim",
    ItemState.RECORDING: "bold yellow",
    ItemState.OK: "green",
    ItemState.REDO: "bold red",
    ItemState.DONE: "green",
}
_REPLY_STYLE = {"error": "bold red", "warning": "yellow", "result": "bold", "ok": "cyan", "done": "green",
                "health": "magenta"}


def title_text(bicycle: str, done: int, total: int, speeds: StabilitySweep | None) -> str:
    """The title line: bicycle, progress and, once there, both speeds with σ (compact: 80 columns).

    E.g. ``bike_rig · Browser · 68/68 done  weave 4.195±0.045  capsize 4.350±0.064 m/s``.
    """
    title = f"bike_rig · {bicycle} · {done}/{total} done"
    if speeds is None or speeds.weave is None or speeds.capsize is None:
        return title
    weave, capsize = format_speed(speeds.weave, compact=True), format_speed(speeds.capsize, compact=True)
    return f"{title}  weave {weave}  capsize {capsize} m/s"


class SessionApp(App[int]):
    """The console (see the module docstring)."""

    CSS = """
    #top { height: 1fr; }
    #plan { width: 44; }
    #side { width: 1fr; padding: 0 1; }
    #next { height: 6; }
    #trace { height: 2; }
    #live { height: 1fr; }
    #health { height: 3; }
    #log { height: 6; border-top: solid $accent; }
    #cmd { height: 3; }
    """
    BINDINGS = [
        Binding("f2", "do_next", "next item"),
        Binding("f3", "stop", "stop"),
        Binding("f4", "abort", "abort"),
        Binding("f5", "advice", "next best"),
        Binding("f10", "quit_session", "quit"),
    ]

    def __init__(self, controller: SessionController) -> None:
        """Show ``controller``'s session (its pump also says which of the graph's nodes died)."""
        super().__init__()
        self.ctl = controller
        self.offer = ""
        self._states: dict[str, ItemState] = {}

    def compose(self) -> ComposeResult:
        """The widgets (see the module docstring)."""
        yield Static(id="title")
        with Horizontal(id="top"):
            yield DataTable(id="plan", cursor_type="row", zebra_stripes=False)
            with Vertical(id="side"):
                yield Static(id="next")
                yield Sparkline([0.0], id="trace")
                yield Static(id="live")
                yield Static(id="health")
        yield RichLog(id="log", wrap=True, markup=False, max_lines=500)
        yield Input(placeholder="command (help) — F2 next item, F3 stop, F4 abort, F5 next best, F10 quit", id="cmd")
        yield Footer()

    def on_mount(self) -> None:
        """Fill the plan table, focus the command line, start the refresh timer."""
        table = self.query_one("#plan", DataTable)
        table.add_column("item", key="item", width=9)
        table.add_column("state", key="state", width=9)
        table.add_column("what", key="what", width=20)
        for item in self.ctl.session.plan.items:
            state = self.ctl.session.state(item)
            self._states[item.item_id] = state
            what = item.key if isinstance(item, ReadingItem) else f"{item.part} {item.measurement.pendulum}"
            table.add_row(item.item_id, Text(state.value, style=_STATE_STYLE[state]), what, key=item.item_id)
        self.query_one("#cmd", Input).focus()
        self._show([Reply("info", "bike_rig session: F2 does the next item; type 'help' for every command")])
        self.set_interval(TICK_S, self._tick)
        self._tick()

    # ------------------------------------------------------------------ refresh
    def _show(self, replies: list[Reply]) -> None:
        log = self.query_one("#log", RichLog)
        for r in replies:
            prefix = {"error": "error: ", "warning": "warning: "}.get(r.kind, "")
            log.write(Text(terminal_safe(prefix + r.text), style=_REPLY_STYLE.get(r.kind, "")))
            if r.kind == "result" and r.data.get("state") == ItemState.REDO.value:
                item = self.ctl.session.trials.get(str(r.data.get("trial_id", "")))
                if item is not None and item.item_id:
                    self.offer = item.item_id
                    log.write(Text(f"F2 records {item.item_id} again", style="bold red"))
        if any(r.kind == "done" for r in replies):
            self.exit(0)

    def _tick(self) -> None:
        self._show(self.ctl.pump())
        self._refresh_plan()
        self._refresh_side()

    def _refresh_plan(self) -> None:
        table = self.query_one("#plan", DataTable)
        for item_id, state in self.ctl.session.states().items():
            if self._states.get(item_id) != state:
                self._states[item_id] = state
                table.update_cell(item_id, "state", Text(state.value, style=_STATE_STYLE[state]))
        done, total = self.ctl.session.progress()
        s = self.ctl.session
        speeds = s.stability if s.complete else None
        title = terminal_safe(title_text(s.bicycle, done, total, speeds))
        self.query_one("#title", Static).update(Text(title, style="bold reverse"))

    def _refresh_health(self) -> None:
        board = self.ctl.health
        troubled = {node: standing.name for node, standing in self.ctl.stalls.troubled().items()}
        # (the reasons are in the log, said when a level changes or a node stalls, lags or catches up)
        line = board.line(reasons=False, instead=troubled)
        level = max((board.node_level(n) for n in {node_of(st) for st in board.statuses.values()}), default=Level.OK)
        if troubled:
            level = max(level, Level.WARN)
        style = {Level.OK: "green", Level.WARN: "bold yellow"}.get(level, "bold red")
        self.query_one("#health", Static).update(Text("Health: " + (line or "no /diagnostics yet"), style=style))

    def _refresh_side(self) -> None:
        self._refresh_health()
        s = self.ctl.session
        if self.offer and s.state(s.plan.item(self.offer)) != ItemState.REDO:
            self.offer = ""
        item = s.plan.item(self.offer) if self.offer else s.next_item()
        nxt = "Everything is ok or done." if item is None else item.instruction
        head = "REDO: " if item is not None and s.state(item) == ItemState.REDO else "Next: "
        missing = s.missing()
        tail = (
            f"\nMissing: {len(missing)} ({', '.join(missing[:6])}{'…' if len(missing) > 6 else ''})" if missing else ""
        )
        self.query_one("#next", Static).update(Text(terminal_safe(head + nxt + tail)))
        live = s.live_status(self.ctl.clock())
        trace = self.query_one("#trace", Sparkline)
        if live is None:
            self.query_one("#live", Static).update(Text("No trial recording.", style="dim"))
            return
        y = s.live.recent(4.0) if s.live is not None else None
        if y is not None and y.size:
            step = max(1, y.size // 60)
            trace.data = [float(v) for v in y[::step]]
        amp = f"{live.amplitude:.3g} rad/s" if math.isfinite(live.amplitude) else "—"
        text = Text(f"Recording {live.trial_id}: {live.seconds:.1f} s, {live.samples} samples, amplitude {amp}\n")
        for w in live.warnings:
            text.append(terminal_safe(f"⚠ {w}\n"), style="bold red")
        self.query_one("#live", Static).update(text)

    # ------------------------------------------------------------------ actions
    def on_input_submitted(self, event: Input.Submitted) -> None:
        """Run the typed command."""
        line = event.value.strip()
        event.input.value = ""
        if line:
            self._show([Reply("info", f"> {line}")])
            self._show(self.ctl.execute(line))

    def action_do_next(self) -> None:
        """F2: the offered redo, or the next item."""
        s = self.ctl.session
        item = s.plan.item(self.offer) if self.offer else s.next_item()
        if item is None:
            self._show([Reply("info", "every item of the plan is ok or done")])
        elif isinstance(item, TrialItem):
            self.offer = ""
            self._show(self.ctl.execute(f"start {item.item_id}"))
        else:
            cmd = self.query_one("#cmd", Input)
            cmd.value = f"reading {item.key} "
            cmd.cursor_position = len(cmd.value)
            cmd.focus()

    def action_stop(self) -> None:
        """F3: stop the recording trial."""
        self._show(self.ctl.execute("stop"))

    def action_abort(self) -> None:
        """F4: abort the recording trial."""
        self._show(self.ctl.execute("abort"))

    def action_advice(self) -> None:
        """F5: the next item and the next-best measurement."""
        self._show(self.ctl.execute("next"))

    def action_quit_session(self) -> None:
        """F10: quit (a recording trial is aborted first)."""
        self._show(self.ctl.execute("quit"))


def run_console(controller: SessionController) -> int:
    """Run the console until the operator quits; its exit status."""
    status = SessionApp(controller).run()
    return int(status or 0)
