"""The bounded campaign of physically impossible, well-formed inputs: none is printed with exit status 0.

``tools/fuzz.py --reader physics`` runs the long one.
"""

from __future__ import annotations

from pathlib import Path

from test.fuzz.physics import physics_campaign, physics_input

#: The suite's campaign: seed and inputs.
SEED = 20261129
INPUTS = 120
#: The rules broken exactly (by value, not through a chain of readings): every such input must be refused.
EXACT = ("mass", "gravity", "length", "tilt", "inertia", "definite", "triangle", "ground", "compound period")


def test_no_impossible_input_ends_in_exit_0_or_a_crash(tmp_path: Path) -> None:
    tally = physics_campaign(tmp_path, SEED, INPUTS)
    assert tally.failures == []
    assert tally.counts["violation"] == tally.counts["crash"] == 0
    for rule in EXACT:
        assert rule in tally.by_rule, rule  # the campaign made inputs of every kind
        assert tally.by_rule[rule]["ok"] == 0 and tally.by_rule[rule]["refused"] > 0, (rule, tally.by_rule[rule])
    assert tally.counts["refused"] >= INPUTS // 2 and tally.counts["ok"] > 0


def test_an_input_is_reproduced_from_its_seed_and_index() -> None:
    assert physics_input(SEED, 17) == physics_input(SEED, 17)
    assert physics_input(SEED, 17) != physics_input(SEED + 1, 17)
