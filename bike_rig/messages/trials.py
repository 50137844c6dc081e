"""Converters of the trial messages: ``TrialEvent``, ``GyroBatch``, ``PeriodEstimate`` and ``FitDetails``.

Each message type has one pair: ``<record>_from_msg`` reads a message into the pipeline's
record, ``fill_<message>`` writes a record into a given message object and returns it.
"""

from __future__ import annotations

import numpy as np

from ..pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from ..pipeline.errors import FlagCodeError
from ..pipeline.fit import TrialFit
from ..pipeline.fit_details import FitDetails
from .fields import MessageError, check_length, floats, set_floats, set_stamp, stamp_ns, strings
from .protocols import FitDetailsMsg, GyroBatchMsg, PeriodEstimateMsg, TrialEventMsg

__all__ = [
    "fill_fit_details",
    "fill_gyro_batch",
    "fill_period_estimate",
    "fill_trial_event",
    "fit_details_from_msg",
    "sample_batch_from_msg",
    "trial_event_from_msg",
    "trial_fit_from_msg",
]


# --------------------------------------------------------------------------------------------
# TrialEvent
# --------------------------------------------------------------------------------------------


def trial_event_from_msg(msg: TrialEventMsg) -> TrialEventRecord:
    """A ``TrialEvent`` as a :class:`TrialEventRecord` (the stamp in ns).

    Raises:
        MessageError: a kind other than START, STOP or ABORT.
    """
    try:
        kind = TrialEventKind(int(msg.kind))
    except ValueError:
        raise MessageError(f"trial event of unknown kind {msg.kind}") from None
    return TrialEventRecord(
        kind=kind,
        trial_id=str(msg.trial_id),
        measurement_key=str(msg.measurement_key),
        part=str(msg.part),
        pendulum=str(msg.pendulum),
        orientation=int(msg.orientation),
        repeat=int(msg.repeat),
        sample_rate_hz=float(msg.sample_rate_hz),
        sample_count=int(msg.sample_count),
        stamp_ns=stamp_ns(msg.header),
        frame_id=str(msg.header.frame_id),
        note=str(msg.note),
    )


def fill_trial_event(msg: TrialEventMsg, event: TrialEventRecord) -> TrialEventMsg:
    """Write a :class:`TrialEventRecord` into a ``TrialEvent`` (header included)."""
    set_stamp(msg, event.stamp_ns)
    msg.header.frame_id = event.frame_id
    msg.kind = int(event.kind)
    msg.trial_id = event.trial_id
    msg.part = event.part
    msg.pendulum = event.pendulum
    msg.orientation = int(event.orientation)
    msg.repeat = int(event.repeat)
    msg.measurement_key = event.measurement_key
    msg.sample_rate_hz = float(event.sample_rate_hz)
    msg.sample_count = int(event.sample_count)
    msg.note = event.note
    return msg


# --------------------------------------------------------------------------------------------
# GyroBatch
# --------------------------------------------------------------------------------------------


def sample_batch_from_msg(msg: GyroBatchMsg) -> SampleBatch:
    """A ``GyroBatch`` as a :class:`SampleBatch`.

    A numpy field (rosbags) is used as it is, without a copy; other containers (rclpy's
    ``array.array``, lists) are copied into a new array.
    """
    rates, volts = msg.rates, msg.raw_volts
    return SampleBatch(
        trial_id=str(msg.trial_id),
        first_index=int(msg.first_index),
        sample_rate_hz=float(msg.sample_rate_hz),
        rates=rates if isinstance(rates, np.ndarray) and rates.dtype == np.float64 else floats(rates),
        raw_volts=volts if isinstance(volts, np.ndarray) and volts.dtype == np.float64 else floats(volts),
        stamp_ns=stamp_ns(msg.header),
        frame_id=str(msg.header.frame_id),
    )


def fill_gyro_batch(msg: GyroBatchMsg, batch: SampleBatch) -> GyroBatchMsg:
    """Write a :class:`SampleBatch` into a ``GyroBatch`` (header included)."""
    set_stamp(msg, batch.stamp_ns)
    msg.header.frame_id = batch.frame_id
    msg.trial_id = batch.trial_id
    msg.first_index = int(batch.first_index)
    msg.sample_rate_hz = float(batch.sample_rate_hz)
    set_floats(msg, "rates", batch.rates)
    set_floats(msg, "raw_volts", batch.raw_volts)
    return msg


# --------------------------------------------------------------------------------------------
# PeriodEstimate
# --------------------------------------------------------------------------------------------


def trial_fit_from_msg(msg: PeriodEstimateMsg) -> TrialFit:
    """A ``PeriodEstimate`` as a :class:`TrialFit` (every field; the stamp in ns).

    Raises:
        MessageError: a flag code that is not a :class:`~bike_rig.core.period.FlagCode`.
    """
    try:
        return TrialFit.from_period(
            str(msg.trial_id),
            str(msg.measurement_key),
            float(msg.period),
            float(msg.period_sigma),
            bool(msg.valid),
            strings(msg.flags),
            strings(msg.flag_reasons),
            zeta=float(msg.zeta),
            omega=float(msg.omega),
            r2=float(msg.r2),
            residual_rms=float(msg.residual_rms),
            n_samples=int(msg.n_samples),
            n_expected=int(msg.n_expected),
            window=(int(msg.window_start), int(msg.window_stop)),
            fit_options_json=str(msg.fit_options_json),
            stamp_ns=stamp_ns(msg.header),
        )
    except FlagCodeError as exc:
        raise MessageError(str(exc)) from None


def fill_period_estimate(msg: PeriodEstimateMsg, trial: TrialFit) -> PeriodEstimateMsg:
    """Write a :class:`TrialFit` into a ``PeriodEstimate`` (header stamp included)."""
    set_stamp(msg, trial.stamp_ns)
    msg.trial_id = trial.trial_id
    msg.measurement_key = trial.measurement_key
    msg.period = float(trial.period)
    msg.period_sigma = float(trial.period_sigma)
    msg.zeta = float(trial.fit.zeta)
    msg.omega = float(trial.fit.omega)
    msg.r2 = float(trial.fit.r2)
    msg.residual_rms = float(trial.fit.residual_rms)
    msg.n_samples = int(trial.n_samples)
    msg.n_expected = int(trial.n_expected)
    msg.window_start, msg.window_stop = (int(x) for x in trial.window)
    msg.valid = bool(trial.valid)
    msg.flags = [f.code.value for f in trial.flags]
    msg.flag_reasons = [f.reason for f in trial.flags]
    msg.fit_options_json = trial.fit_options_json
    return msg


# --------------------------------------------------------------------------------------------
# FitDetails
# --------------------------------------------------------------------------------------------


def fit_details_from_msg(msg: FitDetailsMsg) -> FitDetails:
    """A ``FitDetails`` message as a :class:`FitDetails` (the stamp in ns).

    Raises:
        MessageError: The window periods and their σ differ in number.
    """
    periods, sigmas = floats(msg.window_periods), floats(msg.window_period_sigmas)
    check_length("window_period_sigmas", sigmas.size, periods.size)
    return FitDetails(
        str(msg.trial_id),
        stamp_ns(msg.header),
        str(msg.damping_model),
        float(msg.friction),
        float(msg.friction_sigma),
        float(msg.swing_kappa),
        float(msg.centre_period),
        float(msg.small_swing_period),
        float(msg.small_swing_period_sigma),
        tuple(float(x) for x in periods),
        tuple(float(x) for x in sigmas),
        strings(msg.notes),
    )


def fill_fit_details(msg: FitDetailsMsg, details: FitDetails) -> FitDetailsMsg:
    """Write :class:`FitDetails` into a ``FitDetails`` message (header stamp included)."""
    set_stamp(msg, details.stamp_ns)
    msg.trial_id = details.trial_id
    msg.damping_model = details.damping_model
    msg.friction = float(details.friction)
    msg.friction_sigma = float(details.friction_sigma)
    msg.swing_kappa = float(details.swing_kappa)
    msg.centre_period = float(details.centre_period)
    msg.small_swing_period = float(details.small_swing_period)
    msg.small_swing_period_sigma = float(details.small_swing_period_sigma)
    set_floats(msg, "window_periods", details.window_periods)
    set_floats(msg, "window_period_sigmas", details.window_period_sigmas)
    msg.notes = list(details.notes)
    return msg
