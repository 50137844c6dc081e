"""Names and quality of service of every bike_rig topic and service.

No rclpy import, so the offline replay and the recorder's readers can use them too.

QoS (REP-2003): the driver publishes reliably; consumers that must see every sample (fitter,
recorder) subscribe reliably, live displays may use best effort. Results a late joiner must
still get are transient-local: the whole session's trial events and periods (so a restarted
fitter or parameter node catches up), the current trial's gyro batches, every reading entered
during the session (so a restarted parameter node applies them all again), and the latest static
readings, parameter set and model (depth 1, "latched").
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "DIAGNOSTICS",
    "EIGEN_SWEEP",
    "FIT_DETAILS",
    "GYRO",
    "MATRICES",
    "PARAMETERS",
    "PERIODS",
    "QosSpec",
    "READINGS",
    "RESEND_SAMPLES",
    "RECORDER_PAUSE",
    "RECORDER_RESUME",
    "RECORDER_SNAPSHOT",
    "RECORDER_SPLIT",
    "RIDE_SPEED",
    "RIDE_STATE_SPACE",
    "START_TRIAL",
    "STATE_SPACE",
    "STATIC_READINGS",
    "STOP_TRIAL",
    "TOPICS",
    "TRIAL_EVENTS",
]

NAMESPACE = "/bike_rig"


@dataclass(frozen=True)
class QosSpec:
    """A QoS profile in plain terms (converted to rclpy by :mod:`bike_rig.ros.qos`).

    Attributes:
        reliable: Reliable (True) or best effort.
        transient_local: Late joiners receive the last ``depth`` messages.
        depth: History depth (KEEP_LAST).
    """

    reliable: bool
    transient_local: bool
    depth: int


@dataclass(frozen=True)
class Topic:
    """A topic: name, ROS type and QoS."""

    name: str
    type: str
    qos: QosSpec


#: Gyro sample batches (50 samples each at 1 kHz: 20 per second). The transient-local depth
#: holds a whole session (50,000 batches: 42 min of 1 kHz trials, ~25 MB in the driver), so a
#: restarted fitter re-fits every trial of the session and re-publishes its period: the
#: transient-local history of the periods topic lives in the fitter and dies with it, and a
#: restarted parameter node gets every period back from the new fitter.
GYRO = Topic(f"{NAMESPACE}/gyro", "bike_rig_msgs/msg/GyroBatch", QosSpec(True, True, 50_000))
TRIAL_EVENTS = Topic(f"{NAMESPACE}/trial_events", "bike_rig_msgs/msg/TrialEvent", QosSpec(True, True, 2000))
PERIODS = Topic(f"{NAMESPACE}/periods", "bike_rig_msgs/msg/PeriodEstimate", QosSpec(True, True, 2000))
#: What each trial's fit found beyond its period (damping model, finite swing, the period along
#: the record), published with its estimate for the console. Not recorded: a replay computes it
#: again from the recorded samples.
FIT_DETAILS = Topic(f"{NAMESPACE}/fit_details", "bike_rig_msgs/msg/FitDetails", QosSpec(True, True, 2000))
STATIC_READINGS = Topic(f"{NAMESPACE}/static_readings", "bike_rig_msgs/msg/StaticReadings", QosSpec(True, True, 1))
#: Static readings entered while the session runs (one ``ReadingEntry`` each, corrections too):
#: the whole session's entries stay in the publisher's history for a restarted parameter node.
READINGS = Topic(f"{NAMESPACE}/readings", "bike_rig_msgs/msg/ReadingEntry", QosSpec(True, True, 2000))
PARAMETERS = Topic(f"{NAMESPACE}/parameters", "bike_rig_msgs/msg/BenchmarkParameters", QosSpec(True, True, 1))
MATRICES = Topic(f"{NAMESPACE}/model/matrices", "bike_rig_msgs/msg/CanonicalMatrices", QosSpec(True, True, 1))
EIGEN_SWEEP = Topic(f"{NAMESPACE}/model/eigen_sweep", "bike_rig_msgs/msg/EigenSweep", QosSpec(True, True, 1))
#: The riding speed, m/s (``std_msgs/Float64``: any speed source can publish it without
#: bike_rig's messages). Best effort, volatile, depth 1: the model node only wants the latest
#: speed, and a best-effort subscription matches reliable and best-effort publishers alike.
RIDE_SPEED = Topic(f"{NAMESPACE}/ride/speed", "std_msgs/msg/Float64", QosSpec(False, False, 1))
#: The state space (A, B, eigenvalues, with σ) at the riding speed, from the model node:
#: latched, so a controller started late gets the current one.
RIDE_STATE_SPACE = Topic(f"{NAMESPACE}/ride/state_space", "bike_rig_msgs/msg/StateSpaceModel", QosSpec(True, True, 1))
#: Every node's health (REP-107), once a second: the ROS-wide topic, default QoS (reliable,
#: volatile, depth 10) as every diagnostics tool expects. Not recorded.
DIAGNOSTICS = Topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", QosSpec(True, False, 10))

#: Every topic the recorder records. Not the ride topics: the speed belongs to a ride record
#: (recorded on the bicycle, read by ``bike-rig ride``), and the state space is computed again
#: from the recorded parameter set.
TOPICS: tuple[Topic, ...] = (
    GYRO,
    TRIAL_EVENTS,
    PERIODS,
    STATIC_READINGS,
    PARAMETERS,
    MATRICES,
    EIGEN_SWEEP,
    READINGS,
)

START_TRIAL = f"{NAMESPACE}/driver/start_trial"
STOP_TRIAL = f"{NAMESPACE}/driver/stop_trial"
#: The driver's samples again (``ResendSamples``): the fitter asks for the batches it lost.
RESEND_SAMPLES = f"{NAMESPACE}/driver/resend_samples"
STATE_SPACE = f"{NAMESPACE}/model/state_space"
RECORDER_PAUSE = f"{NAMESPACE}/recorder/pause"
RECORDER_RESUME = f"{NAMESPACE}/recorder/resume"
RECORDER_SPLIT = f"{NAMESPACE}/recorder/split_bag"
RECORDER_SNAPSHOT = f"{NAMESPACE}/recorder/save_snapshot"
