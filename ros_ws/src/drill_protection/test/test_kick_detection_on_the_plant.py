"""The flow-balance kick detector on the truth plant's sensors, the reference well's detector
(detector_for): the plant's own physics (clinging, compression along the annulus, the
formation's inflow), not the detector's balance, makes the flows it judges. The choke is
held at its opening and the pump at its pressure, so nothing closes a loop around it."""

import math

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator
from drill_protection.kick_detection import FlowSample, detector_for

CIRCULATION_M3S = 1000.0 / 60000.0
CHOKE_DP_PA = 2.0e6


def _run(seconds, speed=lambda t: 0.0, pore_pressure_pa=None, at_s=0.0, seed=5):
    """The plant circulating 1000 L/min at 20 bar of choke dp, the block moved at
    ``speed(t)``; from ``at_s`` the formation's pore pressure is ``pore_pressure_pa``.
    Returns the detector's readings and the plant's influx volume per 0.1 s sensor frame."""
    cfg = load_rig(config_dir())
    sim = PlantSimulator(cfg, pm.steady_state(pm.hy.rig_well_model(cfg),
        CIRCULATION_M3S, CHOKE_DP_PA, 0.0), seed=seed)
    detector = detector_for(cfg, sim.wm.geometry)
    steps, step_s = sim.steps_per_frame, cfg.plant.step_s
    u, block_m = sim.inputs.copy(), sim.inputs[0]
    readings, influx = [], []
    for k in range(int(round(seconds / (steps * step_s)))):
        t = k * steps * step_s
        if pore_pressure_pa is not None and t >= at_s:
            sim.set_parameter("pore_pressure_pa", pore_pressure_pa)
        m = sim.measure(circulating=True)
        readings.append(detector.update(FlowSample(
            t, m.return_flow_m3s, m.string_flow_m3s, m.bpp_flow_m3s, m.block_position_m,
            m.choke_dp_pa, m.bhp_pa, m.pit_volume_m3)))
        influx.append(sim.truth().influx_volume_m3)
        rows = np.repeat(u[:, None], steps, axis=1)
        for j in range(steps):
            block_m += speed(t + j * step_s) * step_s
            rows[0, j] = block_m
        sim.advance(rows)
    return cfg, readings, np.array(influx)


def test_a_stand_pulled_and_run_back_in_raises_nothing():
    """0.5 m/s out for 56 s, 30 s at rest, 0.5 m/s back in against the held choke: no alarm,
    and over each leg (once its start has left the 20 s window) the balance's mean is
    within a quarter of the threshold, so the steel's displacement is taken out (a 10 %
    error in the detector's area would read about 40 L/min at this speed). Single windows
    swing with the BHP gauge's noise in the compression term (about 5 L/min at rest) and
    at the legs' starts and stops."""
    def speed(t):
        return 0.5 if 30.0 <= t < 86.0 else (-0.5 if 116.0 <= t < 172.0 else 0.0)
    cfg, readings, influx = _run(220.0, speed)
    threshold = cfg.protection.kick_detection.flow_threshold_m3s
    assert influx[-1] == 0.0 and not any(r.alarm for r in readings)
    flows = np.array([r.excess_flow_m3s for r in readings])
    for start_s, end_s in ((50.0, 86.0), (136.0, 172.0)):
        leg = flows[int(start_s * 10):int(end_s * 10)]
        assert np.all(np.isfinite(leg)) and abs(leg.mean()) < 0.25 * threshold


def test_a_kick_is_alarmed_within_15_s_with_the_plants_influx_volume():
    """Pore pressure 5 bar over the BHP from t = 60 s (the kick scenario's size): alarmed
    within 15 s with under 20 L in, and the volume the alarm reports is the volume the
    formation gave by then (within 30 %)."""
    bhp_pa = 6.85e7
    cfg, readings, influx = _run(100.0, pore_pressure_pa=bhp_pa + 5.0e5, at_s=60.0)
    raised = [k for k, r in enumerate(readings) if r.raised]
    assert raised and readings[raised[0]].alarm == "kick"
    k = raised[0]
    assert 60.0 < k * 0.1 < 75.0 and not any(r.alarm for r in readings[:600])
    assert 0.0 < influx[k] < 0.020
    assert readings[k].volume_at_alarm_m3 == pytest.approx(influx[k], rel=0.3)
    assert math.isfinite(readings[-1].excess_volume_m3)
