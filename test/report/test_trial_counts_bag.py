"""The report header counts every trial of a session, aborted ones and ones without samples too."""

from __future__ import annotations

import dataclasses

from bike_rig.offline.subjects import load_subject
from bike_rig.report.sections import _trial_counts


def test_trials_without_a_fit_are_counted_and_said() -> None:
    subject = load_subject("browser")  # a shipped measurement file, found by name: no trials
    assert _trial_counts(subject) == "0 trials, 0 used, 0 flagged"
    bag_like = dataclasses.replace(subject, not_replayed=(("t9", "aborted"), ("t10", "open"), ("t11", "aborted")))
    assert _trial_counts(bag_like) == "3 trials, 0 used, 0 flagged, 2 aborted, 1 without samples"
