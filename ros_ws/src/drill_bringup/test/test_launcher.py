"""Launcher: the node set of a run, who runs on /clock, and unique node names."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from drill_bringup import launcher
from drill_ros import topics
from drill_ros.graph import default_layout

COMMON = {"config_dir": "/c", "scenario": "/c/s.yaml", "mode": "fast"}


def _by_name(nodes):
    return {n.name: n for n in nodes}


def test_fast_graph_clock_readers_match_the_plants_wait_list():
    nodes = _by_name(launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True))
    on_clock = sorted(name for name, n in nodes.items() if n.params["use_sim_time"])
    assert on_clock == ["recorder"]
    assert "sub@/clock:1" in nodes["plant"].params["wait_for"]
    assert not any(nodes[a].params["use_sim_time"] for a in topics.ACTUATORS)
    assert list(nodes)[0] == "recorder" and list(nodes)[-1] == "plant"
    assert sorted(name for name, n in nodes.items() if n.finishes) == ["estimator", "plant"]


def test_open_loop_graph_has_sequencer_and_protection_but_no_supervisor():
    names = [n.name for n in launcher.graph("open_loop", COMMON, Path("/r/x.mcap"), fast=True)]
    assert "sequencer" in names and "protection" in names
    assert "nmpc" not in names and "baseline" not in names


def test_realtime_graph_runs_on_wall_time_with_a_console():
    nodes = launcher.graph("baseline", dict(COMMON, mode="realtime"), Path("/r/x.mcap"), fast=False)
    assert not any(n.params["use_sim_time"] for n in nodes)
    assert "console" in _by_name(nodes)
    assert [n.name for n in nodes if n.finishes] == ["plant"]   # realtime: the estimator runs on


def test_repeated_node_names_are_refused(tmp_path):
    nodes = launcher.graph("nmpc", COMMON, tmp_path / "x.mcap", fast=False)
    nodes.append(launcher.NodeSpec.of("console", {"port": 0}))
    with pytest.raises(ValueError, match="console"):
        launcher.Launch(nodes, tmp_path, 1)


def test_default_domains_are_exclusive_while_held(monkeypatch, tmp_path):
    monkeypatch.setattr(launcher, "LOCK_DIR", tmp_path)
    monkeypatch.setattr(launcher, "_held_domains", {})
    taken = [launcher.default_domain_id() for _ in range(len(launcher.RUN_DOMAINS))]
    assert sorted(taken) == list(launcher.RUN_DOMAINS)      # each handed out once
    with pytest.raises(RuntimeError, match="in use"):
        launcher.default_domain_id()
    launcher.release_domain(taken[5])                        # given back: free again
    assert launcher.default_domain_id() == taken[5]
    for domain in taken:
        launcher.release_domain(domain)


def test_a_held_test_domain_is_no_other_processes(monkeypatch, tmp_path):
    """Two processes asking for the tests' domains at once (two parallel test workers) get
    different ones: the lock is an flock, exclusive across processes."""
    monkeypatch.setattr(launcher, "LOCK_DIR", tmp_path)
    monkeypatch.setattr(launcher, "_held_domains", {})
    mine = launcher.held_domain(launcher.TEST_DOMAINS)
    other = subprocess.run(
        [sys.executable, "-c", "import pathlib, sys; from drill_bringup import launcher; "
         f"launcher.LOCK_DIR = pathlib.Path({str(tmp_path)!r}); "
         "print(launcher.held_domain(launcher.TEST_DOMAINS))"],
        capture_output=True, text=True, check=True)
    assert int(other.stdout) in launcher.TEST_DOMAINS and int(other.stdout) != mine
    launcher.release_domain(mine)


def test_layouts_put_groups_in_one_process_and_the_recorder_alone():
    nodes = launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True)
    separate = launcher.processes(nodes)
    assert [p.name for p in separate] == [n.name for n in nodes]
    two = {p.name: p for p in launcher.processes(nodes, "two")}
    assert sorted(two) == ["control", "plant", "recorder"]
    assert [n.name for n in two["plant"].nodes] == [*topics.ACTUATORS, "plant"]
    assert [n.name for n in two["control"].nodes] == ["estimator", "nmpc", "protection"]
    assert two["plant"].finishes and two["control"].finishes and not two["recorder"].finishes
    command = two["plant"].command_line(Path("/r/logs/plant.finished"))
    assert command[1:3] == ["-m", "drill_ros.container"]
    assert command[5] == "/r/logs/plant.finished"
    specs = json.loads(command[4])
    assert [s["node_class"] for s in specs] == ["ActuatorNode"] * 4 + ["PlantNode"]
    assert specs[1]["ros_args"][:3] == ["--ros-args", "-r", "__node:=choke"]
    assert "actuator:=choke" in specs[1]["ros_args"]


def test_a_group_with_one_node_of_the_run_is_that_nodes_process():
    nodes = [n for n in launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True)
             if n.name in ("recorder", "drawworks", "plant")]
    assert [p.name for p in launcher.processes(nodes, "actuators")] == \
        ["recorder", "drawworks", "plant"]
    with pytest.raises(ValueError, match="layout 'three'"):
        launcher.processes(nodes, "three")


def test_a_container_takes_what_only_it_publishes_on_its_local_bus():
    two = launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True, layout="two")
    separate = launcher.graph("nmpc", COMMON, Path("/r/x.mcap"), fast=True)
    wait_two = _by_name(two)["plant"].params["wait_for"]
    wait_separate = _by_name(separate)["plant"].params["wait_for"]
    # the measurement reaches the control process (estimator and protection share one
    # subscription) and the recorder through DDS, not the actuators (they share the
    # plant's process); the frames reach the plant locally
    assert f"sub@{topics.MEASUREMENT}:7" in wait_separate
    assert f"sub@{topics.MEASUREMENT}:2" in wait_two
    frame = topics.actuator_frame("drawworks")     # recorder, estimator, nmpc, protection
    assert f"sub@{frame}:5" in wait_separate and f"sub@{frame}:2" in wait_two   # (and plant)
    assert f"sub@{topics.ESTIMATE}:1" in wait_two            # the recorder; nmpc is local
    processes = {p.name: p for p in launcher.processes(two, "two")}
    local = json.loads(processes["control"].command_line(Path("/m"))[6])
    # setpoints are latched: DDS; the machine command reaches the actuators by DDS as well
    assert local == sorted([topics.ESTIMATE, topics.MACHINE_COMMAND, topics.COMMAND])


def test_fast_runs_give_the_control_chain_a_cpu_of_its_own(tmp_path):
    nodes = launcher.graph("nmpc", COMMON, tmp_path / "x.mcap", fast=True)
    two = launcher.processes(nodes, "two")
    assert launcher.cpu_sets(two, [0, 1, 2]) == \
        {"recorder": {1, 2}, "plant": {1, 2}, "control": {0}}
    separate = launcher.cpu_sets(launcher.processes(nodes), [3, 5])
    assert {name for name, cpus in separate.items() if cpus == {3}} == \
        {"estimator", "nmpc", "protection"}
    assert launcher.cpu_sets(two, [0]) == {}                       # one CPU: nothing pinned
    plant_only = [n for n in nodes if n.name in (*topics.ACTUATORS, "plant")]
    assert launcher.cpu_sets(launcher.processes(plant_only, "plant"), [0, 1]) == {}
    if len(launcher.os.sched_getaffinity(0)) > 1:
        assert launcher.Launch(nodes, tmp_path, 1, "two").cpus["control"] == \
            {min(launcher.os.sched_getaffinity(0))}
    assert launcher.Launch(nodes, tmp_path, 1, "two", pin_cpus=False).cpus == {}
    realtime = launcher.graph("nmpc", dict(COMMON, mode="realtime"), tmp_path / "x.mcap",
                              fast=False)
    assert launcher.Launch(realtime, tmp_path, 1, "two").cpus == {}


def test_only_one_launch_at_a_time_pins_its_processes(monkeypatch, tmp_path):
    """Two graphs pinned at once would share the control chains' CPU: a launch that finds
    the pins held by another runs on every CPU; once the first stops, the pins are free."""
    monkeypatch.setattr(launcher, "LOCK_DIR", tmp_path)
    nodes = launcher.graph("nmpc", COMMON, tmp_path / "x.mcap", fast=True)
    first, second, third = (launcher.Launch(nodes, tmp_path, 1, "two") for _ in range(3))
    if not first.cpus:
        pytest.skip("one CPU: nothing is pinned")
    pinned = dict(first.cpus)
    first._take_pins()
    second._take_pins()
    assert first.cpus == pinned and second.cpus == {}
    first.stop()
    third._take_pins()
    assert third.cpus == pinned
    third.stop()


def test_the_recorder_yields_the_cpu_in_fast_mode_only(tmp_path):
    """Niced in fast mode (off every critical path there); in realtime it keeps up with the
    wall clock like every node (a niced recorder under a browser's load missed a short-lived
    operator CLI's event)."""
    fast = launcher.graph("nmpc", COMMON, tmp_path / "x.mcap", fast=True)
    assert launcher.Launch(fast, tmp_path, 1, "two").niceness == {"recorder": 10}
    realtime = launcher.graph("nmpc", dict(COMMON, mode="realtime"), tmp_path / "x.mcap",
                              fast=False)
    assert launcher.Launch(realtime, tmp_path, 1, "two").niceness == {}


def test_a_run_without_a_layout_takes_the_modes_default():
    """Fast runs on one host group their nodes in two processes; realtime runs and a
    host's share of a split run keep a process per node."""
    assert default_layout(realtime=False) == "two"
    assert default_layout(realtime=True) == "separate"
    assert default_layout(realtime=False, split=True) == "separate"
