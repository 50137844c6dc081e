"""A flywheel D in the front wheel: a synthetic case derived by hand.

A uniform disc of mass 2 kg and radius 0.1 m, centred on the axle, has I_yy = m r²/2 = 0.01 kg m²
about the axle (its spin) and I_xx = m r²/4 = 0.005 kg m² about a diameter. Fixed in the Browser's
front wheel, the wheel with it weighs m_F + 2 kg and swings, about the same rim contact l_F, with
the compound period of (I_Fyy + 0.01) + (m_F + 2) l_F² over (m_F + 2) g l_F (Eq 28), and twists
on the torsion rod with 2π √((I_Fxx + 0.005) / k) (Eq 29), k = 4π² I_P / T_P² (Fig 9). Those
periods are computed here from the readings by these formulas; the core must give the disc back.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.core.benchmark import FLYWHEEL_PART_NAMES, compute_parameters
from bike_rig.core.errors import MeasurementError
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.measurements import Measurements, Reading
from test.support.paper import shared_dir

BROWSER = shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt"
DISC_MASS, DISC_RADIUS = 2.0, 0.1
DISC_IYY, DISC_IXX = DISC_MASS * DISC_RADIUS**2 / 2, DISC_MASS * DISC_RADIUS**2 / 4


def _with_disc() -> Measurements:
    m = read_bp_measured(BROWSER)
    v = m.value
    g, mF, lF = v("g"), v("mF"), v("lF")
    rod = v("mP") / 12 * (3 * (v("dP") / 2) ** 2 + v("lP") ** 2)
    k = 4 * math.pi**2 * rod / v("TtP1") ** 2
    IFyy = (v("TcF1") / (2 * math.pi)) ** 2 * mF * g * lF - mF * lF**2
    IFxx = k * v("TtF1") ** 2 / (4 * math.pi**2)
    m_FD = mF + DISC_MASS
    TcD1 = 2 * math.pi * math.sqrt((IFyy + DISC_IYY + m_FD * lF**2) / (m_FD * g * lF))
    TtD1 = 2 * math.pi * math.sqrt((IFxx + DISC_IXX) / k)
    readings = dict(m.readings)
    readings.update({"mD": Reading(m_FD, 0.01), "TcD1": Reading(TcD1, 1e-5), "TtD1": Reading(TtD1, 1e-5)})
    return replace(m, readings=readings)


def test_the_disc_comes_back() -> None:
    ps = compute_parameters(_with_disc())
    assert ps.parts is not None and ps.parts.names == FLYWHEEL_PART_NAMES
    assert ps.parts.value("mD") == pytest.approx(DISC_MASS, rel=1e-12)
    assert ps.parts.value("IDyy") == pytest.approx(DISC_IYY, rel=1e-9)
    assert ps.parts.value("IDxx") == pytest.approx(DISC_IXX, rel=1e-9)
    assert ps.parts.sigma("mD") == pytest.approx(math.hypot(0.01, read_bp_measured(BROWSER).readings["mF"].sigma))


def test_the_26_parameters_are_the_wheel_alone_unless_lumped() -> None:
    alone = compute_parameters(read_bp_measured(BROWSER)).parameters
    m = _with_disc()
    plain = compute_parameters(m).parameters
    lumped = compute_parameters(m, lump_flywheel=True).parameters
    assert (plain.values == alone.values).all()
    assert lumped.value("mF") == pytest.approx(alone.value("mF") + DISC_MASS, rel=1e-12)
    assert lumped.value("IFyy") == pytest.approx(alone.value("IFyy") + DISC_IYY, rel=1e-9)
    assert lumped.value("IFxx") == pytest.approx(alone.value("IFxx") + DISC_IXX, rel=1e-9)
    assert lumped.value("IRyy") == alone.value("IRyy")


def test_an_incomplete_flywheel_names_its_keys() -> None:
    m = _with_disc()
    readings = {k: r for k, r in m.readings.items() if k != "TtD1"}
    with pytest.raises(MeasurementError, match="'TtD1': missing: a flywheel D"):
        compute_parameters(replace(m, readings=readings))


def test_yaml_and_cli_carry_the_flywheel(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "disc.yaml"
    path.write_text(dump_measurements_yaml(_with_disc()))
    assert "\nflywheel:\n" in path.read_text()
    assert main(["params", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["parts"]["IDyy"]["value"] == pytest.approx(DISC_IYY, rel=1e-9)
    assert main(["params", str(path), "--json", "--flywheel-in-wheel"]) == 0
    lumped = json.loads(capsys.readouterr().out)
    assert lumped["parameters"]["IFyy"]["value"] == pytest.approx(doc["parameters"]["IFyy"]["value"] + DISC_IYY)
    assert main(["params", str(path)]) == 0
    assert "per-part outputs (flywheel D):" in capsys.readouterr().out
