"""``bike-rig demo``: the offline speeds carry σ as ``model``'s do; a bad ROS_DOMAIN_ID stops it at once (issue 11)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.config.paths import config_dir
from test.support.cli import run

BROWSER_YAML = config_dir() / "bicycles" / "browser.yaml"


def _speed_lines(out: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(("weave speed:", "capsize speed:"))]


def test_the_offline_demo_gives_the_speeds_with_models_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    """Without and with the paper's rider, the same lines as ``bike-rig model`` (same propagation, same text)."""
    code, out, _ = run(capsys, "demo", "--offline")
    assert code == 0
    _, plain, _ = run(capsys, "model", str(BROWSER_YAML))
    _, ridden, _ = run(capsys, "model", str(BROWSER_YAML), "--rider", "paper")
    expected = _speed_lines(plain) + _speed_lines(ridden)
    assert len(expected) == 4 and all(" ± " in line for line in expected)
    assert _speed_lines(out) == expected
    assert out.index("with the paper's rigid rider") < out.index(expected[2])


@pytest.mark.parametrize("domain_id", ["150", "seven"])
def test_a_bad_domain_id_is_refused_before_anything_is_simulated(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path, domain_id: str
) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", domain_id)
    out_dir = tmp_path / "demo"
    code, out, err = run(capsys, "demo", "--out", str(out_dir))
    assert code == 2 and out == ""
    shown = domain_id if domain_id.isdigit() else repr(domain_id)
    assert err.startswith(f"bike-rig demo: error: ROS_DOMAIN_ID={shown} in the environment")
    assert err.count("\n") == 1
    assert not out_dir.exists()  # no simulated session written
