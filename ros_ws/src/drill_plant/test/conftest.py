"""Fixtures shared by the plant's tests: the reference configuration and its well model."""

import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir

CONFIG_DIR = config_dir()


@pytest.fixture(scope="session")
def cfg():
    return load_rig(CONFIG_DIR)


@pytest.fixture(scope="session")
def wm(cfg):
    return hy.build_well_model(cfg.well, cfg.plant.yield_regularisation_velocity_mps,
                               cfg.plant.choke_regularisation_pa)
