"""config/foxglove/rig-layout.json stays true: every message path in it names a topic of
the graph and a field of that topic's message type (an index only on an array field),
and the panels the live view promises are there."""
import json
import re

from drill_bag import mcap_io
from drill_core.rig_root import rig_root
from drill_ros import graph, topics

ROOT = rig_root()
LAYOUT = ROOT / "config" / "foxglove" / "rig-layout.json"
PATH = re.compile(r"^(?P<topic>/[A-Za-z0-9_/]+?)(?:\.(?P<field>[a-z0-9_]+)(?P<index>\[\d+\])?)?$")


def message_paths(layout: dict) -> list[str]:
    out = []
    for config in layout["configById"].values():
        out += [series["value"] for series in config.get("paths", [])]
        if "topicPath" in config:
            out.append(config["topicPath"])
    return out


def leaves(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    return leaves(node["first"]) + leaves(node["second"])


def test_every_message_path_names_a_declared_topic_and_a_field_of_its_type():
    layout = json.loads(LAYOUT.read_text(encoding="utf-8"))
    paths = message_paths(layout)
    assert len(paths) > 20
    wrong = []
    for path in paths:
        match = PATH.match(path)
        if not match or match["topic"] not in graph.BY_TOPIC:
            wrong.append(f"{path}: not a topic of drill_ros.graph")
            continue
        if match["field"] is None:
            continue
        fields = mcap_io.message_class(graph.BY_TOPIC[match["topic"]].type).get_fields_and_field_types()
        kind = fields.get(match["field"])
        if kind is None:
            wrong.append(f"{path}: {graph.BY_TOPIC[match['topic']].type} has no field {match['field']}")
        elif match["index"] and not kind.startswith("sequence<"):
            wrong.append(f"{path}: {match['field']} is not an array")
    assert not wrong, "\n".join(wrong)


def test_the_layout_shows_what_the_live_view_promises_and_places_every_panel():
    layout = json.loads(LAYOUT.read_text(encoding="utf-8"))
    paths = set(message_paths(layout))
    promised = {topics.MEASUREMENT + ".bhp_pa", topics.ESTIMATE + ".bhp_pa", topics.TRUTH + ".bhp_pa",
                topics.TRUTH + ".pore_pressure_pa", topics.TRUTH + ".fracture_pressure_pa",
                topics.MEASUREMENT + ".choke_dp_pa", topics.MEASUREMENT + ".block_position_m",
                topics.ESTIMATE + ".string_velocity_mps", topics.NMPC_STATUS + ".solve_time_s",
                topics.NMPC_STATUS + ".fallback_count",
                *(topics.actuator_frame(a) + f for a in topics.ACTUATORS
                  for f in (".command", ".output[0]"))}
    assert promised <= paths, sorted(promised - paths)
    assert sorted(leaves(layout["layout"])) == sorted(layout["configById"])
