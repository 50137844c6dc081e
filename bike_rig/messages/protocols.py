"""What the converters read and write of each ``bike_rig_msgs`` message, as typed protocols.

rclpy's generated classes and the dataclasses rosbags deserialises a recording into both
satisfy these; so do plain stand-ins in tests. Float arrays may be a numpy array (rosbags),
an ``array.array('d')`` (rclpy) or a list.
"""

from __future__ import annotations

import array
from collections.abc import Sequence
from typing import Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BenchmarkParametersMsg",
    "CanonicalMatricesMsg",
    "EigenSweepMsg",
    "FitDetailsMsg",
    "Float64Msg",
    "FloatField",
    "GyroBatchMsg",
    "HeaderMsg",
    "PeriodEstimateMsg",
    "ReadingEntryMsg",
    "StateSpaceModelMsg",
    "StateSpaceResponse",
    "StaticReadingsMsg",
    "TimeMsg",
    "TrialEventMsg",
]

#: A ``float64[]`` field as the message classes hold it.
FloatField: TypeAlias = "NDArray[np.float64] | array.array[float] | list[float]"


class TimeMsg(Protocol):
    """``builtin_interfaces/Time``."""

    sec: int
    nanosec: int


class HeaderMsg(Protocol):
    """``std_msgs/Header``."""

    stamp: TimeMsg
    frame_id: str


class TrialEventMsg(Protocol):
    """``bike_rig_msgs/msg/TrialEvent``."""

    header: HeaderMsg
    kind: int
    trial_id: str
    part: str
    pendulum: str
    orientation: int
    repeat: int
    measurement_key: str
    sample_rate_hz: float
    sample_count: int
    note: str


class GyroBatchMsg(Protocol):
    """``bike_rig_msgs/msg/GyroBatch``."""

    header: HeaderMsg
    trial_id: str
    first_index: int
    sample_rate_hz: float
    rates: FloatField
    raw_volts: FloatField


class PeriodEstimateMsg(Protocol):
    """``bike_rig_msgs/msg/PeriodEstimate``."""

    header: HeaderMsg
    trial_id: str
    measurement_key: str
    period: float
    period_sigma: float
    zeta: float
    omega: float
    r2: float
    residual_rms: float
    n_samples: int
    n_expected: int
    window_start: int
    window_stop: int
    valid: bool
    flags: Sequence[str]
    flag_reasons: Sequence[str]
    fit_options_json: str


class FitDetailsMsg(Protocol):
    """``bike_rig_msgs/msg/FitDetails``."""

    header: HeaderMsg
    trial_id: str
    damping_model: str
    friction: float
    friction_sigma: float
    swing_kappa: float
    centre_period: float
    small_swing_period: float
    small_swing_period_sigma: float
    window_periods: FloatField
    window_period_sigmas: FloatField
    notes: Sequence[str]


class StaticReadingsMsg(Protocol):
    """``bike_rig_msgs/msg/StaticReadings``."""

    header: HeaderMsg
    bicycle: str
    keys: Sequence[str]
    values: FloatField
    sigmas: FloatField
    source: str
    document: str


class ReadingEntryMsg(Protocol):
    """``bike_rig_msgs/msg/ReadingEntry``."""

    header: HeaderMsg
    key: str
    value: float
    sigma: float
    note: str


class BenchmarkParametersMsg(Protocol):
    """``bike_rig_msgs/msg/BenchmarkParameters``."""

    header: HeaderMsg
    bicycle: str
    names: Sequence[str]
    values: FloatField
    sigmas: FloatField
    covariance: FloatField
    complete: bool
    missing: Sequence[str]
    period_keys: Sequence[str]
    period_values: FloatField
    period_sigmas: FloatField
    trial_ids: Sequence[str]
    com_method: str


class CanonicalMatricesMsg(Protocol):
    """``bike_rig_msgs/msg/CanonicalMatrices`` (matrices 2 × 2 row-major, and their σ)."""

    header: HeaderMsg
    bicycle: str
    rider: str
    g: float
    m: FloatField
    c1: FloatField
    k0: FloatField
    k2: FloatField
    m_sigma: FloatField
    c1_sigma: FloatField
    k0_sigma: FloatField
    k2_sigma: FloatField
    sigma_convention: str


class EigenSweepMsg(Protocol):
    """``bike_rig_msgs/msg/EigenSweep``."""

    header: HeaderMsg
    bicycle: str
    rider: str
    speeds: FloatField
    eigenvalues_real: FloatField
    eigenvalues_imag: FloatField
    mode_labels: Sequence[str]
    has_weave: bool
    weave_speed: float
    weave_speed_sigma: float
    has_capsize: bool
    capsize_speed: float
    capsize_speed_sigma: float


class StateSpaceResponse(Protocol):
    """The response of ``bike_rig_msgs/srv/StateSpace``."""

    ok: bool
    message: str
    a: FloatField
    b: FloatField
    eigenvalues_real: FloatField
    eigenvalues_imag: FloatField
    mode_labels: Sequence[str]


class StateSpaceModelMsg(Protocol):
    """``bike_rig_msgs/msg/StateSpaceModel``."""

    header: HeaderMsg
    speed: float
    bicycle: str
    rider: str
    feedback: str
    sigma_convention: str
    a: FloatField
    a_sigma: FloatField
    b: FloatField
    b_sigma: FloatField
    eigenvalues_real: FloatField
    eigenvalues_real_sigma: FloatField
    eigenvalues_imag: FloatField
    eigenvalues_imag_sigma: FloatField
    mode_labels: Sequence[str]


class Float64Msg(Protocol):
    """``std_msgs/msg/Float64`` (the ride speed, m/s)."""

    data: float
