"""The estimator's sample step (drill_estimator.tick): which flow it takes for the choke
while the string-flow meter reads nothing."""

import dataclasses
import math

import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import build_well_model
from drill_core.rig_root import config_dir
from drill_estimator.tick import EstimatorTick
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator

STEPS = 10


@pytest.fixture(scope="module")
def config():
    return load_rig(config_dir())


def _started(config):
    """A tick initialised on a circulating well, and the plant it measures."""
    wm = build_well_model(config.well, config.plant.yield_regularisation_velocity_mps,
                          config.plant.choke_regularisation_pa)
    sim = PlantSimulator(config, pm.steady_state(wm, 1000.0 / 60000.0, 2.0e6, 0.0), seed=3)
    tick = EstimatorTick(config)
    tick.step(0.0, sim.measure(True), {}, STEPS)
    assert tick.ukf.initialised
    return tick, sim


@pytest.mark.parametrize("stopped_by_floor", [True, False])
def test_without_circulation_the_meter_is_the_choke_flow_only_through_a_connection(
        config, stopped_by_floor):
    """The mud pump stopped for a connection: the return-flow meter still reads the choke
    line's flow (the back-pressure pump's) and stays the model's choke flow; stopped
    otherwise (a trip), the valve law takes over and the frame is counted."""
    tick, sim = _started(config)
    m = dataclasses.replace(sim.measure(False), return_flow_m3s=0.009)
    assert not m.string_flow_valid
    tick.step(0.1, m, {}, STEPS, pump_stopped_by_floor=stopped_by_floor)
    if stopped_by_floor:
        assert tick.inputs.return_flow_m3s == 0.009
    else:
        assert math.isnan(tick.inputs.return_flow_m3s)
    before = tick.inputs.valve_law_frames
    tick.step(0.2, m, {}, STEPS, pump_stopped_by_floor=stopped_by_floor)
    assert tick.inputs.valve_law_frames == before + (0 if stopped_by_floor else 1)
