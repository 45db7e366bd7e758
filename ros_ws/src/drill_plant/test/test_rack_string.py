"""A connection in the truth plant: a stand pulled with the pump off, the string at rest,
then racked back. The plant's new string carries the state over: the bit stays where it
was, and BHP and the pit follow a twin that keeps the old string to within what the
changed volumes and stiffness can move at rest."""

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import rig_well_model
from drill_core.operating_point import operating_point
from drill_core.rig_root import config_dir
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator

STAND_M = 28.0
SPEED_MPS = 0.5


@pytest.fixture(scope="module")
def pulled_twins():
    """Two plants of one seed, pump off, choke as at rest: the block pulls a stand at
    0.5 m/s and holds; after 120 s the string is at rest a stand up."""
    cfg = load_rig(config_dir())
    wm = rig_well_model(cfg)
    start = pm.steady_state(wm, 0.0, 0.0, 0.0)
    sims = [PlantSimulator(cfg, start, seed=11) for _ in range(2)]
    steps = cfg.plant.steps_per_frame
    frame_s = steps * cfg.plant.step_s
    u0 = start.inputs.copy()
    for k in range(int(round(120.0 / frame_s))):
        t = (k * steps + np.arange(steps)) * cfg.plant.step_s
        u = np.repeat(u0[:, None], steps, axis=1)
        u[0] = u0[0] + SPEED_MPS * np.clip(t, 0.0, STAND_M / SPEED_MPS)
        for sim in sims:
            sim.advance(u)
    return cfg, sims, u


def test_racking_a_stand_keeps_the_bit_bhp_and_pit_where_they_were(pulled_twins):
    cfg, (kept, racked), u = pulled_twins
    lay = kept.layout
    x_before = racked.state[lay.position]
    assert x_before == pytest.approx(STAND_M, abs=0.05)       # the stand is out, at rest
    racked.rack_string(STAND_M)
    g = racked.wm.geometry
    assert racked.state[lay.position] == pytest.approx(x_before - STAND_M, abs=1e-12)
    # the elevator latched to the new top, carrying the string where it is
    u_racked = u[:, -1:].repeat(u.shape[1], axis=1).copy()
    u_racked[0] = racked.state[lay.position] + g.static_stretch_m
    u_kept = u[:, -1:].repeat(u.shape[1], axis=1)
    bhp_gap, pit_gap, bit_gap = [], [], []
    for _ in range(100):                                      # 10 s
        kept.advance(u_kept)
        racked.advance(u_racked)
        n = kept.wm.n
        bhp_gap.append(racked.state[lay.pressure(n)] - kept.state[lay.pressure(n)])
        pit_gap.append(racked.state[lay.pit_gain] - kept.state[lay.pit_gain])
        bit_gap.append(g.bit_above_bhp_node_m + racked.state[lay.position]
                       - kept.state[lay.position])
    assert np.max(np.abs(bhp_gap)) < 0.05e5                  # 0.05 bar
    assert np.max(np.abs(pit_gap)) < 2e-5                    # 20 mL
    assert np.max(np.abs(bit_gap)) < 5e-3                    # 5 mm


@pytest.mark.parametrize("pulled_m", [0.0, 280.0])
def test_a_short_strings_operating_point_is_the_plants_steady_state(pulled_m):
    """A run that starts ten stands short (trip_in) starts from the closed-form balance of
    that string: the stand-pipe pressure that drives 1000 L/min through it, the inside of
    the string at the bit a column of ``pulled_m`` lighter than at the bottom node. Held
    there, the plant stays: its BHP and flows drift by no more than its noise in 20 s."""
    cfg = load_rig(config_dir())
    wm = rig_well_model(cfg, pulled_m)
    op = operating_point(wm, 1000.0 / 60000.0, 2.0e6, 0.0)
    rho_g = cfg.well.mud.density_kgm3 * cfg.well.gravity_mps2
    bit_dp = op.string_pressure_pa - (op.annulus_pressure_pa[-1] - rho_g * pulled_m)
    assert 0.0 < bit_dp < 1.0e7                   # the bit's loss, the column taken off
    sim = PlantSimulator(cfg, pm.plant_steady_state(wm.n, op), seed=3, pulled_m=pulled_m)
    lay = sim.layout
    u = np.repeat(op.inputs[:, None], sim.steps_per_frame, axis=1)
    bhp, flow = [], []
    for _ in range(200):
        sim.advance(u)
        bhp.append(sim.state[lay.pressure(wm.n)])
        flow.append(sim.state[lay.string_flow])
    assert np.mean(bhp[-50:]) == pytest.approx(op.annulus_pressure_pa[-1], abs=1.0e5)
    assert np.mean(flow[-50:]) == pytest.approx(op.string_flow_m3s, rel=0.02)
