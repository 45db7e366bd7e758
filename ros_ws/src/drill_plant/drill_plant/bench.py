"""Timing of the truth plant: one 0.1 s sensor frame (the frame's plant steps, each with
its SRK substeps, compiled CasADi) from the benches' circulating steady state
(drill_core.operating_point.BENCH_POINT), in process.

    python -m drill_plant.bench [config_dir]
"""
from __future__ import annotations

import json
import statistics
import sys
import time

import numpy as np

from drill_core import hydraulics as hy
from drill_core.config import RigConfig, load_rig
from drill_core.rig_root import config_dir as default_config_dir
from drill_core.operating_point import BENCH_POINT
from drill_plant.plant_model import steady_state
from drill_plant.simulator import PlantSimulator

def plant_frame_cost(config: RigConfig, repetitions: int = 2000) -> dict:
    """Median wall time [s] of one sensor frame and of one plant step, and the plant
    core's real-time factor (frame time over the sensor period), for ``config``'s well."""
    wm = hy.rig_well_model(config)
    ss = steady_state(wm, BENCH_POINT.circulation_m3s, BENCH_POINT.choke_dp_pa,
                      BENCH_POINT.bpp_flow_m3s)
    sim = PlantSimulator(config, ss, seed=1)
    inputs = np.tile(ss.inputs[:, None], (1, sim.steps_per_frame))
    times = []
    for _ in range(repetitions):
        start = time.perf_counter()
        sim.advance(inputs)
        times.append(time.perf_counter() - start)
    frame_s = statistics.median(times)
    return {"plant_frame_median_s": frame_s, "plant_step_median_s": frame_s / sim.steps_per_frame,
            "plant_core_rtf": frame_s / config.plant.sensor_period_s}


if __name__ == "__main__":
    print(json.dumps(plant_frame_cost(load_rig(sys.argv[1] if len(sys.argv) > 1
                                               else default_config_dir())), indent=2))
