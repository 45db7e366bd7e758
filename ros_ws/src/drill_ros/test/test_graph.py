"""The graph declaration: run node sets, the lockstep endpoints the plant waits for, and
docs/architecture.md's topic table generated from it."""

import pytest

from drill_core.rig_root import rig_root
from drill_ros import graph, topics

ROOT = rig_root()
FRAMES = [topics.actuator_frame(n) for n in topics.ACTUATORS]


def test_a_closed_loop_run_has_its_advisor_and_the_protection():
    names = [n.name for n in graph.run_nodes("nmpc", fast=True)]
    assert names == ["recorder", *topics.ACTUATORS, "estimator", "nmpc", "protection", "plant"]
    assert "sequencer" in [n.name for n in graph.run_nodes("open_loop", fast=True)]
    assert "console" in [n.name for n in graph.run_nodes("baseline", fast=False)]
    with pytest.raises(ValueError, match="mpc2"):
        graph.run_nodes("mpc2", fast=True)


def test_the_nmpc_lockstep_waits_for_every_endpoint_of_the_protocol():
    # docs/architecture.md, fast mode: who reads what in frame k (counted by hand)
    expected = {
        "sub@/rig/measurement:7",            # 4 actuators, estimator, protection, recorder
        "sub@/rig/truth:1",                  # recorder only: no controller reads the truth
        "sub@/rig/events:1",                 # recorder only (and the console, in realtime)
        "sub@/estimator/estimate:2", "pub@/estimator/estimate:1",      # nmpc, recorder
        "sub@/clock:1",                      # recorder
        "sub@/supervisor/command:2", "pub@/supervisor/command:1",      # protection, recorder
        "sub@/rig/command:6", "pub@/rig/command:1",            # 4 actuators, nmpc, recorder
        "sub@/actuators/choke/frame:4",      # plant, estimator, protection, recorder
        "sub@/actuators/drawworks/frame:5",  # and nmpc
        *(f"sub@/actuators/{n}/frame:4" for n in ("bpp", "mud_pump")),  # plant, estimator,
                                                                        # nmpc, recorder
        *(f"pub@{f}:1" for f in FRAMES),
    }
    nodes = graph.run_nodes("nmpc", fast=True)
    assert set(graph.lockstep_endpoints(nodes, fast=True)) == expected


def test_a_drilling_run_is_its_own_node_set():
    nodes = graph.run_nodes("none", fast=True, kind="drilling")
    assert [n.name for n in nodes] == ["recorder", "driller", *topics.DRILLING_ACTUATORS,
                                       "drilling_plant"]
    assert [n.name for n in nodes if n.plant] == ["drilling_plant"]
    with pytest.raises(ValueError, match="milling"):
        graph.run_nodes("none", fast=True, kind="milling")


def test_the_drilling_lockstep_waits_for_every_endpoint_of_its_protocol():
    # drilling plant publishes surface, downhole, truth and /clock at t_k; the driller
    # answers on the command period, the two drives on every frame
    drives = [topics.actuator_frame(n) for n in topics.DRILLING_ACTUATORS]
    expected = {
        "sub@/drilling/surface:4",           # driller, top drive, block feed, recorder
        "sub@/drilling/downhole:1", "sub@/drilling/truth:1", "sub@/clock:1",   # recorder
        "sub@/drilling/command:3", "pub@/drilling/command:1",   # the drives, recorder
        *(f"sub@{f}:2" for f in drives),     # drilling plant, recorder
        *(f"pub@{f}:1" for f in drives),
    }
    nodes = graph.run_nodes("none", fast=True, kind="drilling")
    assert set(graph.lockstep_endpoints(nodes, fast=True)) == expected
    local = graph.local_subscriptions("two", nodes)      # drives and plant in one container
    assert set(graph.lockstep_endpoints(nodes, True, local)) == expected - {
        "sub@/drilling/surface:4", "sub@/drilling/command:3", *(f"sub@{f}:2" for f in drives)} | {
        "sub@/drilling/surface:2", "sub@/drilling/command:2",    # the drives share one
        *(f"sub@{f}:1" for f in drives)}


def test_a_container_takes_a_topic_published_elsewhere_once():
    nodes = graph.run_nodes("nmpc", fast=True)
    local = graph.local_subscriptions("two", nodes)
    endpoints = set(graph.lockstep_endpoints(nodes, True, local))
    # the control process (estimator, nmpc, protection) and the recorder read the plant
    # process's measurement and frames: one subscription each, whoever reads them there
    assert "sub@/rig/measurement:2" in endpoints
    assert {f"sub@{f}:2" for f in FRAMES} <= endpoints
    assert "sub@/rig/command:2" in endpoints         # the four actuators share one
    assert local["estimator"] == frozenset()         # the first reader subscribes
    assert {"/rig/measurement"} <= local["protection"]
    assert set(FRAMES) - {topics.actuator_frame("choke")} <= local["nmpc"]


def test_no_estimator_or_controller_reads_the_truth():
    for node in graph.NODES:
        if node.name == "estimator" or node.controller:
            assert not node.subscribes_to(topics.TRUTH), node.name


def test_only_the_plant_the_actuators_and_the_recorder_are_given_the_plants_mismatch():
    given = {node.name for node in graph.NODES if node.truth_side}
    assert given == {"plant", "recorder", *topics.ACTUATORS}
    for node in graph.NODES:
        if node.name in ("estimator", "protection") or node.controller:
            assert not node.truth_side, node.name


def test_the_documented_topic_table_is_the_declared_one():
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert graph.markdown_table() in doc, "regenerate it: python -m drill_ros.graph"


def test_every_reliable_first_message_waits_for_its_readers_but_latched_ones_do_not():
    nodes = graph.run_nodes("nmpc", fast=True)
    by_name = {n.name: n for n in nodes}
    gates = {name: dict(spec.rsplit(":", 1) for spec in
                        graph.first_publish_matches(n, nodes)) for name, n in by_name.items()}
    # the plant's lockstep topics and its status (the recorder reads every topic)
    assert gates["plant"][topics.MEASUREMENT] == "7"
    assert gates["plant"][topics.status("plant")] == "1"
    # the NMPC's status and events are gated on the recorder; the latched setpoints are not
    assert gates["nmpc"][topics.NMPC_STATUS] == "1"
    assert gates["nmpc"][topics.OPERATOR_EVENTS] == "1"
    assert topics.SETPOINTS not in gates["nmpc"] and graph.latched(topics.SETPOINTS)
    # the recorder does not wait for itself to read its own status
    assert topics.status("recorder") not in gates["recorder"]


def test_a_multi_stand_trip_adds_the_rig_floor_and_everyone_waits_for_it():
    plain = graph.run_nodes("baseline", fast=True)
    trip = graph.run_nodes("baseline", fast=True, multi_stand=True)
    assert "rig_floor" not in [n.name for n in plain]
    assert set(n.name for n in trip) == set(n.name for n in plain) | {"rig_floor"}
    endpoints = graph.lockstep_endpoints(trip, fast=True)
    # plant, drawworks, mud pump, estimator, baseline, protection, recorder
    assert "sub@/rig/floor:7" in endpoints and "pub@/rig/floor:1" in endpoints
    assert not any("/rig/floor" in e for e in graph.lockstep_endpoints(plain, fast=True))
    assert "rig_floor" in [n.name for n in dict(graph.process_groups("two", trip))["plant"]]
