"""The operator's session as it stands: the plan's states, the trials, the readings, the result.

:class:`OperatorSession` is fed what the live graph publishes (records of
:mod:`bike_rig.pipeline`) and the readings entered, and answers what the console shows: each
plan item's state, the next item, the live trial, each trial's result line, what is missing, and
the parameters and speeds once complete. No ROS (``nodes/session_link.py`` feeds it). Trial items
match trials by key and repeat (``TtB2#3``): a redo replaces the earlier in the item's state,
while every trial stays in :attr:`OperatorSession.trials`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..core.period.advice import flag_advice
from ..core.period.result import FlagCode
from ..core.textfmt import format_uncertain
from ..pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from ..pipeline.assemble import SessionParameters
from ..pipeline.fit import TrialFit
from ..pipeline.fit_details import FitDetails, join_details
from ..pipeline.model import StabilitySweep
from ..pipeline.readings import ReadingEntry
from .live import LiveStatus, LiveTrace
from .plan import ItemState, PlanItem, ReadingItem, SessionPlan, TrialItem

__all__ = ["OperatorSession", "Progress", "SessionTrialView", "flag_text", "result_line"]


@dataclass
class SessionTrialView:
    """One trial of the session as the console tracks it.

    Attributes:
        trial_id: The trial.
        item_id: The plan item it belongs to ("" when it matches none).
        key: Its measurement key.
        sample_rate_hz: From its START (or its first gyro batch, when the START is late), Hz.
        state: RECORDING, then OK or REDO.
        fit: The period estimate, once published.
        aborted: Its end was an ABORT.
        stopped: A STOP or ABORT was seen.
        started: This console started it (the driver accepted its start).
    """

    trial_id: str
    item_id: str
    key: str
    sample_rate_hz: float = math.nan
    state: ItemState = ItemState.RECORDING
    fit: TrialFit | None = None
    aborted: bool = False
    stopped: bool = False
    started: bool = False


def _unannounced(fit: TrialFit) -> bool:
    """Whether the fitter had no START for ``fit``'s samples (its flags say so)."""
    return bool({FlagCode.NO_START.value, FlagCode.UNKNOWN_TRIAL.value} & set(fit.flag_codes))


def _known_rate(rate_hz: float) -> bool:
    """Whether ``rate_hz`` is a sample rate (finite and positive), not a placeholder."""
    return math.isfinite(rate_hz) and rate_hz > 0


def _cycles(fit: TrialFit, rate_hz: float) -> float:
    """Cycles in the fit's window, at the fit's own sample rate when it has one, else at ``rate_hz``."""
    if _known_rate(fit.sample_rate_hz):
        rate_hz = fit.sample_rate_hz
    n = fit.window[1] - fit.window[0]
    if not (_known_rate(rate_hz) and math.isfinite(fit.period) and fit.period > 0 and n > 0):
        return math.nan
    return n / rate_hz / fit.period


def flag_text(code: str, reason: str) -> str:
    """A flag as ``code: reason → advice``, the advice without what the reason already says.

    E.g. ``aborted: the trial was aborted → redo it``; ``too_few_cycles: … : record longer``
    (the advice "record longer …" is already the reason's).
    """
    advice = flag_advice(code)
    head, sep, rest = advice.partition(": ")
    if head.split(" (")[0].strip().lower() in reason.lower():
        advice = rest if sep else ""
    return f"{code}: {reason} → {advice}" if advice else f"{code}: {reason}"


@dataclass(frozen=True)
class Progress:
    """Where the plan stands: one definition for the console, plain mode and ``status``.

    Attributes:
        done: Plan items ok or done.
        total: Plan items.
        trials_done: Trial items ok.
        trials: Trial items.
        readings_done: Reading items entered (typed or from ``--readings``).
        readings: Reading items.
        open: The items still to do or redo (recording ones too), in plan order.
    """

    done: int
    total: int
    trials_done: int
    trials: int
    readings_done: int
    readings: int
    open: tuple[str, ...]

    def line(self) -> str:
        """E.g. ``39/68 items (trials 10/39, readings 29/29)``."""
        return (
            f"{self.done}/{self.total} items (trials {self.trials_done}/{self.trials}, "
            f"readings {self.readings_done}/{self.readings})"
        )


def result_line(view: SessionTrialView) -> str:
    """The trial's result in one line: period ± σ, cycles, r², then ok, or REDO with every flag's reason and advice.

    What the fit found beyond the period follows, when there is something to say: the damping
    model when not Eq 23's, the small-swing period, a period that moves along the record
    (:meth:`~bike_rig.pipeline.fit_details.FitDetails.summary`).

    A flag reads ``code: reason → advice`` (:func:`flag_text`; the advice is
    :func:`~bike_rig.core.period.advice.flag_advice`'s, which ``bike-rig run`` prints too).
    """
    fit = view.fit
    head = f"{view.item_id or view.key} {view.trial_id}:"
    if fit is None:
        return f"{head} aborted" if view.aborted else f"{head} waiting for its fit"
    cycles = _cycles(fit, view.sample_rate_hz)
    counted = f", {cycles:.0f} cycles" if math.isfinite(cycles) else ""  # (none: neither event nor batch told the rate)
    numbers = f"T = {format_uncertain(fit.period, fit.period_sigma, 's')}{counted}, r² {fit.fit.r2:.5f}"
    numbers = numbers if fit.valid else "no period"
    details = FitDetails.of(fit).summary(fit.period) if fit.valid else ""
    more = f"; {details}" if details else ""
    if fit.usable:
        return f"{head} {numbers} — ok{more}"
    reasons = "; ".join(flag_text(c, r) for c, r in zip(fit.flag_codes, fit.flag_reasons, strict=True))
    reasons = reasons or "no period"
    return f"{head} {numbers} — REDO ({reasons}){more}"


@dataclass
class OperatorSession:
    """The session's state (see the module docstring).

    Attributes:
        plan: The session plan.
        bicycle: The bicycle's name.
        source: The gyro source's name (for the no-samples warning).
        foreign: Lines on results ignored as another process's (see :meth:`on_period`).
    """

    plan: SessionPlan
    bicycle: str = ""
    source: str = "gyro"
    trials: dict[str, SessionTrialView] = field(default_factory=dict)
    readings: dict[str, list[ReadingEntry]] = field(default_factory=dict)
    parameters: SessionParameters | None = None
    stability: StabilitySweep | None = None
    live: LiveTrace | None = None
    results: list[str] = field(default_factory=list)
    foreign: list[str] = field(default_factory=list)
    resumed: tuple[str, ...] = ()
    _item_trial: dict[str, str] = field(default_factory=dict)
    _details: dict[str, FitDetails] = field(default_factory=dict)  # the newest by trial id

    # ------------------------------------------------------------------ feeding
    def resume(self, trial_ids: Sequence[str]) -> None:
        """The recorded trials of an interrupted session are coming back (see :attr:`resuming`)."""
        self.resumed = tuple(trial_ids)

    @property
    def resuming(self) -> tuple[int, int]:
        """(recorded trials back, recorded trials): back is a result, or aborted."""
        back = 0
        for trial_id in self.resumed:
            view = self.trials.get(trial_id)
            back += view is not None and (view.fit is not None or view.aborted)
        return back, len(self.resumed)

    def expect(self, trial_id: str, item_id: str, now_wall_s: float) -> None:
        """The driver accepted a start of ``item_id`` as ``trial_id``: track it from now."""
        item = self.plan.item(item_id)
        key = item.key
        self.trials[trial_id] = SessionTrialView(trial_id, item_id, key, started=True)
        self._item_trial[item_id] = trial_id
        self.live = LiveTrace(trial_id, now_wall_s, source=self.source)

    def _item_for(self, event: TrialEventRecord) -> str:
        wanted = f"{event.measurement_key}#{event.repeat}"
        ids = {i.item_id for i in self.plan.trials}
        if wanted in ids:
            return wanted
        free = [i.item_id for i in self.plan.trials if i.key == event.measurement_key]
        return next((i for i in free if i not in self._item_trial), free[-1] if free else "")

    def on_trial_event(self, event: TrialEventRecord, now_wall_s: float) -> None:
        """A START, STOP or ABORT from the driver."""
        view = self.trials.get(event.trial_id)
        if view is None:
            item_id = self._item_for(event)
            view = SessionTrialView(event.trial_id, item_id, event.measurement_key)
            self.trials[event.trial_id] = view
            if item_id:
                self._item_trial[item_id] = event.trial_id
        if math.isfinite(event.sample_rate_hz):
            view.sample_rate_hz = event.sample_rate_hz
        if event.kind == TrialEventKind.START:
            if event.trial_id in self.resumed:
                return  # a recorded trial coming back: nothing to watch live
            if self.live is None or self.live.trial_id != event.trial_id:
                self.live = LiveTrace(event.trial_id, now_wall_s, source=self.source)
            return
        view.stopped = True
        view.aborted = event.kind == TrialEventKind.ABORT
        if view.aborted:
            view.state = ItemState.REDO
            self.results.append(f"{view.item_id or view.key} {event.trial_id}: aborted — REDO")
        if self.live is not None and self.live.trial_id == event.trial_id:
            self.live = None

    def on_samples(self, batch: SampleBatch, now_wall_s: float) -> None:
        """A gyro batch: feeds the live trace of the recording trial (and gives its rate, if its START did not)."""
        if self.live is not None and batch.trial_id == self.live.trial_id:
            self.live.add(batch.rates, batch.sample_rate_hz, now_wall_s, batch.first_index)
            view = self.trials.get(batch.trial_id)
            if view is not None and math.isnan(view.sample_rate_hz) and _known_rate(batch.sample_rate_hz):
                view.sample_rate_hz = batch.sample_rate_hz  # (its cycles need it: the result may come first)

    def on_period(self, fit: TrialFit) -> str | None:
        """A period estimate: the trial's state becomes OK or REDO. Returns its result line.

        A result without a START of its own (``no_start``, ``unknown_trial``) for a trial this
        console started is another process's under the same id: the fitter publishes it before
        the driver's START reaches it. It is not this trial's result; None, and :attr:`foreign`
        has the line saying so. (A trial only seen, e.g. resumed, takes whatever result comes.)
        """
        view = self.trials.get(fit.trial_id)
        if view is not None and view.started and _unannounced(fit):
            self.foreign.append(
                f"{fit.trial_id}: a result without a START from another process than the driver's ignored "
                f"({', '.join(fit.flag_codes)})"
            )
            return None
        if view is None:
            event = TrialEventRecord(TrialEventKind.STOP, fit.trial_id, fit.measurement_key)
            item_id = self._item_for(event)
            view = SessionTrialView(fit.trial_id, item_id, fit.measurement_key, stopped=True)
            self.trials[fit.trial_id] = view
            if item_id:
                self._item_trial.setdefault(item_id, fit.trial_id)
        if math.isnan(view.sample_rate_hz) and math.isfinite(fit.sample_rate_hz):
            view.sample_rate_hz = fit.sample_rate_hz
        view.fit = join_details(fit, self._details)
        view.state = ItemState.OK if fit.usable else ItemState.REDO
        if self.live is not None and self.live.trial_id == fit.trial_id:
            self.live = None  # its result proves it stopped (the STOP may arrive after: another topic)
        line = result_line(view)
        self.results.append(line)
        return line

    def on_fit_details(self, details: FitDetails) -> str:
        """What a trial's fit found beyond its period: joined to its estimate (before or after it).

        Returns:
            When its result line was already given: what it adds, as one line ("" when nothing).
        """
        self._details[details.trial_id] = details
        view = self.trials.get(details.trial_id)
        if view is None or view.fit is None:
            return ""
        view.fit = details.apply(view.fit)
        summary = details.summary(view.fit.period) if view.fit.valid else ""
        return f"{view.item_id or view.key} {view.trial_id}: {summary}" if summary else ""

    def on_reading(self, entry: ReadingEntry) -> None:
        """A reading entered (its newest entry wins; every entry is kept)."""
        self.readings.setdefault(entry.key, []).append(entry)

    def on_parameters(self, result: SessionParameters) -> None:
        """The parameter node's latest result."""
        self.parameters = result

    def on_stability(self, sweep: StabilitySweep) -> None:
        """The model node's latest critical speeds."""
        self.stability = sweep

    # ------------------------------------------------------------------ reading
    def reading(self, key: str) -> ReadingEntry | None:
        """The newest entry of ``key``, or None."""
        entries = self.readings.get(key)
        return max(entries, key=lambda e: e.stamp_ns) if entries else None

    def state(self, item: PlanItem) -> ItemState:
        """Where ``item`` stands."""
        if isinstance(item, ReadingItem):
            return ItemState.DONE if item.key in self.readings else ItemState.TODO
        trial_id = self._item_trial.get(item.item_id)
        if trial_id is None:
            return ItemState.TODO
        view = self.trials[trial_id]
        if view.state == ItemState.RECORDING and view.stopped and view.fit is None:
            return ItemState.RECORDING  # stopped, its fit on the way
        return view.state

    def states(self) -> Mapping[str, ItemState]:
        """Every item's state by item id, in plan order."""
        return {i.item_id: self.state(i) for i in self.plan.items}

    def progress(self) -> Progress:
        """Where the plan stands (:class:`Progress`)."""
        states = self.states()
        finished = {i for i, s in states.items() if s in (ItemState.OK, ItemState.DONE)}
        trials = [i.item_id for i in self.plan.trials]
        readings = [i.item_id for i in self.plan.readings]
        return Progress(
            done=len(finished),
            total=len(states),
            trials_done=sum(i in finished for i in trials),
            trials=len(trials),
            readings_done=sum(i in finished for i in readings),
            readings=len(readings),
            open=tuple(i for i in states if i not in finished),
        )

    def next_item(self) -> PlanItem | None:
        """The first item to do or redo, in plan order (None when everything is ok or done)."""
        for item in self.plan.items:
            if self.state(item) in (ItemState.TODO, ItemState.REDO):
                return item
        return None

    def next_trial(self) -> TrialItem | None:
        """The first trial item to do or redo."""
        for item in self.plan.trials:
            if self.state(item) in (ItemState.TODO, ItemState.REDO):
                return item
        return None

    def recording(self) -> SessionTrialView | None:
        """The trial recording now, if any."""
        if self.live is None:
            return None
        return self.trials.get(self.live.trial_id)

    def live_status(self, now_wall_s: float) -> LiveStatus | None:
        """The recording trial's live status and warnings."""
        return None if self.live is None else self.live.status(now_wall_s)

    def missing(self) -> tuple[str, ...]:
        """The plan items still to do or redo (:attr:`Progress.open`: the same count everywhere)."""
        return self.progress().open

    def lacking(self) -> tuple[str, ...]:
        """What the parameter node's set still lacks (its keys; empty before its first result)."""
        return () if self.parameters is None else tuple(self.parameters.missing)

    @property
    def complete(self) -> bool:
        """The parameter set is complete."""
        return self.parameters is not None and self.parameters.complete

    def unaccounted(self) -> tuple[str, ...]:
        """Usable trial results the parameter set does not hold yet (its update is on the way)."""
        if self.parameters is None:
            return ()
        held = {t for p in self.parameters.periods for t in p.trial_ids}
        keys = {p.key for p in self.parameters.periods} | set(self.parameters.missing)
        return tuple(
            i for i, v in self.trials.items() if v.fit is not None and v.fit.usable and v.key in keys and i not in held
        )
