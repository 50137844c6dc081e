"""The one boundary between ``bike_rig_msgs`` messages and the pipeline's records, without ROS.

One pair of converters per message type: ``<record>_from_msg`` reads a message (rclpy's, the
dataclasses rosbags deserialises a recording into, or a stand-in) into a record;
``fill_<message>`` writes a record into a given message object and returns it. A record field
travels in the message field of the same name, converted by the record's annotated type
(:func:`.fields.record_fields`, :func:`.fields.fill_fields`): a field added to a ``.msg`` and to
its record needs nothing here. The converters spell out only real conversions (nested records,
matrices, flags, enums under another name). Float arrays are written in the container the object
already holds (numpy array, ``array.array`` or list), so rclpy's field checks and rosbags'
serialiser both accept them. The live nodes and the offline runner both use these functions, so
a recording converts to exactly the records the nodes computed with.

Pairs (message: record, converters):

* ``TrialEvent``: :class:`~bike_rig.pipeline.acquire.TrialEventRecord`,
  :func:`trial_event_from_msg`, :func:`fill_trial_event`;
* ``GyroBatch``: :class:`~bike_rig.pipeline.acquire.SampleBatch`,
  :func:`sample_batch_from_msg`, :func:`fill_gyro_batch`;
* ``PeriodEstimate``: :class:`~bike_rig.pipeline.fit.TrialFit`,
  :func:`trial_fit_from_msg`, :func:`fill_period_estimate`;
* ``FitDetails``: :class:`~bike_rig.pipeline.fit_details.FitDetails`,
  :func:`fit_details_from_msg`, :func:`fill_fit_details`;
* ``StaticReadings``: :class:`~bike_rig.core.measurements.Measurements`,
  :func:`static_readings_from_msg`, :func:`fill_static_readings`;
* ``ReadingEntry``: :class:`~bike_rig.pipeline.readings.ReadingEntry`,
  :func:`reading_entry_from_msg`, :func:`fill_reading_entry`;
* ``BenchmarkParameters``: :class:`~bike_rig.pipeline.assemble.SessionParameters`,
  :func:`session_parameters_from_msg`, :func:`fill_benchmark_parameters`;
* ``CanonicalMatrices``: :class:`~bike_rig.pipeline.model.ModelMatrices`,
  :func:`model_matrices_from_msg`, :func:`fill_canonical_matrices`;
* ``EigenSweep``: :class:`~bike_rig.pipeline.model.StabilitySweep`,
  :func:`stability_sweep_from_msg`, :func:`fill_eigen_sweep`;
* the ``StateSpace`` response: :class:`~bike_rig.pipeline.model.StateSpaceAt`,
  :func:`state_space_from_response`, :func:`fill_state_space_response` (and
  :func:`fill_state_space_error`);
* ``StateSpaceModel``: :class:`~bike_rig.pipeline.model.StateSpaceWithSigma`,
  :func:`state_space_model_from_msg`, :func:`fill_state_space_model`;
* the ride speed, ``std_msgs/Float64`` (m/s): a float, :func:`ride_speed_from_msg`,
  :func:`fill_ride_speed`.

Header stamps are integer ns (:func:`stamp_ns`, :func:`set_stamp`); TrialEvent kinds are
:class:`~bike_rig.pipeline.acquire.TrialEventKind`.
"""

from __future__ import annotations

from .fields import MessageError, set_stamp, stamp_ns
from .readings import fill_reading_entry, reading_entry_from_msg
from .results import (
    fill_benchmark_parameters,
    fill_canonical_matrices,
    fill_eigen_sweep,
    fill_state_space_error,
    fill_state_space_response,
    fill_static_readings,
    model_matrices_from_msg,
    session_parameters_from_msg,
    stability_sweep_from_msg,
    state_space_from_response,
    static_readings_from_msg,
)
from .ride import fill_ride_speed, fill_state_space_model, ride_speed_from_msg, state_space_model_from_msg
from .trials import (
    fill_fit_details,
    fill_gyro_batch,
    fill_period_estimate,
    fill_trial_event,
    fit_details_from_msg,
    sample_batch_from_msg,
    trial_event_from_msg,
    trial_fit_from_msg,
)

__all__ = [
    "MessageError",
    "fill_benchmark_parameters",
    "fill_canonical_matrices",
    "fill_eigen_sweep",
    "fill_fit_details",
    "fill_gyro_batch",
    "fill_period_estimate",
    "fill_reading_entry",
    "fill_ride_speed",
    "fill_state_space_error",
    "fill_state_space_model",
    "fill_state_space_response",
    "fill_static_readings",
    "fill_trial_event",
    "fit_details_from_msg",
    "model_matrices_from_msg",
    "reading_entry_from_msg",
    "ride_speed_from_msg",
    "sample_batch_from_msg",
    "session_parameters_from_msg",
    "set_stamp",
    "stability_sweep_from_msg",
    "state_space_from_response",
    "state_space_model_from_msg",
    "static_readings_from_msg",
    "stamp_ns",
    "trial_event_from_msg",
    "trial_fit_from_msg",
]
