"""The trip tank in the truth plant: lined up, the returns and the pumps' suction move its
volume instead of the active pit's, so a stand pulled dry out of a circulating well shows
on it as the stand's steel (drill_core.tripping.stands, by hand 0.1049 m^3)."""

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import rig_well_model
from drill_core.rig_root import config_dir
from drill_core.tripping.stands import StandVolumes
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator

STAND_M = 28.0


def test_a_stand_pulled_on_the_trip_tank_takes_its_steel_from_it():
    cfg = load_rig(config_dir())
    wm = rig_well_model(cfg)
    sim = PlantSimulator(cfg, pm.steady_state(wm, 1000.0 / 60000.0, 2.0e6, 0.0), seed=9)
    steps, step_s = sim.steps_per_frame, cfg.plant.step_s
    u = sim.inputs.copy()

    def frames(seconds, speed_mps=0.0):
        readings = []
        for _ in range(int(round(seconds / (steps * step_s)))):
            rows = np.repeat(u[:, None], steps, axis=1)
            rows[0] = u[0] + speed_mps * step_s * np.arange(1, steps + 1)
            u[0] = rows[0, -1]
            sim.advance(rows)
            readings.append(sim.measure(circulating=True))
        return readings

    before = frames(10.0)
    sim.line_up_trip_tank(True)
    frames(STAND_M / 0.5, 0.5)
    after = frames(60.0)                                   # at rest again, pressures settled
    mean = lambda rs, f: float(np.mean([getattr(r, f) for r in rs[-50:]]))
    steel = StandVolumes.of(sim.wm.geometry, STAND_M).steel_m3
    assert steel == pytest.approx(0.1049, abs=5e-4)
    drawn = mean(before, "trip_tank_volume_m3") - mean(after, "trip_tank_volume_m3")
    assert drawn == pytest.approx(steel, abs=0.01)         # 10 L: compression of the settled well
    assert abs(mean(after, "pit_volume_m3") - mean(before, "pit_volume_m3")) < 0.03
    assert mean(before, "trip_tank_volume_m3") == pytest.approx(cfg.plant.trip_tank_volume_m3,
                                                                abs=0.005)
