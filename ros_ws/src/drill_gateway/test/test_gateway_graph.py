"""The gateways in the graph: optional nodes, in a run only when asked for, readers the
plant waits for like any other, never readers of the truth that decide anything."""
import pytest

from drill_bringup import launcher
from drill_ros import graph, topics


def test_the_gateways_join_a_run_only_when_asked_for():
    plain = [n.name for n in graph.run_nodes("nmpc", fast=True)]
    assert "foxglove_bridge" not in plain and "opcua_gateway" not in plain
    both = [n.name for n in graph.run_nodes("nmpc", True, extras=("foxglove_bridge", "opcua_gateway"))]
    assert both == [*plain[:-1], "foxglove_bridge", "opcua_gateway", "plant"]
    drilling = graph.run_nodes("none", True, "drilling", extras=("foxglove_bridge",))
    assert "foxglove_bridge" in [n.name for n in drilling]


def test_an_unknown_or_misplaced_gateway_is_refused_by_name():
    with pytest.raises(ValueError, match="'console' is not one of foxglove_bridge, opcua_gateway"):
        graph.run_nodes("nmpc", True, extras=("console",))
    with pytest.raises(ValueError, match="opcua_gateway does not run in a drilling scenario"):
        graph.run_nodes("none", True, "drilling", extras=("opcua_gateway",))


def test_the_plant_waits_for_the_gateways_subscriptions_too():
    nodes = graph.run_nodes("nmpc", True, extras=("foxglove_bridge", "opcua_gateway"))
    endpoints = set(graph.lockstep_endpoints(nodes, fast=True))
    # measurement: 4 actuators, estimator, protection, recorder + bridge + OPC-UA gateway
    assert "sub@/rig/measurement:9" in endpoints
    assert "sub@/rig/truth:2" in endpoints                  # recorder, bridge
    assert "sub@/clock:1" in endpoints                      # the bridge streams no /clock


def test_the_launcher_gives_each_gateway_its_parameters(tmp_path):
    nodes = launcher.graph("nmpc", {"mode": "fast"}, tmp_path / "x.mcap", fast=True,
                           extras={"foxglove_bridge": {"port": 9001}, "opcua_gateway": {}})
    by_name = {n.name: n for n in nodes}
    assert by_name["foxglove_bridge"].params["port"] == 9001
    assert by_name["foxglove_bridge"].module == "drill_gateway.foxglove_node"
    assert not by_name["opcua_gateway"].finishes


def test_no_gateway_feeds_a_controller():
    gateway = graph.BY_NAME["opcua_gateway"]
    assert not gateway.subscribes_to(topics.TRUTH)
    assert topics.COMMAND not in gateway.publishes and topics.MACHINE_COMMAND not in gateway.publishes


def test_in_a_split_run_a_gateway_runs_on_the_host_that_asks_for_it(monkeypatch, tmp_path):
    from drill_bringup import runs
    from drill_rig import cli
    started = {}

    class Started(Exception):
        pass

    def launch(nodes, run_dir, domain_id, layout, here, peers, **_):
        started.update(here=here)
        raise Started

    monkeypatch.setattr(runs.launcher, "Launch", launch)
    with pytest.raises(Started):
        cli.main(["run", "short_trip", "--runs-dir", str(tmp_path), "--nodes", "plant",
                  "--domain", "77", "--foxglove"])
    assert started["here"] == {"plant", "foxglove_bridge"}   # the plant waits for its readers


@pytest.mark.parametrize("argv, extras", [
    ([], {}),
    (["--foxglove"], {"foxglove_bridge": {}}),
    (["--foxglove", "0"], {"foxglove_bridge": {"port": 0}}),             # a free port
    (["--foxglove", "9001", "--opcua"], {"foxglove_bridge": {"port": 9001}, "opcua_gateway": {}}),
    (["--opcua", "opc.tcp://0.0.0.0:4840/drill-rig"],
     {"opcua_gateway": {"endpoint": "opc.tcp://0.0.0.0:4840/drill-rig"}}),
])
def test_rig_run_adds_the_gateways_asked_for(monkeypatch, argv, extras):
    from drill_rig import cli
    asked = {}
    monkeypatch.setattr(cli, "run_scenario", lambda *a, **kw: asked.update(kw) or (0, None))
    assert cli.main(["run", "short_trip", *argv]) == 0
    assert asked["extras"] == extras
