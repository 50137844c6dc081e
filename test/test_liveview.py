"""The Foxglove layout shipped in ``config/foxglove/``, checked against what the bridge serves.

Every panel refers to a topic the bridge advertises (:data:`bike_rig.ros.liveview.VIEW_TOPICS`) or
to the output of one of the layout's user scripts, and every field it names exists: in the
message definition (the ``ros2msg`` text the bridge and the recorder send) or in the script's
output type. Every field a script reads exists in its inputs' definitions. The layout's rig
topics are all recorded (:data:`bike_rig.config.topics.TOPICS`), so it opens a recorded bag as well;
``/diagnostics`` is the exception until the recorder records it (a documented expectation).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

import pytest

from bike_rig.bag.typestore import store_for
from bike_rig.config.paths import config_dir
from bike_rig.config.topics import TOPICS
from bike_rig.ros.liveview import DIAGNOSTICS, LAYOUT_FILE, VIEW_TOPICS, GraphPresence, schema_text

SCRIPT_PREFIX = "/studio_script/"
VIEW_TYPES = {v.name: v.type for v in VIEW_TOPICS}


@pytest.fixture(scope="module")
def layout() -> dict[str, Any]:
    return dict(json.loads((config_dir() / LAYOUT_FILE).read_text(encoding="utf-8")))


def scripts(layout: dict[str, Any]) -> dict[str, str]:
    """Each user script's output topic → its source."""
    out = {}
    for script in layout["userNodes"].values():
        src = script["sourceCode"]
        match = re.search(r'export const output = "([^"]+)";', src)
        assert match, f"script {script['name']!r} declares no output"
        out[match.group(1)] = src
    return out


def script_inputs(src: str) -> list[str]:
    match = re.search(r"export const inputs = \[([^\]]*)\];", src)
    assert match, "a script declares no inputs"
    return re.findall(r'"([^"]+)"', match.group(1))


def panel_ids(tree: Any) -> Iterator[str]:
    """The panel ids of a layout tree (a panel id, or a split of two trees)."""
    if isinstance(tree, str):
        yield tree
    else:
        yield from panel_ids(tree["first"])
        yield from panel_ids(tree["second"])


def message_paths(config: dict[str, Any]) -> list[str]:
    """Every message path a panel's configuration names."""
    out = [config[k] for k in ("topicPath", "topicToRender") if config.get(k)]
    out += [p["value"] for p in config.get("paths", [])]
    if "xAxisPath" in config:
        out.append(config["xAxisPath"]["value"])
    return out


def split_path(path: str, topics: set[str]) -> tuple[str, list[str]]:
    """A message path's topic (the longest known one it starts with) and its field names."""
    topic = max((t for t in topics if path == t or path.startswith(t + ".")), key=len, default="")
    assert topic, f"{path}: no topic the bridge advertises or a script outputs"
    fields = [re.sub(r"\[.*?\]", "", part) for part in path[len(topic) :].split(".") if part]
    return topic, fields


def fields_of(msgtype: str) -> dict[str, Any]:
    """A type's fields: name → (node type, spec), as rosbags parses the definition."""
    _, fields = store_for(msgtype).fielddefs[msgtype]
    return dict(fields)


def assert_field_path(msgtype: str, fields: list[str], where: str) -> None:
    """Each field exists, nested messages (also inside arrays) followed."""
    current = msgtype
    for name in fields:
        defs = fields_of(current)
        assert name in defs, f"{where}: {current} has no field {name!r} (fields: {', '.join(defs)})"
        nodetype, spec = defs[name]
        if nodetype == 2:
            current = spec
        elif nodetype in (3, 4) and spec[0][0] == 2:
            current = spec[0][1]


def output_fields(src: str) -> set[str]:
    """The field names of a script's ``Output`` type."""
    match = re.search(r"type Output = \{(.*?)\};", src, re.S)
    assert match, "a script has no Output type"
    return set(re.findall(r"(\w+):", match.group(1)))


def test_every_panel_is_placed_and_every_placed_panel_configured(layout: dict[str, Any]) -> None:
    placed = list(panel_ids(layout["layout"]))
    assert sorted(placed) == sorted(layout["configById"]), "panels placed and panels configured differ"
    kinds = {pid.split("!")[0] for pid in placed}
    assert {"Plot", "Table", "DiagnosticSummary"} <= kinds


def test_every_panel_path_names_an_advertised_topic_and_existing_fields(layout: dict[str, Any]) -> None:
    outputs = scripts(layout)
    topics = set(VIEW_TYPES) | set(outputs)
    seen: set[str] = set()
    for pid, config in layout["configById"].items():
        paths = message_paths(config)
        assert paths, f"{pid} shows nothing"
        for path in paths:
            topic, fields = split_path(path, topics)
            seen.add(topic)
            if topic in VIEW_TYPES:
                assert_field_path(VIEW_TYPES[topic], fields, f"{pid} {path}")
            elif fields:  # (no field: the whole output, e.g. in a raw-messages panel)
                assert fields[0] in output_fields(outputs[topic]), f"{pid} {path}: not in the script's Output"
    used_rig = {t for t in seen if t in VIEW_TYPES} | {i for o in outputs.values() for i in script_inputs(o)}
    for wanted in (
        "/bike_rig/gyro",
        "/bike_rig/trial_events",
        "/bike_rig/periods",
        "/bike_rig/parameters",
        "/bike_rig/model/eigen_sweep",
        DIAGNOSTICS.name,
    ):
        assert wanted in used_rig, f"the layout does not show {wanted}"


def test_every_script_reads_fields_its_inputs_have(layout: dict[str, Any]) -> None:
    for output, src in scripts(layout).items():
        assert output.startswith(SCRIPT_PREFIX), f"{output}: Foxglove's script outputs start with {SCRIPT_PREFIX}"
        inputs = script_inputs(src)
        assert inputs and all(i in VIEW_TYPES for i in inputs), f"{output}: inputs {inputs} not all served"
        known = set().union(*(fields_of(VIEW_TYPES[i]) for i in inputs))
        read = set(re.findall(r"\bm\.(\w+)", src))
        assert read, f"{output}: reads no field (the scripts name the input message m)"
        assert read <= known, f"{output}: reads {sorted(read - known)}, which its inputs do not have"


def test_the_layout_opens_a_recorded_bag(layout: dict[str, Any]) -> None:
    outputs = scripts(layout)
    used = {
        split_path(p, set(VIEW_TYPES) | set(outputs))[0]
        for c in layout["configById"].values()
        for p in message_paths(c)
    }
    used = {t for t in used if t in VIEW_TYPES} | {i for o in outputs.values() for i in script_inputs(o)}
    recorded = {t.name for t in TOPICS}
    # /diagnostics: recorded once the recorder takes it in (issue 15, section 1); live only until then
    assert used - {DIAGNOSTICS.name} <= recorded, sorted(used - recorded)


def test_schemas_are_the_message_definitions() -> None:
    for view in VIEW_TOPICS:
        if view.name == DIAGNOSTICS.name:
            continue
        text = schema_text(view.type)
        for name in fields_of(view.type):
            assert re.search(rf"^\S+ {name}\b", text, re.M), f"{view.type}: {name} not in its schema text"


def test_graph_presence_says_none_after_the_grace_then_each_change() -> None:
    presence = GraphPresence(domain_id=17, grace_s=5.0)
    assert presence.update(1.0, set(), set()) is None  # discovery still running: nothing said yet
    none = presence.update(5.0, set(), {"someone_else"})
    assert none is not None and none.startswith("no bike_rig graph found on ROS_DOMAIN_ID=17: ")
    assert "bike-rig view --domain-id N" in none
    assert presence.update(6.0, set(), set()) is None  # said once
    found = presence.update(9.0, {"/bike_rig/gyro"}, {"fitter", "driver"})
    assert found == "found a bike_rig graph on ROS_DOMAIN_ID=17: nodes driver, fitter"
    assert presence.update(10.0, {"/bike_rig/gyro"}, {"driver"}) is None
    gone = presence.update(11.0, set(), set())
    assert gone is not None and gone.startswith("the bike_rig graph on ROS_DOMAIN_ID=17 is gone")
    assert presence.update(30.0, set(), set()) is None


def test_a_graph_there_from_the_start_is_found_at_once() -> None:
    presence = GraphPresence(domain_id=0)
    assert presence.update(0.0, {"/bike_rig/periods"}, set()) == (
        "found a bike_rig graph on ROS_DOMAIN_ID=0: nodes (names not yet discovered)"
    )
