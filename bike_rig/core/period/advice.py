"""What the operator should do about a flagged trial: one line of advice per quality flag code.

A flag's reason (:class:`~bike_rig.core.period.result.Flag`) says what is wrong with the trial's
record; the advice says what to change before redoing it.
"""

from __future__ import annotations

from collections.abc import Mapping

from .result import FlagCode

__all__ = ["FLAG_ADVICE", "flag_advice"]

#: The advice for each flag code (every code has one).
FLAG_ADVICE: Mapping[FlagCode, str] = {
    FlagCode.EMPTY: "check that the gyro is connected and streaming, then redo the trial",
    FlagCode.NON_FINITE: "the gyro sent NaN or infinite values: check the sensor and its cable, then redo",
    FlagCode.BAD_TIMES: "the time stamps do not increase: check the source's clock, then redo",
    FlagCode.CONSTANT: "the rate never changed: is the gyro powered, on the right axis, and the pendulum swinging?",
    FlagCode.NO_OSCILLATION: "no swing stands out of the noise: release the pendulum from a clear angle "
    "(about 0.5-1 degree) and check the gyro's axis",
    FlagCode.FIT_FAILED: "redo with one clean swing: release without a push, and do not touch the rig",
    FlagCode.TOO_FEW_CYCLES: "record longer (at least the minimum number of whole cycles after the lead-in)",
    FlagCode.POOR_FIT: "keep the rig still and untouched while it swings, then redo",
    FlagCode.BEATING: "a second swing mode is mixed in: release straight, without a sideways push, and let it settle",
    FlagCode.CLIPPED: "the signal hit the ADC's rails: release from a smaller angle",
    FlagCode.GAP_FILLED: "held or repeated samples: check the link to the DAQ or CAN bus for dropouts",
    FlagCode.DRIFT: "the gyro's offset drifted: let the gyro warm up and keep the temperature steady, then redo",
    FlagCode.PERIOD_DRIFT: "the period changed during the trial beyond what its swing explains: check that the "
    "part and its clamp are tight and that nothing touches the pendulum or the rig, then redo",
    FlagCode.UNKNOWN_TRIAL: "samples arrived for a trial that was never started: check that only one driver runs",
    FlagCode.NO_START: "the trial's START was lost: redo the trial",
    FlagCode.NO_STOP: "the trial never stopped (the driver stopped or died): redo the trial",
    FlagCode.ABORTED: "the trial was aborted: redo it",
    FlagCode.OVERSIZED_BATCH: "the driver sends batches larger than the fitter accepts: lower samples_per_batch",
    FlagCode.TRUNCATED: "the trial is longer than the fitter keeps: record shorter or raise max_trial_samples",
    FlagCode.OVERLAP: "batches overlapped: check that only one driver publishes, then redo",
    FlagCode.GAP: "samples were lost on the way: check the link and the computer's load, then redo",
    FlagCode.SAMPLE_COUNT: "more samples arrived than the driver sent: check that only one driver publishes",
    FlagCode.RATE_MISMATCH: "the sample rates disagree: check the source's sample_rate_hz",
    FlagCode.BAD_RATE: "no usable sample rate: check the source's sample_rate_hz",
}


def flag_advice(code: FlagCode | str) -> str:
    """The advice for a flag code (a :class:`FlagCode` or its value); "redo the trial" for an unknown one."""
    try:
        return FLAG_ADVICE[FlagCode(code)]
    except ValueError:
        return "redo the trial"
