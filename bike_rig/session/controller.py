"""The operator's commands, shared by the console and plain mode.

One command per line; each gives one or more :class:`Reply` (a line of text and, for
``--json``, a dict). The commands and their help are :data:`COMMAND_HELP` (``help`` lists them).

:meth:`SessionController.pump` moves what the graph published into the session and gives
the replies it causes (a trial's result, a new warning, the set complete, a node stalled, behind
its input or caught up).
"""

from __future__ import annotations

import math
import shlex
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..core.period.advice import flag_advice
from ..core.suggest import did_you_mean
from ..core.symbols import PARAMETER_NAMES
from ..core.textfmt import format_speed, format_value_sigma
from ..pipeline.acquire import SampleBatch, TrialEventRecord
from ..pipeline.assemble import SessionParameters
from ..pipeline.diagnostics import HealthBoard, StatusReport
from ..pipeline.fit import TrialFit
from ..pipeline.fit_details import FitDetails
from ..pipeline.model import StabilitySweep
from ..pipeline.readings import ReadingEntry
from ..pipeline.stalls import StallWatch
from .plan import ItemState, ReadingItem, TrialItem
from .state import OperatorSession

__all__ = ["COMMANDS", "COMMAND_HELP", "GraphEvent", "GraphLink", "Reply", "SessionController", "StartReply"]

GraphEvent = (
    TrialEventRecord
    | SampleBatch
    | TrialFit
    | FitDetails
    | SessionParameters
    | StabilitySweep
    | ReadingEntry
    | StatusReport
)

#: Every command: its usage and what it does (``help`` prints them).
COMMAND_HELP: tuple[tuple[str, str], ...] = (
    (
        "start [ITEM] [SECONDS]",
        "start a trial: the next trial to do or redo, or ITEM (TtB2#3); SECONDS overrides the plan's duration",
    ),
    ("stop", "stop the recording trial (its result follows)"),
    ("abort", "abort the recording trial (ABORT is recorded; the item stays REDO)"),
    (
        "reading KEY VALUE SIGMA",
        "enter a static reading (degrees only where the key says so); again for a "
        "correction: the newer wins, both are recorded; one that looks wrong (a unit?) is held until answered",
    ),
    ("keep", "enter the reading held for its warning as it is"),
    ("status", "what the session is connected to, progress, the recording trial, what is missing, the result"),
    ("next", "the next item with its instruction, and the next-best measurement"),
    ("best", "the ranking of open and repeatable items by σ reduction"),
    ("plan", "every item with its state"),
    ("params", "the 25 parameters with σ (once complete)"),
    ("help", "this list"),
    ("quit", "leave (a recording trial is aborted first)"),
)
COMMANDS = tuple(usage.split()[0] for usage, _ in COMMAND_HELP)


@dataclass(frozen=True)
class StartReply:
    """The driver's answer to a start request.

    Attributes:
        accepted: The trial records.
        trial_id: Its id (when accepted).
        message: The driver's message (the reason when refused).
    """

    accepted: bool
    trial_id: str
    message: str


class GraphLink(Protocol):
    """What the controller needs of the live graph (ROS: :mod:`bike_rig.ros.nodes.session_link`)."""

    def start_trial(self, item: TrialItem, duration_s: float) -> StartReply:
        """Ask the driver to start a trial of ``item`` lasting ``duration_s`` (s)."""
        ...

    def stop_trial(self, trial_id: str, abort: bool) -> tuple[bool, str]:
        """Ask the driver to stop (or abort) a trial: (accepted, message)."""
        ...

    def send_reading(self, entry: ReadingEntry) -> None:
        """Publish a reading entry."""
        ...

    def events(self) -> list[GraphEvent]:
        """What the graph published since the last call, in arrival order."""
        ...


@dataclass(frozen=True)
class Reply:
    """One line of output.

    Attributes:
        kind: ``ok``, ``error``, ``warning``, ``result``, ``info``, ``health`` (a node's
            ``/diagnostics`` level changed, or it stalled, fell behind its input or caught up;
            ``data`` has ``node`` and ``level``, the latter also ``standing`` and ``seconds``)
            or ``done``.
        text: The line.
        data: The same for ``--json``.
    """

    kind: str
    text: str
    data: dict[str, Any] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        """The reply as a JSON object."""
        return {"kind": self.kind, "text": self.text, **self.data}


class CommandError(Exception):
    """A command that cannot be carried out (the message says why)."""


def _speed(name: str, s: Any) -> str:
    return f"{name} {format_speed(s, name)}"


@dataclass
class SessionController:
    """Commands on a session through a link to the graph.

    Attributes:
        session: The session state.
        link: The live graph.
        clock: Wall clock, s (monotonic).
        check_reading: ``(key, value_text, sigma_text, session) -> (ReadingEntry, warnings)``;
            raises ``ValueError`` with a one-line reason for a reading that cannot be taken.
        rank: ``(session) -> [(item_id, text)]``, best first: the next-best measurements.
        watch: ``() -> [(node, line)]``: the graph's nodes that died since the last call
            (:class:`~bike_rig.ros.graphwatch.NodeWatch`), said as errors by :meth:`pump`.
        ended: ``() -> nodes``: the graph's nodes whose process has ended now (not stalled:
            gone); unknown when joining a graph (none).
        stalls: The nodes stalled or behind their input (a line when that changes).
    """

    session: OperatorSession
    link: GraphLink
    check_reading: Callable[[str, str, str, OperatorSession], tuple[ReadingEntry, list[str]]]
    rank: Callable[[OperatorSession], list[tuple[str, str]]] = lambda _s: []
    clock: Callable[[], float] = time.monotonic
    watch: Callable[[], list[tuple[str, str]]] = lambda: []
    ended: Callable[[], Collection[str]] = lambda: ()
    quit_requested: bool = False
    #: What the session is connected to (source, bus, ROS domain, the ``bike-rig view`` line).
    connection: str = ""
    #: A reading held for its plausibility warnings, with them, until ``keep`` or a new entry of its key.
    held: tuple[ReadingEntry, tuple[str, ...]] | None = None
    _warned: set[str] = field(default_factory=set)
    _announced: tuple[float, ...] = ()
    _resume_note: str = ""
    _pending: list[Reply] = field(default_factory=list)
    #: When the last parameter set or stability sweep arrived (``clock``), s.
    updated_at: float = 0.0
    #: The nodes' latest ``/diagnostics`` statuses (a line when a node's worst level changes).
    health: HealthBoard = field(default_factory=HealthBoard)
    stalls: StallWatch = field(init=False)

    def __post_init__(self) -> None:
        """Follow the nodes' heartbeats on the controller's clock."""
        self.stalls = StallWatch(clock=lambda: self.clock())

    # ------------------------------------------------------------------ resume
    def resume(self, trial_ids: Sequence[str], entries: Sequence[ReadingEntry], note: str) -> None:
        """Continue an interrupted session: its recorded trials are coming back from the graph.

        The driver streams the recorded trials ``trial_ids`` again (its ``resume`` parameter);
        each recorded reading entry is published again here, as it was (stamp and note kept),
        so that the parameter node applies it and the new bag holds the whole session. Trials
        cannot be started until every recorded one is back (:attr:`resumed`). The next
        :meth:`pump` announces the resume (``note``: what is resumed, from where), and a later
        one that every recorded trial is back.
        """
        self.session.resume(trial_ids)
        for entry in entries:
            self.link.send_reading(entry)
            self.session.on_reading(entry)  # its echo from the graph may come seconds later
        self._resume_note = note
        back, total = self.session.resuming
        self._pending.append(
            Reply("info", f"resuming {note}: {back}/{total} recorded trials back", {"resuming": [back, total]})
        )

    @property
    def resumed(self) -> bool:
        """Every recorded trial of a resumed session is back (True when not resuming)."""
        back, total = self.session.resuming
        return back >= total

    def _resume_replies(self) -> list[Reply]:
        """The announcement that the resumed session's recorded trials are back (once)."""
        if not self._resume_note or not self.resumed:
            return []
        note, self._resume_note = self._resume_note, ""
        total = len(self.session.resumed)
        return [Reply("info", f"resumed {note}: all {total} recorded trials are back", {"resumed": total})]

    def connect(self, text: str, data: dict[str, Any]) -> None:
        """Say what the session is connected to (``status`` repeats it; the next :meth:`pump` says it once)."""
        self.connection = text
        self._pending.append(Reply("info", text, {"connection": data}))

    # ------------------------------------------------------------------ commands
    def execute(self, line: str) -> list[Reply]:
        """Carry out one command line; errors become ``error`` replies (never raise)."""
        try:
            words = shlex.split(line)
        except ValueError as exc:
            return [Reply("error", f"cannot read the command: {exc}")]
        if not words:
            return []
        name, args = words[0].lower(), words[1:]
        handler = getattr(self, f"_cmd_{name}", None)
        if handler is None or name not in COMMANDS:
            hint = did_you_mean(name, COMMANDS) or f" (commands: {', '.join(COMMANDS)})"
            return [Reply("error", f"unknown command '{name}'{hint}")]
        try:
            replies: list[Reply] = handler(args)
            return replies
        except CommandError as exc:
            return [Reply("error", str(exc), {"command": name})]

    def _cmd_start(self, args: Sequence[str]) -> list[Reply]:
        if not self.resumed:
            back, total = self.session.resuming
            raise CommandError(f"the recorded trials are still coming back ({back}/{total}): start again in a moment")
        if self.session.recording() is not None:
            raise CommandError(f"trial {self.session.recording().trial_id} is recording: stop or abort it first")  # type: ignore[union-attr]
        item: Any = self.session.next_trial() if not args or _is_number(args[0]) else None
        if args and not _is_number(args[0]):
            try:
                item = self.session.plan.item(args[0])
            except KeyError as exc:
                raise CommandError(str(exc.args[0])) from None
            if not isinstance(item, TrialItem):
                raise CommandError(f"{args[0]} is a reading: enter it with 'reading {args[0]} VALUE SIGMA'")
        if item is None:
            raise CommandError("every trial of the plan is ok; give an item to record one again (e.g. start TtB2#1)")
        rest = args[1:] if args and not _is_number(args[0]) else args
        duration = float(rest[0]) if rest else item.duration_s
        if not (math.isfinite(duration) and duration > 0):
            raise CommandError(f"duration {rest[0]} s: must be a positive number of seconds")
        reply = self.link.start_trial(item, duration)
        if not reply.accepted:
            raise CommandError(f"the driver refused {item.item_id}: {reply.message}")
        self.session.expect(reply.trial_id, item.item_id, self.clock())
        data = {"command": "start", "item": item.item_id, "trial_id": reply.trial_id, "duration_s": duration}
        return [Reply("ok", f"recording {item.item_id} as {reply.trial_id} ({duration:g} s): {item.instruction}", data)]

    def _stop(self, abort: bool) -> list[Reply]:
        view = self.session.recording()
        if view is None:
            raise CommandError("no trial is recording")
        accepted, message = self.link.stop_trial(view.trial_id, abort)
        if not accepted:
            raise CommandError(f"the driver refused to {'abort' if abort else 'stop'} {view.trial_id}: {message}")
        what = "abort" if abort else "stop"
        return [Reply("ok", message, {"command": what, "trial_id": view.trial_id})]

    def _cmd_stop(self, args: Sequence[str]) -> list[Reply]:
        return self._stop(False)

    def _cmd_abort(self, args: Sequence[str]) -> list[Reply]:
        return self._stop(True)

    def _cmd_reading(self, args: Sequence[str]) -> list[Reply]:
        if len(args) != 3:
            raise CommandError(
                "usage: reading KEY VALUE SIGMA (e.g. reading mR 3.02 0.02; degrees only for gamma, alpha*)"
            )
        try:
            entry, warnings = self.check_reading(args[0], args[1], args[2], self.session)
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        if self.held is not None and self.held[0].key == entry.key:
            self.held = None  # answered by a new entry
        if warnings:
            self.held = (entry, tuple(warnings))
            data = {"command": "reading", "key": entry.key, "value": entry.value, "sigma": entry.sigma, "held": True}
            out = [Reply("warning", w, {"key": entry.key}) for w in warnings]
            return out + [Reply("warning", self.held_line(), data)]
        return self._enter(entry)

    def held_line(self) -> str:
        """What to do about the held reading ("" when none)."""
        if self.held is None:
            return ""
        e = self.held[0]
        return (
            f"{e.key} = {e.value:g} ± {e.sigma:g} is held, not entered: 'keep' enters it as it is, "
            f"'reading {e.key} VALUE SIGMA' enters another"
        )

    def _enter(self, entry: ReadingEntry) -> list[Reply]:
        corrected = entry.key in self.session.readings
        self.link.send_reading(entry)
        self.session.on_reading(entry)
        verb = "corrected" if corrected else "entered"
        data = {"command": "reading", "key": entry.key, "value": entry.value, "sigma": entry.sigma}
        return [Reply("ok", f"{verb} {entry.key} = {entry.value:g} ± {entry.sigma:g}", data)]

    def _cmd_keep(self, args: Sequence[str]) -> list[Reply]:
        if self.held is None:
            raise CommandError("no reading is held (a reading is held when it looks wrong)")
        entry, _ = self.held
        self.held = None
        return self._enter(entry)

    def _cmd_status(self, args: Sequence[str]) -> list[Reply]:
        p = self.session.progress()
        out = [Reply("info", self.connection, {"connection": self.connection})] if self.connection else []
        out.append(
            Reply(
                "info",
                f"progress {p.line()}",
                {
                    "done": p.done,
                    "total": p.total,
                    "trials_done": p.trials_done,
                    "trials": p.trials,
                    "readings_done": p.readings_done,
                    "readings": p.readings,
                },
            )
        )
        if self.held is not None:
            out.append(Reply("warning", self.held_line(), {"key": self.held[0].key, "held": True}))
        if not self.resumed:
            back, n = self.session.resuming
            out.append(Reply("info", f"resuming: {back}/{n} recorded trials back", {"resuming": [back, n]}))
        live = self.session.live_status(self.clock())
        if live is not None:
            amp = f", amplitude {live.amplitude:.3g} rad/s" if math.isfinite(live.amplitude) else ""
            out.append(
                Reply(
                    "info",
                    f"recording {live.trial_id}: {live.samples} samples ({live.seconds:.1f} s){amp}",
                    {"recording": live.trial_id, "samples": live.samples},
                )
            )
            out += [Reply("warning", w) for w in live.warnings]
        out += [Reply("warning", t) for t in self.stalls.troubles()]
        out += self._result_replies()
        return out

    def _result_replies(self) -> list[Reply]:
        s = self.session
        if not s.complete:
            missing = s.missing()
            shown = ", ".join(missing[:12]) + (f" … ({len(missing)} in all)" if len(missing) > 12 else "")
            lacking = s.lacking()
            # (unaccounted: usable trials the parameter node's set does not hold yet)
            open_items = {"missing": list(missing), "lacking": list(lacking), "unaccounted": list(s.unaccounted())}
            out = [Reply("info", f"missing: {shown or 'nothing'}", open_items)]
            if not missing and lacking:  # (every item done, yet the parameter node still lacks these)
                text = f"the parameter set still lacks {', '.join(lacking)}"
                out.append(Reply("info", text, {"lacking": list(lacking)}))
            return out
        out = [Reply("info", "parameter set complete", {"complete": True})]
        if s.stability is not None:
            w, c = s.stability.weave, s.stability.capsize
            data = {
                "weave": None if w is None else [w.speed, w.sigma],
                "capsize": None if c is None else [c.speed, c.sigma],
            }
            out.append(Reply("info", f"{_speed('weave', w)}, {_speed('capsize', c)}", data))
        return out

    def _cmd_next(self, args: Sequence[str]) -> list[Reply]:
        item = self.session.next_item()
        out = []
        if item is None:
            out.append(Reply("info", "every item of the plan is ok or done", {"next": None}))
        else:
            state = self.session.state(item).value
            out.append(Reply("info", f"next ({state}): {item.instruction}", {"next": item.item_id, "state": state}))
        ranked = self.rank(self.session)
        if ranked:
            out.append(Reply("info", f"next best: {ranked[0][1]}", {"best": ranked[0][0]}))
        return out

    def _cmd_best(self, args: Sequence[str]) -> list[Reply]:
        ranked = self.rank(self.session)
        if not ranked:
            return [Reply("info", "no ranking yet: the parameter set must be complete first", {"ranking": []})]
        return [
            Reply("info", f"{k + 1}. {text}", {"rank": k + 1, "item": item})
            for k, (item, text) in enumerate(ranked[:10])
        ]

    def _cmd_plan(self, args: Sequence[str]) -> list[Reply]:
        out = []
        for item in self.session.plan.items:
            state = self.session.state(item)
            kind = "reading" if isinstance(item, ReadingItem) else "trial"
            out.append(
                Reply(
                    "info", f"{item.item_id:10s} {state.value:9s} {kind}", {"item": item.item_id, "state": state.value}
                )
            )
        return out

    def _cmd_params(self, args: Sequence[str]) -> list[Reply]:
        p = self.session.parameters
        if p is None or not p.complete:
            raise CommandError("the parameter set is not complete yet (see 'status' for what is missing)")
        ps = p.complete_parameters().parameters
        out = []
        for name in PARAMETER_NAMES:
            v, s = ps.value(name), ps.sigma(name)
            value, sigma = format_value_sigma(v, s, digits=None)
            out.append(Reply("info", f"{name:4s} {value:>12} ± {sigma}", {"name": name, "value": v, "sigma": s}))
        return out

    def _cmd_help(self, args: Sequence[str]) -> list[Reply]:
        width = max(len(usage) for usage, _ in COMMAND_HELP)
        return [
            Reply("info", f"{usage:<{width}}  {what}", {"command": usage.split()[0]}) for usage, what in COMMAND_HELP
        ]

    def _cmd_quit(self, args: Sequence[str]) -> list[Reply]:
        out = []
        if self.session.recording() is not None:
            out += self._stop(True)
        self.quit_requested = True
        return out + [Reply("done", "bye")]

    # ------------------------------------------------------------------ graph
    def _apply(self, ev: GraphEvent, now: float) -> list[Reply]:
        """Apply one thing the graph published; the replies it makes."""
        s = self.session
        if isinstance(ev, SampleBatch):
            s.on_samples(ev, now)
        elif isinstance(ev, TrialEventRecord):
            before = len(s.results)
            s.on_trial_event(ev, now)
            return [Reply("result", r, {"trial_id": ev.trial_id, "state": "REDO"}) for r in s.results[before:]]
        elif isinstance(ev, FitDetails):
            late = s.on_fit_details(ev)  # (after its result line: what it adds)
            return [Reply("info", late, {"trial_id": ev.trial_id, "damping_model": ev.damping_model})] if late else []
        elif isinstance(ev, TrialFit):
            line = s.on_period(ev)
            if line is None:
                return [Reply("warning", s.foreign[-1], {"trial_id": ev.trial_id, "foreign": True})]
            state = ItemState.OK.value if ev.usable else ItemState.REDO.value
            return [Reply("result", line, _fit_data(ev, state))]
        elif isinstance(ev, SessionParameters):
            s.on_parameters(ev)
            self.updated_at = now
        elif isinstance(ev, StabilitySweep):
            s.on_stability(ev)
            self.updated_at = now
        elif isinstance(ev, StatusReport):
            self.stalls.heard(ev.statuses)
            return [
                Reply("health", f"health: {node} {level.name}: {message}", {"node": node, "level": level.name})
                for node, level, message in self.health.update(ev.statuses)
            ]
        elif isinstance(ev, ReadingEntry):
            if not any(e.stamp_ns == ev.stamp_ns and e.value == ev.value for e in s.readings.get(ev.key, [])):
                s.on_reading(ev)
        return []

    def _new_warnings(self, now: float) -> list[Reply]:
        """Each live warning once per trial and kind (its first words), as it appears."""
        live = self.session.live_status(now)
        if live is None:
            return []
        out = []
        for w in live.warnings:
            tag = f"{live.trial_id}:{w.split(' for ')[0][:40]}"
            if tag not in self._warned:
                self._warned.add(tag)
                out.append(Reply("warning", f"{live.trial_id}: {w}", {"trial_id": live.trial_id}))
        return out

    def pump(self) -> list[Reply]:
        """Apply what the graph published; replies for new results, warnings, dead nodes and completion."""
        out, self._pending = self._pending, []
        now = self.clock()
        s = self.session
        for ev in self.link.events():
            out += self._apply(ev, now)
        out += self._new_warnings(now)
        deaths = self.watch()
        for node, _ in deaths:
            self.stalls.forget(node)  # (restarted or gone: not stalled)
        out += [Reply("error", line, {"node": node}) for node, line in deaths]
        out += [
            Reply(
                "health",
                c.text,
                {"node": c.node, "level": c.level.name, "standing": c.standing.value, "seconds": c.seconds},
            )
            for c in self.stalls.check(self.ended())
        ]
        out += self._resume_replies()
        if s.complete and s.stability is not None:
            sw, sc = s.stability.weave, s.stability.capsize
            speeds = tuple(x for v in (sw, sc) if v is not None for x in (v.speed, v.sigma))
            if speeds != self._announced:  # the result as it forms: after every change
                self._announced = speeds
                out += self._result_replies()
        return out


def _fit_data(fit: TrialFit, state: str) -> dict[str, Any]:
    return {
        "trial_id": fit.trial_id,
        "key": fit.measurement_key,
        "period": fit.period,
        "period_sigma": fit.period_sigma,
        "r2": fit.fit.r2,
        "flags": list(fit.flag_codes),
        "reasons": list(fit.flag_reasons),
        "advice": [flag_advice(c) for c in fit.flag_codes],
        "state": state,
    }


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
