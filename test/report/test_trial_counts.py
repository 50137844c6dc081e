"""The report header's trial counts: every trial, an aborted one (a trial's flag, not the fit's) included."""

from __future__ import annotations

from types import SimpleNamespace

from bike_rig.core.period import FlagCode
from bike_rig.report.sections import _trial_counts


def _trial(used: bool, codes: tuple[FlagCode, ...], fit_codes: tuple[FlagCode, ...] = ()) -> SimpleNamespace:
    trial_flags = tuple(SimpleNamespace(code=c) for c in codes)
    fit_flags = tuple(SimpleNamespace(code=c) for c in fit_codes)
    return SimpleNamespace(
        used=used,
        result=SimpleNamespace(flags=trial_flags + fit_flags, trial_flags=trial_flags),
        fit=SimpleNamespace(flags=fit_flags),
    )


def test_an_aborted_trial_is_counted_flagged_and_said() -> None:
    trials = (_trial(True, ()), _trial(False, (FlagCode.ABORTED,)), _trial(False, (), (FlagCode.BEATING,)))
    subject = SimpleNamespace(trials=trials, not_replayed=())
    assert _trial_counts(subject) == "3 trials, 1 used, 2 flagged, 1 aborted"  # type: ignore[arg-type]
    one = SimpleNamespace(trials=trials[:1], not_replayed=())
    assert _trial_counts(one) == "1 trials, 1 used, 0 flagged"  # type: ignore[arg-type]
