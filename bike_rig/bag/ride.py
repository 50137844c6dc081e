"""A ride record from a bag: a field of one topic as the signal (default: ``sensor_msgs/Imu``'s roll rate).

The signal is the field ``angular_velocity.x`` (the roll rate, rad/s, of an IMU whose x axis
points forward) of the first ``sensor_msgs/msg/Imu`` topic unless a topic and a dotted field
are named. The speed [m/s] and steer torque [N m] may come from further topics (a plain
number field, e.g. ``std_msgs/Float64``'s ``data``), interpolated to the signal's times; the
speed is read from ``/bike_rig/ride/speed`` (the live graph's speed topic) when the bag has it
and no other topic is named.
Sample times are the messages' ``header.stamp`` when they have one, else their log times.
Types are decoded with ROS 2 Kilted's standard definitions (rosbags' typestore).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..config.topics import RIDE_SPEED
from ..core.ride.record import RideRecord
from .errors import BagError
from .reader import open_bag
from .typestore import standard_typestore

__all__ = ["IMU_TYPE", "read_ride_bag"]

#: The usual roll-rate source.
IMU_TYPE = "sensor_msgs/msg/Imu"


def _field(msg: Any, dotted: str, shown: str, topic: str) -> float:
    value = msg
    for part in dotted.split("."):
        if not hasattr(value, part):
            raise BagError(shown, f"topic {topic}: its messages have no field '{dotted}'")
        value = getattr(value, part)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise BagError(shown, f"topic {topic}: field '{dotted}' is not a number") from None


def _series(bag: Any, topic: str, dotted: str, shown: str) -> tuple[np.ndarray, np.ndarray]:
    """(times [ns since the epoch, int64], values) of one topic's field."""
    if topic not in bag.topics:
        raise BagError(shown, f"no topic {topic} (topics: {', '.join(sorted(bag.topics))})")
    msgtype = bag.topics[topic].msgtype
    store = standard_typestore()
    if msgtype not in store.fielddefs:
        raise BagError(shown, f"topic {topic}: type {msgtype} is not a standard ROS 2 type")
    times, values = [], []
    for raw in bag.messages([topic]):
        try:
            msg = store.deserialize_cdr(raw.data, msgtype)
        except Exception as exc:  # rosbags raises several kinds for bad CDR
            raise BagError(shown, f"a {msgtype} message on {topic} does not deserialize ({exc})") from None
        stamp = getattr(getattr(msg, "header", None), "stamp", None)
        t = stamp.sec * 1_000_000_000 + stamp.nanosec if stamp is not None else raw.log_time
        times.append(t)
        values.append(_field(msg, dotted, shown, topic))
    return np.asarray(times, dtype=np.int64), np.asarray(values, dtype=float)


def read_ride_bag(
    path: str | Path,
    topic: str | None = None,
    field: str = "angular_velocity.x",
    speed_topic: str | None = None,
    speed_field: str = "data",
    torque_topic: str | None = None,
    torque_field: str = "data",
) -> RideRecord:
    """Read a ride record from a bag (module docstring).

    Raises:
        BagError: Not a bag, no such topic or field, no Imu topic, fewer than two messages,
            times that do not increase.
    """
    shown = str(path)
    with open_bag(path) as bag:
        if topic is None:
            imus = sorted(name for name, info in bag.topics.items() if info.msgtype == IMU_TYPE)
            if not imus:
                raise BagError(shown, f"no {IMU_TYPE} topic: name the signal's topic and field")
            topic = imus[0]
        if speed_topic is None and RIDE_SPEED.name in bag.topics:
            speed_topic = RIDE_SPEED.name  # (the live graph's speed topic, read when the bag has it)
        t_ns, y = _series(bag, topic, field, shown)
        t0 = int(t_ns.min()) if t_ns.size else 0
        t = (t_ns - t0).astype(float) * 1e-9  # (from the first sample: exact to the ns)
        extra = {}
        for key, name, dotted in (("speed", speed_topic, speed_field), ("torque", torque_topic, torque_field)):
            if name is not None:
                ts, vs = _series(bag, name, dotted, shown)
                extra[key] = np.interp(t, (ts - t0).astype(float) * 1e-9, vs) if ts.size else np.full(t.size, np.nan)
    if t.size < 2:
        raise BagError(shown, f"topic {topic}: {t.size} messages, a record needs at least two")
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    if not np.all(np.diff(t) > 0):
        raise BagError(shown, f"topic {topic}: repeated sample times")
    return RideRecord(
        source=shown,
        times=t - t[0],
        signal=y,
        signal_name=f"{topic}:{field}",
        speed=extra["speed"][order] if "speed" in extra else None,
        torque=extra["torque"][order] if "torque" in extra else None,
    )


#: The topics of a simulated ride's bag: the IMU, the speed and the steer torque.
RIDE_BAG_TOPICS = {"imu": "/imu/data", "speed": RIDE_SPEED.name, "torque": "/ride/steer_torque"}


def write_ride_bag(ride: Any, path: str | Path, start_ns: int = 1_700_000_000_000_000_000) -> None:
    """Write a simulated ride (:class:`bike_rig.core.sim.ride.SimulatedRide`) as a bag.

    ``sensor_msgs/Imu`` on ``/imu/data`` (roll rate in ``angular_velocity.x``, steer rate in
    ``angular_velocity.z`` as a stand-in for a steer gyro), ``std_msgs/Float64`` speed [m/s]
    on ``/bike_rig/ride/speed`` (the live graph's speed topic) and steer torque [N m] on
    ``/ride/steer_torque``; every message stamped at its sample time from ``start_ns`` (ns since
    the epoch).

    Raises:
        BagError: The bag cannot be written (e.g. it exists).
    """
    from .typestore import new_message
    from .writer import BagWriter

    store = standard_typestore()
    imu_t, f64 = IMU_TYPE, "std_msgs/msg/Float64"
    with BagWriter(path) as w:
        w.add_topic(RIDE_BAG_TOPICS["imu"], imu_t)
        w.add_topic(RIDE_BAG_TOPICS["speed"], f64)
        w.add_topic(RIDE_BAG_TOPICS["torque"], f64)
        for k, t in enumerate(ride.times):
            ns = start_ns + int(round(float(t) * 1e9))
            stamp = new_message("builtin_interfaces/msg/Time", sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            header = new_message("std_msgs/msg/Header", stamp=stamp, frame_id="imu")
            gyro = new_message(
                "geometry_msgs/msg/Vector3", x=float(ride.roll_rate[k]), y=0.0, z=float(ride.steer_rate[k])
            )
            imu = new_message(imu_t, header=header, angular_velocity=gyro)
            w.write(RIDE_BAG_TOPICS["imu"], ns, bytes(store.serialize_cdr(imu, imu_t)))
            for key, values in (("speed", ride.speed), ("torque", ride.steer_torque)):
                msg = new_message(f64, data=float(values[k]))
                w.write(RIDE_BAG_TOPICS[key], ns, bytes(store.serialize_cdr(msg, f64)))
