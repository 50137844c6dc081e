"""Every field of every ``bike_rig_msgs`` message travels through its converters.

Each field of a ``.msg`` definition (parsed by rosbags) gets a value unlike its default; the
message is read into its record and written into a fresh message, which must hold every value
again. A field the converters neither read nor write comes back at its default and fails.
Both message kinds are tried: rosbags' dataclasses and rclpy's generated classes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import Nodetype

from bike_rig import messages as conv
from bike_rig.core.benchmark import ComMethod
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention
from bike_rig.messages.fields import record_fields

REPO = Path(__file__).resolve().parents[1]
MSG_DIR = REPO / "bike_rig_msgs" / "msg"
SRV_DIR = REPO / "bike_rig_msgs" / "srv"
Fields = list[tuple[str, Any]]


def definition(name: str) -> Fields:
    """The fields of a message (or ``<Service>Response``), in order, as rosbags parses them."""
    if name.endswith("Response"):
        text = (SRV_DIR / f"{name.removesuffix('Response')}.srv").read_text().split("---", 1)[1]
    else:
        text = (MSG_DIR / f"{name}.msg").read_text()
    typename = f"bike_rig_msgs/msg/{name}"
    return list(get_types_from_msg(text, typename)[typename][1])


def _sentinel(index: int, field: str, desc: Any) -> Any:
    """A value of the field's type, unlike its default and unlike other fields'."""
    kind, detail = desc
    if kind == Nodetype.NAME:
        return ("header", 1_700_000_000 + index, 123_456_789 + index, f"frame-{index}")
    if kind == Nodetype.BASE:
        base = detail[0]
        if base == "string":
            return f"{field}-{index}"
        if base == "bool":
            return True
        if base.startswith("float"):
            return 1.25 + index
        return 3 + index
    (item, _), size = detail
    n = size or 3
    if item == Nodetype.BASE and detail[0][1][0] == "string":
        return [f"{field}{i}" for i in range(n)]
    return np.arange(n) + 0.5 + index


def sentinels(name: str) -> dict[str, Any]:
    return {field: _sentinel(i, field, desc) for i, (field, desc) in enumerate(definition(name))}


# ------------------------------------------------------- values the records accept


def _trial_event(v: dict[str, Any]) -> None:
    v["kind"] = 2  # ABORT


def _period_estimate(v: dict[str, Any]) -> None:
    v["flags"], v["flag_reasons"] = ["no_stop", "constant"], ["no STOP event", "flat"]


def _static_readings(v: dict[str, Any]) -> None:
    v["keys"] = ["mB", "mF", "mR"]


def _benchmark_parameters(v: dict[str, Any]) -> None:
    n = len(PARAMETER_NAMES)
    rng = np.random.default_rng(3)
    a = rng.normal(size=(n, n))
    cov = a @ a.T + n * np.eye(n)
    v.update(
        names=list(PARAMETER_NAMES),
        values=np.arange(n) + 1.5,
        covariance=cov.reshape(-1),
        sigmas=np.sqrt(np.diag(cov)),
        complete=True,
        period_keys=["TtB1", "TcH1"],
        period_values=np.array([2.1, 1.3]),
        period_sigmas=np.array([1e-4, 2e-4]),
        trial_ids=["TtB1:a", "TtB1:b", "TcH1:c"],
        com_method=ComMethod.LEAST_SQUARES.value,
    )


def _sigma_convention(v: dict[str, Any]) -> None:
    v["sigma_convention"] = SigmaConvention.PAPER.value


def _eigen_sweep(v: dict[str, Any]) -> None:
    v["speeds"] = np.array([0.0, 2.5, 5.0])
    v["mode_labels"] = ["weave", "capsize", "caster", "weave2"]
    v["eigenvalues_real"] = np.arange(12) - 5.5
    v["eigenvalues_imag"] = np.arange(12) * 0.25


def _state_space_response(v: dict[str, Any]) -> None:
    v["ok"] = True


# ------------------------------------------------------- the converters of each message

Read = Callable[[Any], Any]
Fill = Callable[[Any, Any, Any], Any]
#: name -> (read, fill, adjust the sentinels); ``fill`` gets (fresh message, record, original message).
CONVERTERS: dict[str, tuple[Read, Fill, Callable[[dict[str, Any]], None] | None]] = {
    "TrialEvent": (conv.trial_event_from_msg, lambda m, r, _: conv.fill_trial_event(m, r), _trial_event),
    "GyroBatch": (conv.sample_batch_from_msg, lambda m, r, _: conv.fill_gyro_batch(m, r), None),
    "PeriodEstimate": (conv.trial_fit_from_msg, lambda m, r, _: conv.fill_period_estimate(m, r), _period_estimate),
    "FitDetails": (conv.fit_details_from_msg, lambda m, r, _: conv.fill_fit_details(m, r), None),
    "ReadingEntry": (conv.reading_entry_from_msg, lambda m, r, _: conv.fill_reading_entry(m, r), None),
    "StaticReadings": (
        conv.static_readings_from_msg,
        lambda m, r, o: conv.fill_static_readings(m, r, document=o.document),  # the file's text: not in the record
        _static_readings,
    ),
    "BenchmarkParameters": (
        conv.session_parameters_from_msg,
        lambda m, r, _: conv.fill_benchmark_parameters(m, r),
        _benchmark_parameters,
    ),
    "CanonicalMatrices": (
        conv.model_matrices_from_msg,
        lambda m, r, _: conv.fill_canonical_matrices(m, r),
        _sigma_convention,
    ),
    "EigenSweep": (conv.stability_sweep_from_msg, lambda m, r, _: conv.fill_eigen_sweep(m, r), _eigen_sweep),
    "StateSpaceModel": (
        conv.state_space_model_from_msg,
        lambda m, r, _: conv.fill_state_space_model(m, r),
        _sigma_convention,
    ),
    "StateSpaceResponse": (
        lambda m: conv.state_space_from_response(m, 4.5),
        lambda m, r, o: conv.fill_state_space_response(m, r, o.message),  # the reason: not in the record
        _state_space_response,
    ),
}


# ------------------------------------------------------- message kinds


def _store() -> Any:
    store = get_typestore(Stores.ROS2_KILTED)
    for path in sorted(MSG_DIR.glob("*.msg")):
        store.register(get_types_from_msg(path.read_text(), f"bike_rig_msgs/msg/{path.stem}"))
    store.register(definition_types("StateSpaceResponse"))
    return store


def definition_types(name: str) -> dict[str, Any]:
    text = (SRV_DIR / f"{name.removesuffix('Response')}.srv").read_text().split("---", 1)[1]
    return dict(get_types_from_msg(text, f"bike_rig_msgs/msg/{name}"))


STORE = _store()


def _zero(desc: Any) -> Any:
    kind, detail = desc
    if kind == Nodetype.NAME:
        return ("header", 0, 0, "")
    if kind == Nodetype.BASE:
        return {"string": "", "bool": False}.get(detail[0], 0.0 if detail[0].startswith("float") else 0)
    (item, _), size = detail
    if item == Nodetype.BASE and detail[0][1][0] == "string":
        return [""] * size
    return np.zeros(size)


def rosbags_message(name: str, values: dict[str, Any] | None = None) -> Any:
    """Rosbags' dataclass of the message with ``values`` (default: every field at its zero)."""
    values = values or {f: _zero(d) for f, d in definition(name)}
    kwargs = {}
    for field, value in values.items():
        if isinstance(value, tuple) and value[0] == "header":
            time = STORE.types["builtin_interfaces/msg/Time"](sec=value[1], nanosec=value[2])
            value = STORE.types["std_msgs/msg/Header"](stamp=time, frame_id=value[3])
        kwargs[field] = np.asarray(value, dtype=np.float64) if isinstance(value, np.ndarray) else value
    return STORE.types[f"bike_rig_msgs/msg/{name}"](**kwargs)


def rclpy_message(name: str, values: dict[str, Any] | None = None) -> Any:
    """Rclpy's message (or service response) with ``values`` (default: a fresh one)."""
    if name.endswith("Response"):
        import bike_rig_msgs.srv as srvs

        msg = getattr(srvs, name.removesuffix("Response")).Response()
    else:
        import bike_rig_msgs.msg as msgs

        msg = getattr(msgs, name)()
    for field, value in (values or {}).items():
        if isinstance(value, tuple) and value[0] == "header":
            msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = value[1:]
        else:
            setattr(msg, field, value.tolist() if isinstance(value, np.ndarray) else value)
    return msg


KINDS = {"rosbags": rosbags_message, "rclpy": rclpy_message}


def _as_plain(value: Any) -> Any:
    if hasattr(value, "stamp"):
        return ("header", int(value.stamp.sec), int(value.stamp.nanosec), str(value.frame_id))
    if isinstance(value, str | bool | int | float):
        return value
    items = list(value)
    return [str(x) for x in items] if items and isinstance(items[0], str) else np.asarray(items, dtype=float)


# ------------------------------------------------------- the tests


def test_every_message_has_converters() -> None:
    names = {p.stem for p in MSG_DIR.glob("*.msg")} | {"StateSpaceResponse"}
    assert names == set(CONVERTERS)


@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("name", sorted(CONVERTERS))
def test_every_field_survives_a_round_trip(name: str, kind: str) -> None:
    read, fill, adjust = CONVERTERS[name]
    values = sentinels(name)
    if adjust is not None:
        adjust(values)
    make = KINDS[kind]
    msg = make(name, values)
    record = read(msg)
    back = fill(make(name), record, msg)
    names = {f.name for f in dataclasses.fields(record)}
    lost = []
    for field, _ in definition(name):
        if field == "header" and "stamp_ns" not in names:
            continue  # a header its converters leave to the publisher
        want, got = _as_plain(getattr(msg, field)), _as_plain(getattr(back, field))
        if field == "header" and "frame_id" not in names:
            want, got = want[:3], got[:3]  # the stamp is the record's, the frame the publisher's
        same = np.allclose(got, want, rtol=1e-12, atol=0) if isinstance(want, np.ndarray) else got == want
        if not same:
            lost.append(f"{field}: sent {want!r}, got back {got!r}")
    assert lost == []


def test_a_missing_field_is_caught() -> None:
    """The check itself: a message whose converter forgets a field does not come back whole."""
    values = sentinels("ReadingEntry")
    msg = rosbags_message("ReadingEntry", values)
    entry = conv.reading_entry_from_msg(msg)
    back = rosbags_message("ReadingEntry")
    from bike_rig.messages.fields import fill_fields

    fill_fields(back, entry, skip=("note",))
    assert back.note != msg.note and back.key == msg.key


def test_an_unknown_enum_value_is_a_message_error() -> None:
    values = sentinels("TrialEvent")
    values["kind"] = 9
    with pytest.raises(conv.MessageError, match=r"kind: unknown 9"):
        conv.trial_event_from_msg(rosbags_message("TrialEvent", values))


def test_record_fields_leaves_out_what_the_message_lacks() -> None:
    from bike_rig.pipeline.model import StabilitySweep

    got = record_fields(StabilitySweep, rosbags_message("EigenSweep", sentinels("EigenSweep")))
    assert set(got) == {"bicycle", "rider"}
