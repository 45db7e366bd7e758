"""The OPC-UA name map: every name bound to a real field of its message, units by their
UNECE codes, writable exactly where the console can write, the sources read from the
topics the graph declares for the gateway, and the documented table."""

import math

import pytest

from drill_bag.well_log import LOG_TOPICS
from drill_hmi import console_state as cs
from drill_bag import mcap_io
from drill_core.rig_root import rig_root
from drill_ros import graph
from drill_gateway import opcua_names as names
from drill_gateway.opcua_node import MeasuredView, source_topics

ROOT = rig_root()


def test_every_variable_reads_an_existing_field_of_its_source():
    for v in names.VARIABLES:
        if v.derived:                   # computed by the node (opcua_node.MeasuredView)
            continue
        msg_type = graph.BY_TOPIC[source_topics()[v.source]].type
        fields = mcap_io.message_class(msg_type).get_fields_and_field_types()
        assert v.field in fields, f"{'/'.join(v.path)}: {v.field} not in {msg_type}"
        expected = {"float": "double", "bool": "boolean", "text": "string"}[v.kind]
        assert fields[v.field] == expected, v.path


def test_browse_paths_are_unique_and_units_are_given_for_every_number():
    paths = [v.path for v in names.VARIABLES]
    assert len(set(paths)) == len(paths)
    assert all((v.unit is not None) == (v.kind == "float") for v in names.VARIABLES)


def test_unit_ids_are_the_unece_codes_as_opc_ua_part_8_packs_them():
    assert names.UNITS["Pa"].unit_id == 0x50414C         # "PAL"
    assert names.UNITS["m"].unit_id == 5067858           # "MTR" = 0x4D5452
    assert names.UNITS["N"].unit_id == 0x4E4557          # "NEW"
    assert {u.code for u in names.UNITS.values()} == {"PAL", "MTR", "MTS", "MQS", "MTQ", "KMQ",
                                                      "NEW"}


def test_the_writable_variables_are_the_setpoints_and_the_automation_level():
    writable = {v.field for v in names.VARIABLES if v.writable and v.source == "setpoints"}
    form = {spec.setpoint for spec in cs.FORM_FIELDS.values()} | set(cs.BOOL_FIELDS)
    assert writable == form                   # what the console lets an operator change
    assert [v.name for v in names.VARIABLES if v.source == "level"] == ["AutomationLevel"]
    assert not any(v.writable for v in names.VARIABLES if v.source in ("measurement", "estimate"))


def test_the_sources_are_the_topics_the_graph_declares_for_the_gateway():
    assert set(source_topics()) == set(names.SOURCES)
    frames = {topic for topic in LOG_TOPICS if topic not in source_topics().values()}
    assert set(source_topics().values()) | frames == \
        set(graph.BY_NAME["opcua_gateway"].subscribes)


def test_the_derived_variables_are_the_ones_the_node_computes(cfg):
    from drill_msgs.msg import RigMeasurement
    view = MeasuredView(cfg.well)
    view.live.on_measurement(RigMeasurement(bhp_pa=6.85e7, block_position_m=1.0))
    computed = view.fields()
    assert {v.field for v in names.by_source("measurement")} == set(computed)
    assert computed["bit_depth_m"] == pytest.approx(3296.7 + 251.1 + 60.0 - 1.0)   # well.yaml
    assert math.isnan(computed["spp_pa"])                  # no mud pump frame yet


def test_names_are_d_wis_prototypes_where_given_and_floats_have_a_range():
    prototypes = {"DownholePressure", "MPDChokePressure", "SPP", "DownholeECD", "HookLoad", "HookPosition",
                  "BitDepth", "FlowRateIn", "FlowRateOut", "ActiveVolume", "MPDPumpFlowRate",
                  "HookVelocity"}        # DDHub DrillingDataSemantics PrototypeData nouns
    assert all(v.prototype in prototypes for v in names.VARIABLES if v.prototype)
    assert all(v.name == v.prototype for v in names.VARIABLES if v.prototype)
    for v in names.VARIABLES:
        assert (v.eu_range is not None) == (v.kind == "float"), v.path
        if v.eu_range:
            assert v.eu_range[0] < v.eu_range[1], v.path


def test_the_documented_table_is_the_map():
    doc = (ROOT / "docs" / "gateways.md").read_text(encoding="utf-8")
    assert names.markdown_table(source_topics()) in doc, \
        "regenerate it: python -m drill_gateway.opcua_table"
