"""The riding injected into a found segment's fit: its bias removed, its σ widened, nothing without riding."""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.injection import InjectionOptions, inject_segments, riding_mask
from bike_rig.core.ride.record import RideRecord
from bike_rig.core.ride.segment import Kick, Segment, Segmentation, detrend, find_kicks

RATE = 100.0
#: The decay's eigenvalue [1/s].
LAM = complex(-1.5, 6.0)
#: The riding: a lightly damped resonance at the decay's frequency, driven by white noise [1/s].
RIDING = complex(-0.5, 6.0)
OPTIONS = InjectionOptions(injections=12)


def _record(seed: int, length: float = 90.0, level: float = 0.1) -> tuple[RideRecord, Segment]:
    """A record of coloured riding (RMS ``level``) with one free decay of two cycles at its middle."""
    rng = np.random.default_rng(seed)
    n = int(length * RATE)
    t = np.arange(n) / RATE
    r, w = math.exp(RIDING.real / RATE), RIDING.imag / RATE
    coloured = lfilter([1.0], [1.0, -2.0 * r * math.cos(w), r * r], rng.normal(size=n))
    y = level * coloured / np.std(coloured) + 0.01 * rng.normal(size=n)
    start = 0.5 * length
    stop = start + 2.0 * 2.0 * math.pi / LAM.imag
    inside = (t >= start) & (t <= stop)
    tau = t[inside] - start
    y[inside] += np.exp(LAM.real * tau) * np.cos(LAM.imag * tau)
    segment = Segment(start, stop, Kick(start - 0.3, start - 0.2, "a test push", confirmed=True), "start", "stop")
    return RideRecord("test", t, y), segment


def _found(record: RideRecord, segment: Segment) -> Segmentation:
    """The hand-cut ``segment`` with the kicks the segmenter finds in ``record``."""
    return Segmentation((segment,), tuple(find_kicks(record)), detrend(record))


def _fit(record: RideRecord, segment: Segment):  # type: ignore[no-untyped-def]
    inside = (record.times >= segment.start) & (record.times <= segment.stop)
    return fit_segment(record.times[inside], record.signal[inside])


def test_injection_removes_the_coloured_riding_bias() -> None:
    plain, injected = [], []
    for seed in range(6):
        record, segment = _record(seed)
        m = _fit(record, segment)
        (a,) = inject_segments(record, _found(record, segment), [m], options=OPTIONS)
        assert any("refits with this record's own riding" in n for n in a.notes)
        assert a.real_sigma >= m.real_sigma and a.imag_sigma >= m.imag_sigma
        plain.append((m.real - LAM.real, m.real_sigma))
        injected.append((a.real - LAM.real, a.real_sigma))
    p, q = np.array(plain), np.array(injected)
    assert p[:, 0].mean() > 0.05 * abs(LAM.real)  # the plain fit decays too slowly
    assert abs(q[:, 0].mean()) < 0.5 * p[:, 0].mean()
    assert abs(np.mean(q[:, 0] / q[:, 1])) < abs(np.mean(p[:, 0] / p[:, 1]))


def test_no_riding_leaves_the_segment_as_it_is() -> None:
    record, segment = _record(1, length=8.0)  # the segment and its guards fill the record
    m = _fit(record, segment)
    (a,) = inject_segments(record, _found(record, segment), [m], options=OPTIONS)
    assert a == m


def test_the_riding_leaves_out_every_kick_with_a_segment_or_without() -> None:
    record, segment = _record(3)
    motion = Kick(20.0, 20.2, "the rider's own motion")
    found = Segmentation((segment,), (motion, segment.kick), detrend(record))
    riding = riding_mask(record, found, OPTIONS)
    t = record.times
    assert not riding[(t >= motion.onset - OPTIONS.lead_s) & (t <= motion.end + OPTIONS.guard_s)].any()
    assert not riding[(t >= segment.kick.onset - OPTIONS.lead_s) & (t <= segment.stop + OPTIONS.guard_s)].any()
    assert riding[(t > motion.end + OPTIONS.guard_s) & (t < segment.kick.onset - OPTIONS.lead_s)].all()


def test_a_correction_never_makes_a_decay_grow() -> None:
    from bike_rig.core.ride.injection import BIAS_UNSTABLE, Injection, injected

    record, segment = _record(2)
    m = _fit(record, segment)
    big = Injection(12, 20.0, m.real - 0.5, 0.0, 0.01, 0.01, 0.2, 0.2)
    a = injected(m, big)
    assert a.real == m.real and a.real < 0
    assert any(f.startswith(BIAS_UNSTABLE) for f in a.flags) and not a.clean
