"""The report header's trial counts: every trial, an aborted one (a trial's flag, not the fit's) included."""

from __future__ import annotations

from types import SimpleNamespace

from bike_rig.report.sections import _trial_counts


def _trial(used: bool, codes: tuple[str, ...], fit_codes: tuple[str, ...] = ()) -> SimpleNamespace:
    flags = codes + fit_codes
    return SimpleNamespace(
        used=used, result=SimpleNamespace(flags=flags, flag_codes=flags), fit=SimpleNamespace(flags=fit_codes)
    )


def test_an_aborted_trial_is_counted_flagged_and_said() -> None:
    trials = (_trial(True, ()), _trial(False, ("aborted",)), _trial(False, (), ("beating",)))
    assert _trial_counts(SimpleNamespace(trials=trials)) == "3 trials, 1 used, 2 flagged (1 aborted)"  # type: ignore[arg-type]
    assert _trial_counts(SimpleNamespace(trials=trials[:1])) == "1 trials, 1 used, 0 flagged"  # type: ignore[arg-type]
