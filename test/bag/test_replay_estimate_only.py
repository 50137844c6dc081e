"""``replay``: a trial recorded only as a period estimate (no gyro data, no events) is left out with a note."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.bag.simulated import SimulatedMessage, period_estimate, write_simulated_bag
from bike_rig.config import topics
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline.replay import replay_bag, result_json
from bike_rig.pipeline.fit import TrialFit
from test.support.replay import run_cli


@pytest.fixture(scope="module")
def bags(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The session's input stream, without and with a stray estimate of a trial that has no data."""
    folder = tmp_path_factory.mktemp("estimate_only")
    stray = TrialFit.from_period("stray-t1", "TtQ7", 1.2, 1e-4, True, stamp_ns=1)
    extra = [SimulatedMessage(topics.PERIODS.name, 1, period_estimate(stray))]
    return (
        write_simulated_bag(folder / "plain", session, pause_s=2.0),
        write_simulated_bag(folder / "stray", session, extra=extra, pause_s=2.0),
    )


def test_an_estimate_without_data_is_left_out_with_a_note(bags: tuple[Path, Path]) -> None:
    plain, stray = replay_bag(bags[0]), replay_bag(bags[1])
    assert [t.trial_id for t in stray.trials] == [t.trial_id for t in plain.trials]
    assert "stray-t1" not in {t.trial_id for t in stray.trials}
    note = "trial stray-t1 left out: only its period estimate was recorded (no gyro data to fit)"
    assert note in stray.notes and note not in plain.notes
    ours, theirs = result_json(stray), result_json(plain)
    for key in ("parameters", "periods", "trials", "weave_speed", "capsize_speed"):
        assert ours[key] == theirs[key]


def test_the_cli_prints_the_note_and_exits_0(bags: tuple[Path, Path]) -> None:
    code, out, err = run_cli("replay", str(bags[1]))
    assert code == 0 and err == ""
    assert "note: trial stray-t1 left out: only its period estimate was recorded" in out
