"""A run split across hosts (docs/multihost.md), without ROS: the options checked before
launch, the environment each flag sets, which processes a host's share starts and when
its watch says the run has ended."""
from pathlib import Path

import pytest

from drill_bringup import finish_watch, launcher
from drill_bringup.split_run import split_options
from drill_ros import topics
from drill_ros.graph import SelectionError

COMMON = {"config_dir": "/c", "scenario": "/c/s.yaml", "mode": "fast"}
PLANT_SIDE = {"recorder", "plant", *topics.ACTUATORS}
CONTROL_SIDE = {"estimator", "nmpc", "protection"}


def _nodes(fast: bool = True, controller: str = "nmpc"):
    mode = "fast" if fast else "realtime"
    return launcher.graph(controller, dict(COMMON, mode=mode), Path("/r/x.mcap"), fast=fast)


def test_peers_are_split_on_commas_and_checked():
    assert split_options("plant", 77, "10.0.0.2, rig-control.local") == (
        "10.0.0.2", "rig-control.local")
    assert split_options(None, None, None) == ()
    with pytest.raises(SelectionError, match="'fd00::2' is IPv6: Fast DDS takes IPv4 peers only"):
        split_options("plant", 77, "10.0.0.2,fd00::2")
    with pytest.raises(SelectionError, match="'bad host!' is not an IP address or host name"):
        split_options("plant", 77, "10.0.0.2,bad host!")
    with pytest.raises(SelectionError, match="no address given"):
        split_options("plant", 77, " , ")


def test_a_share_needs_a_domain_inside_the_valid_range():
    with pytest.raises(SelectionError, match="--nodes needs --domain"):
        split_options("plant", None, "10.0.0.2")
    with pytest.raises(SelectionError, match="--domain 102: a ROS domain id is 0..101"):
        split_options("plant", 102, None)
    assert split_options("plant", 0, None) == ()


def test_localhost_only_discovery_stays_the_default(monkeypatch):
    monkeypatch.setenv("ROS_STATIC_PEERS", "192.0.2.9")          # inherited: never used
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    env = launcher.isolated_env(17)
    assert env["ROS_DOMAIN_ID"] == "17"
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert "ROS_STATIC_PEERS" not in env
    assert env["RMW_IMPLEMENTATION"] == "rmw_fastrtps_cpp"


def test_peers_become_static_peers_with_the_range_left_at_localhost():
    env = launcher.isolated_env(77, ("10.231.7.2", "rig-control.local"))
    assert env["ROS_STATIC_PEERS"] == "10.231.7.2;rig-control.local"
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"   # no multicast
    assert env["ROS_DOMAIN_ID"] == "77"


def test_each_share_starts_its_own_nodes_and_watches_the_other_hosts_finishers(tmp_path):
    nodes = _nodes()
    plant_side = launcher.Launch(nodes, tmp_path, 77, here=PLANT_SIDE, peers=("10.0.0.2",))
    control_side = launcher.Launch(nodes, tmp_path, 77, here=CONTROL_SIDE, peers=("10.0.0.1",))
    started = [p.name for p in plant_side.processes] + [p.name for p in control_side.processes]
    assert sorted(started) == sorted([n.name for n in nodes] + ["finish_watch"] * 2)
    # the plant's host waits for the estimator's end (as a one-host run does), the
    # control host for the plant's
    assert plant_side.processes[-1].topics == (topics.ESTIMATE,)
    assert control_side.processes[-1].topics == (topics.MEASUREMENT,)
    assert plant_side.env["ROS_STATIC_PEERS"] == "10.0.0.2"
    # the plant still waits for every endpoint of the whole graph, not only its host's
    plant = next(n for n in nodes if n.name == "plant")
    assert "sub@/supervisor/command:2" in plant.params["wait_for"]


def test_a_share_with_every_finishing_node_needs_no_watch(tmp_path):
    nodes = _nodes()
    everything = {n.name for n in nodes} - {"nmpc"}
    launch = launcher.Launch(nodes, tmp_path, 77, here=everything)
    assert "finish_watch" not in [p.name for p in launch.processes]
    realtime = launcher.Launch(_nodes(fast=False), tmp_path, 77, here=CONTROL_SIDE)
    assert realtime.processes[-1].topics == (topics.MEASUREMENT,)   # the estimator runs on


def test_a_layout_process_cannot_be_cut_between_hosts(tmp_path):
    nodes = launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True, layout="two")
    with pytest.raises(SelectionError, match="process 'plant' holds drawworks, .*, plant; "
                                             "--nodes takes plant of them"):
        launcher.Launch(nodes, tmp_path, 77, layout="two", here={"plant", "recorder"})
    launch = launcher.Launch(nodes, tmp_path, 77, layout="two", here=PLANT_SIDE)
    assert [p.name for p in launch.processes] == ["recorder", "plant", "finish_watch"]


def test_the_watch_ends_only_once_every_watched_publisher_came_and_went():
    a, b = topics.MEASUREMENT, topics.ESTIMATE
    assert finish_watch.all_ended([{a: 0}, {a: 1}, {a: 1}, {a: 0}])
    assert not finish_watch.all_ended([{a: 0}, {a: 0}])           # never seen: not started
    assert not finish_watch.all_ended([{a: 0, b: 1}, {a: 1, b: 0}, {a: 1, b: 0}])
    assert finish_watch.all_ended([{a: 0, b: 1}, {a: 1, b: 0}, {a: 0, b: 0}])
    assert finish_watch.all_ended([{a: 1, b: 1}, {a: 0, b: 1}, {a: 1, b: 0}])  # gone stays gone


def test_the_watch_refuses_a_relative_topic(capsys):
    assert finish_watch.main(["rig/measurement"]) == 2
    assert "topics must be absolute names" in capsys.readouterr().err
    assert finish_watch.main([]) == 2


@pytest.mark.parametrize("flags, error", [
    (["--nodes", "plant,pump", "--domain", "77"], "unknown node or group 'pump'; allowed: "),
    (["--nodes", "plant"], "--nodes needs --domain"),
    (["--nodes", "plant", "--domain", "77", "--peers", "a b"], "'a b' is not an IP address"),
])
def test_rig_run_refuses_a_bad_share_before_anything_is_made(flags, error, runs_dir, capsys):
    from drill_rig import cli
    assert cli.main(["run", "short_trip", "--runs-dir", str(runs_dir), *flags]) == 2
    assert error in capsys.readouterr().err
    assert not runs_dir.exists()
