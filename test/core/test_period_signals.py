"""Tests of the synthetic rate-gyro trials of test/support/signals.py."""

from __future__ import annotations

import numpy as np
import pytest

from test.support.signals import BITS, FULL_SCALE, LSB, gyro_trial, quantise

# ---------------------------------------------------------------- the generator's own tests


def test_quantise_is_a_12_bit_adc() -> None:
    y = quantise(np.linspace(-2.0, 2.0, 10001))
    assert np.unique(y).size == 2**BITS
    assert y.min() == pytest.approx(-FULL_SCALE) and y.max() == pytest.approx(FULL_SCALE - LSB)
    steps = np.diff(np.unique(y))
    assert np.allclose(steps, LSB)


def test_gyro_trial_truth_and_noise() -> None:
    clean = gyro_trial(1, noise=0.0, drift=0.0, bits=None, bias=0.0, zeta=0.0)
    # an undamped sine of the stated period: zero crossings every half period
    crossings = np.flatnonzero(np.diff(np.sign(clean.samples)) != 0)
    assert np.median(np.diff(crossings)) / clean.rate_hz == pytest.approx(clean.period / 2, abs=2e-3)
    noisy = gyro_trial(1, noise=LSB, drift=0.0, bits=None, bias=0.0, zeta=0.0)
    assert np.std(noisy.samples - clean.samples) == pytest.approx(LSB, rel=0.05)
