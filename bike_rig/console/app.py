"""The operator's console: a textual app over :class:`~bike_rig.session.controller.SessionController`.

Lays itself out for any terminal from 80×24 up: title and connection, the plan with each item's
state, what to do next, the recording trial's live trace and warnings, the nodes' health from
``/diagnostics``, the log, and the command line (every plain-mode command). Keys: F2 next item,
F3 stop, F4 abort, F5 next best, PgUp/PgDn scroll the log, F10 or Ctrl-C quit (pressed twice; a
recording trial is aborted first). The screen is described in ``docs/session.md``.
"""

from __future__ import annotations

import math

from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.widgets import DataTable, Footer, Input, RichLog, Sparkline, Static

from ..core.textfmt import format_speed, terminal_safe
from ..pipeline.diagnostics import Level, node_of
from ..pipeline.model import StabilitySweep
from ..session.controller import Reply, SessionController
from ..session.plan import ItemState, ReadingItem, TrialItem

__all__ = ["SessionApp", "layout_rows", "run_console", "title_text"]

#: Screen refresh and graph polling period, s.
TICK_S = 0.05

_STATE_STYLE = {
    ItemState.TODO: "dim",
    ItemState.RECORDING: "bold yellow",
    ItemState.OK: "green",
    ItemState.REDO: "bold red",
    ItemState.DONE: "green",
}
#: Rows of the title, connection, command and footer lines.
_CHROME_ROWS = 4
#: Fewest rows of the plan and side panels (the side panel's widgets need them).
MIN_TOP_ROWS = 12
#: The plan and side panels' share of the rows left, beyond :data:`MIN_TOP_ROWS` (the log has the rest).
TOP_SHARE = 0.4

_REPLY_STYLE = {
    "error": "bold red",
    "warning": "yellow",
    "result": "bold",
    "ok": "cyan",
    "done": "green",
    "health": "magenta",
}


def title_text(bicycle: str, done: int, total: int, speeds: StabilitySweep | None) -> str:
    """The title line: bicycle, progress and, once there, both speeds with σ (compact: 80 columns).

    E.g. ``bike_rig · Browser · 68/68 done  weave 4.20±0.05  capsize 4.35±0.06 m/s``.
    """
    title = f"bike_rig · {bicycle} · {done}/{total} done"
    if speeds is None or speeds.weave is None or speeds.capsize is None:
        return title
    weave, capsize = format_speed(speeds.weave, compact=True), format_speed(speeds.capsize, compact=True)
    return f"{title}  weave {weave}  capsize {capsize} m/s"


def layout_rows(height: int, plan_rows: int) -> tuple[int, int]:
    """Rows of the plan/side panels and of the log (its border included) in a terminal ``height`` rows high.

    The panels have :data:`TOP_SHARE` of the rows (at least :data:`MIN_TOP_ROWS`, at most the
    whole plan and its header); the log grows with the window.
    """
    body = max(0, height - _CHROME_ROWS)
    top = min(max(MIN_TOP_ROWS, int(TOP_SHARE * body)), plan_rows + 1)
    top = min(top, max(0, body - 3))
    return top, body - top


class SessionApp(App[int]):
    """The console (see the module docstring)."""

    CSS = """
    #conn { height: 1; }
    #top { height: 12; }
    #plan { width: 44; }
    #side { width: 1fr; padding: 0 1; }
    #next { height: auto; max-height: 9; }
    #trace { height: 2; }
    #live { height: 1fr; }
    #health { height: auto; max-height: 3; }
    #log { height: 1fr; border-top: solid $accent; border-title-align: left; }
    #cmd { height: 1; border: none; padding: 0 1; }
    """
    BINDINGS = [
        Binding("f2", "do_next", "next item"),
        Binding("f3", "stop", "stop"),
        Binding("f4", "abort", "abort"),
        Binding("f5", "advice", "next best"),
        Binding("f10", "quit_session", "quit"),
        Binding("pageup", "log_scroll(-1)", "log ↑", priority=True, show=False),
        Binding("pagedown", "log_scroll(1)", "log ↓", priority=True, show=False),
        Binding("end", "log_end", priority=True, show=False),
        Binding("ctrl+c", "quit_session", "quit", priority=True, show=False),
    ]

    def __init__(self, controller: SessionController) -> None:
        """Show ``controller``'s session (its pump also says which of the graph's nodes died)."""
        super().__init__()
        self.ctl = controller
        self.offer = ""
        self._states: dict[str, ItemState] = {}
        self._rows: dict[str, int] = {}
        self._followed = ""
        self._quit_asked = False

    def compose(self) -> ComposeResult:
        """The widgets (see the module docstring)."""
        yield Static(id="title")
        yield Static(id="conn")
        with Horizontal(id="top"):
            yield DataTable(id="plan", cursor_type="row", zebra_stripes=False)
            with Vertical(id="side"):
                yield Static(id="next")
                yield Sparkline([0.0], id="trace")
                yield Static(id="live")
                yield Static(id="health")
        yield RichLog(id="log", wrap=True, markup=False, max_lines=500)
        yield Input(placeholder="command (help) — F2 next item, PgUp/PgDn scroll the log, F10 quit", id="cmd")
        yield Footer()

    def on_mount(self) -> None:
        """Fill the plan table, focus the command line, start the refresh timer."""
        table = self.query_one("#plan", DataTable)
        table.add_column("item", key="item", width=9)
        table.add_column("state", key="state", width=9)
        table.add_column("what", key="what", width=20)
        for row, item in enumerate(self.ctl.session.plan.items):
            self._rows[item.item_id] = row
            state = self.ctl.session.state(item)
            self._states[item.item_id] = state
            what = item.key if isinstance(item, ReadingItem) else f"{item.part} {item.measurement.pendulum}"
            table.add_row(item.item_id, Text(state.value, style=_STATE_STYLE[state]), what, key=item.item_id)
        self.query_one("#cmd", Input).focus()
        log = self.query_one("#log", RichLog)
        log.border_title = "log · PgUp/PgDn scroll, End the newest"
        conn = self.ctl.connection or "connected to the graph of this session"
        self.query_one("#conn", Static).update(Text(conn, style="italic"))
        self._fit_to(self.size.height)
        self._show([Reply("info", "bike_rig session: F2 does the next item; type 'help' for every command")])
        self.set_interval(TICK_S, self._tick)
        self._tick()

    # ------------------------------------------------------------------ layout
    def on_resize(self, event: events.Resize) -> None:
        """Share the rows between the panels and the log for the new size."""
        self._fit_to(event.size.height)

    def _fit_to(self, height: int) -> None:
        top, _log = layout_rows(height, len(self._rows))
        self.query_one("#top", Horizontal).styles.height = top

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
        s = self.ctl.session
        p = s.progress()
        speeds = s.stability if s.complete else None
        title = terminal_safe(title_text(s.bicycle, p.done, p.total, speeds))
        self.query_one("#title", Static).update(Text(title, style="bold reverse"))
        self._follow(table)

    def _follow(self, table: DataTable[object]) -> None:
        """Keep the recording, offered or next item in sight (moved to when it changes)."""
        s = self.ctl.session
        view = s.recording()
        item = s.plan.item(self.offer) if self.offer else s.next_item()
        target = view.item_id if view is not None and view.item_id else (item.item_id if item is not None else "")
        if target and target != self._followed and target in self._rows:
            self._followed = target
            table.move_cursor(row=self._rows[target], scroll=True)

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
        text = Text(terminal_safe(head + nxt + tail))
        if self._quit_asked:
            text = Text(
                "Quit? F10 or Ctrl-C again leaves (a recording trial is aborted); any command stays.",
                style="bold reverse",
            )
        elif self.ctl.held is not None:
            warning = "; ".join(self.ctl.held[1])
            key = self.ctl.held[0].key
            text = Text(terminal_safe(f"⚠ {warning}\n'keep' enters it, or 'reading {key} …' again"), style="bold red")
        self.query_one("#next", Static).update(text)
        live = s.live_status(self.ctl.clock())
        trace = self.query_one("#trace", Sparkline)
        trace.display = live is not None
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
        self._quit_asked = False
        self.action_log_end()
        if line:
            self._show([Reply("info", f"> {line}")])
            self._show(self.ctl.execute(line))
            self._refresh_plan()  # (the item's new state in the same frame as the reply)

    def action_do_next(self) -> None:
        """F2: the offered redo, or the next item."""
        self._quit_asked = False
        self.action_log_end()
        s = self.ctl.session
        item = s.plan.item(self.offer) if self.offer else s.next_item()
        if item is None:
            self._show([Reply("info", "every item of the plan is ok or done")])
        elif isinstance(item, TrialItem):
            self.offer = ""
            self._show(self.ctl.execute(f"start {item.item_id}"))
            self._refresh_plan()
        else:
            cmd = self.query_one("#cmd", Input)
            cmd.value = f"reading {item.key} "
            cmd.cursor_position = len(cmd.value)
            cmd.focus()

    def action_stop(self) -> None:
        """F3: stop the recording trial."""
        self._quit_asked = False
        self.action_log_end()
        self._show(self.ctl.execute("stop"))

    def action_abort(self) -> None:
        """F4: abort the recording trial."""
        self._quit_asked = False
        self.action_log_end()
        self._show(self.ctl.execute("abort"))

    def action_advice(self) -> None:
        """F5: the next item and the next-best measurement."""
        self._quit_asked = False
        self.action_log_end()
        self._show(self.ctl.execute("next"))

    def action_log_scroll(self, pages: int) -> None:
        """PgUp / PgDn: scroll the log by a page (it stays there while new lines come, until its end)."""
        log = self.query_one("#log", RichLog)
        if pages < 0:
            log.auto_scroll = False
            log.scroll_page_up(animate=False)
        else:
            log.scroll_page_down(animate=False)
            log.auto_scroll = log.scroll_y + log.scrollable_content_region.height >= log.virtual_size.height

    def action_log_end(self) -> None:
        """End: the log's newest line (and follow new ones again)."""
        log = self.query_one("#log", RichLog)
        log.auto_scroll = True
        log.scroll_end(animate=False, immediate=True)

    def action_quit_session(self) -> None:
        """F10 or Ctrl-C: ask; pressed again, quit (a recording trial is aborted first)."""
        if not self._quit_asked:
            self._quit_asked = True
            self._show([Reply("warning", "quit? F10 or Ctrl-C again leaves; any command stays")])
            return
        self._show(self.ctl.execute("quit"))


def run_console(controller: SessionController) -> int:
    """Run the console until the operator quits; its exit status."""
    status = SessionApp(controller).run()
    return int(status or 0)
