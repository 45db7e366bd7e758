"""The estimator's sample step (drill_estimator.tick): the time update's inputs while the
string-flow meter reads nothing."""

import dataclasses

import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import rig_well_model
from drill_core.rig_root import config_dir
from drill_estimator.model_inputs import ModelInputs
from drill_estimator.tick import EstimatorTick
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator

STEPS = 10


@pytest.mark.parametrize("stopped_by_floor", [True, False])
def test_the_valve_law_is_calibrated_only_through_a_connections_planned_stop(
        monkeypatch, stopped_by_floor):
    """The rig floor's planned stop of the mud pump reaches the inputs as ``calibrated``
    (the valve law times the meter's calibration); any other stop (a trip) does not. The
    calibration's weight per frame is the sensor period over its time constant."""
    config = load_rig(config_dir())
    wm = rig_well_model(config)
    sim = PlantSimulator(config, pm.steady_state(wm, 1000.0 / 60000.0, 2.0e6, 0.0), seed=3)
    tick = EstimatorTick(config)
    assert tick.inputs.calibration_gain == pytest.approx(
        config.plant.sensor_period_s / config.estimator.valve_law_calibration_s)
    tick.step(0.0, sim.measure(True), {}, STEPS)
    asked = []
    frame = ModelInputs.frame

    def spy(self, frames, steps, calibrated=False):
        asked.append(calibrated)
        return frame(self, frames, steps, calibrated)
    monkeypatch.setattr(ModelInputs, "frame", spy)
    m = dataclasses.replace(sim.measure(False), return_flow_m3s=0.009)
    tick.step(0.1, m, {}, STEPS, pump_stopped_by_floor=stopped_by_floor)
    assert asked == [stopped_by_floor]
