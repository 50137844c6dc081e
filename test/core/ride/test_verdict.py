"""The comparison in words: agrees, in tension, disagrees and how; never a NaN in the words."""

from __future__ import annotations

import math

import pytest

from bike_rig.core.ride.verdict import Verdict, overall_verdict, pair_verdict


def test_agreement_says_within_how_many_sigma() -> None:
    v = pair_verdict(complex(-0.30, 5.31), complex(-0.31, 5.30), 0.4, 1.3)
    assert v.code == "agrees" and v.text == "agrees within 1.3 σ" and v.sigma == pytest.approx(1.3)


def test_a_frequency_far_off_is_said_in_percent_and_sigma() -> None:
    v = pair_verdict(complex(-0.3, 7.4), complex(-0.3, 5.4), 0.1, 6.0)
    assert v.code == "disagrees"
    assert v.text == "disagrees: the measured weave frequency is 37 % above the model's: 6.0 σ"


def test_decay_against_growth_and_tension() -> None:
    v = pair_verdict(complex(-0.4, 5.0), complex(0.3, 5.0), -2.5, 0.0)
    assert v.code == "tension" and v.text.startswith("in tension: the measured weave decays where the model's grows")
    slow = pair_verdict(complex(-0.2, 5.0), complex(-0.4, 5.0), 3.5, 0.0)
    assert "decays 50 % slower than the model's" in slow.text and slow.code == "disagrees"


def test_a_model_mode_that_does_not_oscillate_is_said_so() -> None:
    v = pair_verdict(complex(-0.3, 2.2), complex(-0.5, 0.0), 0.0, 9.0)
    assert "where the model's nearest mode does not oscillate" in v.text
    far = pair_verdict(complex(-0.3, 5.3), complex(-0.3, 0.05), 0.0, 57.0)
    assert "the measured weave frequency is 106 times the model's: 57.0 σ" in far.text


def test_no_numbers_no_nan_in_words() -> None:
    for v in (
        pair_verdict(complex(math.nan, math.nan), complex(-0.3, 5.0), math.nan, math.nan),
        pair_verdict(complex(-0.3, 5.0), complex(-0.3, 5.0), math.nan, math.nan),
        overall_verdict([], [], 4),
    ):
        assert "nan" not in v.text.lower() and v.text.startswith("no verdict")
    assert overall_verdict([], [], 4).code == "no_clean_segment"


def test_overall_is_the_worst_speed_with_counts() -> None:
    far = "disagrees: the measured weave frequency is 37 % above the model's: 6.0 σ"
    speeds = [(3.0, Verdict("agrees", "agrees within 0.5 σ", 0.5)), (4.5, Verdict("disagrees", far, 6.0))]
    v = overall_verdict(speeds, [1.7])
    assert v.code == "disagrees" and v.sigma == 6.0
    assert v.text.startswith("the model disagrees with the ride at 1 of 2 speeds (4.50 m/s); worst at 4.50 m/s")
    assert v.text.endswith("no clean segment at 1.70 m/s")
    ok = overall_verdict(speeds[:1])
    assert ok.text == "the model agrees with the ride at the one speed: largest deviation 0.5 σ (at 3.00 m/s)"
