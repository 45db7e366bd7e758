"""Launcher: the node set of a run, who runs on /clock, and unique node names."""
from pathlib import Path

import pytest

from drill_bringup import launcher
from drill_core.ros import topics

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
    nodes.append(launcher.NodeSpec("console", "drill_bringup.console", {"port": 0}))
    with pytest.raises(ValueError, match="console"):
        launcher.Launch(nodes, tmp_path, 1)


def test_default_domains_are_exclusive_while_held(monkeypatch, tmp_path):
    monkeypatch.setattr(launcher, "LOCK_DIR", tmp_path)
    monkeypatch.setattr(launcher, "_held_domains", [])
    taken = [launcher.default_domain_id() for _ in range(len(launcher.RUN_DOMAINS))]
    assert sorted(taken) == list(launcher.RUN_DOMAINS)      # each handed out once
    with pytest.raises(RuntimeError, match="in use"):
        launcher.default_domain_id()
    for handle in launcher._held_domains:                    # released: free again
        handle.close()
    launcher._held_domains.clear()
    assert launcher.default_domain_id() in launcher.RUN_DOMAINS
