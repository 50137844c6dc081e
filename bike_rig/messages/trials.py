"""Converters of the trial messages: ``TrialEvent``, ``GyroBatch``, ``PeriodEstimate`` and ``FitDetails``.

Each message type has one pair: ``<record>_from_msg`` reads a message into the pipeline's
record, ``fill_<message>`` writes a record into a given message object and returns it. Fields
of the same name are copied (:func:`~.fields.record_fields`, :func:`~.fields.fill_fields`).
"""

from __future__ import annotations

from ..pipeline.acquire import SampleBatch, TrialEventRecord
from ..pipeline.errors import FlagCodeError
from ..pipeline.fit import TrialFit
from ..pipeline.fit_details import FitDetails
from .fields import Message, MessageError, check_length, fill_fields, record_fields, strings

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


def trial_event_from_msg(msg: Message) -> TrialEventRecord:
    """A ``TrialEvent`` as a :class:`TrialEventRecord` (the stamp in ns).

    Raises:
        MessageError: a kind other than START, STOP or ABORT.
    """
    return TrialEventRecord(**record_fields(TrialEventRecord, msg))


def fill_trial_event(msg: Message, event: TrialEventRecord) -> Message:
    """Write a :class:`TrialEventRecord` into a ``TrialEvent`` (header included)."""
    fill_fields(msg, event)
    return msg


def sample_batch_from_msg(msg: Message) -> SampleBatch:
    """A ``GyroBatch`` as a :class:`SampleBatch`.

    A numpy field (rosbags) is used as it is, without a copy; other containers (rclpy's
    ``array.array``, lists) are copied into a new array.
    """
    return SampleBatch(**record_fields(SampleBatch, msg))


def fill_gyro_batch(msg: Message, batch: SampleBatch) -> Message:
    """Write a :class:`SampleBatch` into a ``GyroBatch`` (header included)."""
    fill_fields(msg, batch)
    return msg


def trial_fit_from_msg(msg: Message) -> TrialFit:
    """A ``PeriodEstimate`` as a :class:`TrialFit` (every field; the stamp in ns).

    The fit's numbers, the window and the flags are converted here; the other fields are copied.

    Raises:
        MessageError: a flag code that is not a :class:`~bike_rig.core.period.FlagCode`.
    """
    try:
        return TrialFit.from_period(
            **record_fields(TrialFit, msg),
            period=float(msg.period),
            period_sigma=float(msg.period_sigma),
            valid=bool(msg.valid),
            flags=strings(msg.flags),
            flag_reasons=strings(msg.flag_reasons),
            zeta=float(msg.zeta),
            omega=float(msg.omega),
            r2=float(msg.r2),
            residual_rms=float(msg.residual_rms),
            window=(int(msg.window_start), int(msg.window_stop)),
        )
    except FlagCodeError as exc:
        raise MessageError(str(exc)) from None


def fill_period_estimate(msg: Message, trial: TrialFit) -> Message:
    """Write a :class:`TrialFit` into a ``PeriodEstimate`` (header stamp included)."""
    fill_fields(msg, trial)
    msg.period = float(trial.period)
    msg.period_sigma = float(trial.period_sigma)
    msg.zeta = float(trial.fit.zeta)
    msg.omega = float(trial.fit.omega)
    msg.r2 = float(trial.fit.r2)
    msg.residual_rms = float(trial.fit.residual_rms)
    msg.window_start, msg.window_stop = (int(x) for x in trial.window)
    msg.valid = bool(trial.valid)
    msg.flags = [f.code.value for f in trial.flags]
    msg.flag_reasons = [f.reason for f in trial.flags]
    return msg


def fit_details_from_msg(msg: Message) -> FitDetails:
    """A ``FitDetails`` message as a :class:`FitDetails` (the stamp in ns).

    Raises:
        MessageError: The window periods and their σ differ in number.
    """
    fields = record_fields(FitDetails, msg)
    check_length("FitDetails.window_period_sigmas", len(fields["window_period_sigmas"]), len(fields["window_periods"]))
    return FitDetails(**fields)


def fill_fit_details(msg: Message, details: FitDetails) -> Message:
    """Write :class:`FitDetails` into a ``FitDetails`` message (header stamp included)."""
    fill_fields(msg, details)
    return msg
