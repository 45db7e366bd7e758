"""Fixtures every test may ask for: the rig's configuration as committed (config/), its
plant well model, and a scratch directory for run directories; and, once per session, the
tests' ROS domains cleared of dead shared-memory ports (drill_bringup.shm_ports)."""
from __future__ import annotations

import pytest

from drill_bringup import shm_ports
from drill_bringup.launcher import TEST_DOMAINS
from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir


@pytest.fixture(scope="session", autouse=True)
def _test_domains_without_dead_ports():
    """A test that starts DDS processes itself (not through the launcher, which clears its
    domain) must not meet a port a killed process left in its domain."""
    for domain in TEST_DOMAINS:
        shm_ports.remove_dead_ports(domain)


@pytest.fixture(scope="session")
def cfg():
    """The rig configuration of config/ (frozen dataclasses: safe to share)."""
    return load_rig(config_dir())


@pytest.fixture(scope="session")
def wm(cfg):
    """The reference well as the truth plant builds it (its yield and choke regularisation)."""
    return hy.rig_well_model(cfg)


@pytest.fixture()
def runs_dir(tmp_path):
    """Where a test's runs put their run directories: private to the test, not created
    (a run makes it; a refused run must leave it absent)."""
    return tmp_path / "runs"


def pytest_collection_modifyitems(items):
    """The slow tests' modules first (graph runs and closed loops): on scripts/test's two
    workers (a module per worker at a time) the long modules start at once and the many
    short ones fill in behind them, rather than one long module starting last."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
