"""Tests of ``bike_rig.offline.subjects``: a bag's trials and the mass-centre method.

A bag's trials come with the samples and the time axis their fit used (also across gaps and
overlaps), and the mass-centre method reaches a replayed bag.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bike_rig.bag.simulated import simulated_messages
from bike_rig.bag.typestore import rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config import topics
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline.subjects import SessionTrial, load_subject
from test.support.simulated import short_session

GAPPED = "rear_wheel_compound_t1"  # loses a batch
OVERLAPPED = "rear_wheel_compound_t2"  # gets a batch again, shifted to overlap the next one


def _write(path: Path, session: SimulatedSession) -> Path:
    store = rig_typestore()
    types = {t.name: t.type for t in topics.TOPICS}
    with BagWriter(path, flush_period_s=3600.0) as w:
        for t in topics.TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for m in simulated_messages(session):
            msg = m.message
            if m.topic == topics.GYRO.name and msg.trial_id == GAPPED and msg.first_index == 2000:
                continue
            w.write(m.topic, m.log_time, bytes(store.serialize_cdr(msg, types[m.topic])))
            if m.topic == topics.GYRO.name and msg.trial_id == OVERLAPPED and msg.first_index == 3000:
                again = type(msg)(**{**msg.__dict__, "first_index": 3020})  # 30 samples overlap the next batch
                w.write(m.topic, m.log_time + 1, bytes(store.serialize_cdr(again, types[m.topic])))
    return path


@pytest.fixture(scope="module")
def damaged(tmp_path_factory: pytest.TempPathFactory) -> dict[str, SessionTrial]:
    bag = _write(tmp_path_factory.mktemp("bags") / "damaged", short_session())
    return {t.trial_id: t for t in load_subject(bag).trials}


def _window_residual_rms(t: SessionTrial) -> float:
    assert t.samples is not None
    axis = t.times if t.times is not None else np.arange(t.samples.size) / float(t.sample_rate_hz or 1.0)
    a, b = t.fit.window
    return float(np.sqrt(np.mean((t.samples[a:b] - t.fit.predict(axis[a:b])) ** 2)))


def test_the_fit_is_drawn_on_the_samples_and_axis_it_was_fitted_on(damaged: dict[str, SessionTrial]) -> None:
    gapped, overlapped = damaged[GAPPED], damaged[OVERLAPPED]
    assert gapped.times is not None and gapped.samples is not None
    assert gapped.samples.size == 12000 - 50 and np.all(np.diff(gapped.times) > 0)
    assert gapped.times[2000] - gapped.times[1999] == pytest.approx(51 / float(gapped.sample_rate_hz or 0))
    for t in (gapped, overlapped):
        # the residual of the drawn window is the fit's own (a shifted axis would give the signal's size)
        assert _window_residual_rms(t) == pytest.approx(t.fit.residual_rms, rel=1e-9)
    clean = damaged["front_wheel_compound_t1"]
    assert clean.times is None and _window_residual_rms(clean) == pytest.approx(clean.fit.residual_rms, rel=1e-9)


def test_the_mass_centre_method_reaches_a_bag(tmp_path: Path) -> None:
    bag = _write(tmp_path / "bag", short_session())
    recorded = load_subject(bag).parameters.parameters
    lstsq = load_subject(bag, "lstsq").parameters.parameters
    assert recorded.value("xB") != lstsq.value("xB")
    assert load_subject(bag, "centroid").parameters.parameters.value("xB") == recorded.value("xB")
