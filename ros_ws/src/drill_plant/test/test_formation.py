"""The formation across the open hole and the active pit, against independent numbers:
the productivity law evaluated here, the shut-in limit (a closed well with an influx
settles at the pore pressure), and mass conservation (pit gain = influx - losses - mud
stored by compression - volume vacated by the string). Deterministic: zero Wiener
increments."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

_SRC = Path(__file__).resolve().parents[1]
if "drill_plant" not in sys.modules:
    sys.path.insert(0, str(_SRC))

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from drill_core import hydraulics as hy  # noqa: E402
from drill_core.config import replace  # noqa: E402
from drill_plant import plant_model as pm  # noqa: E402
from drill_plant.simulator import PlantSimulator  # noqa: E402

BAR = 1e5
BETA = 6.5e9                       # mud bulk modulus, config/well.yaml (typed here on purpose)
PI = 2.7e-9                        # productivity and injectivity index, config/well.yaml


@pytest.fixture(scope="module")
def frame(wm, cfg):
    return pm.build_frame_function(wm, cfg)


def run(frame, cfg, x0, inputs_at, theta, duration_s):
    """Deterministic frames with inputs ``inputs_at(t)`` [4] per plant step and parameters
    ``theta`` held; the states after every plant step, t = 0 included."""
    lay = pm.PlantLayout((x0.size - 6) // 2)
    steps, sub, h = cfg.plant.steps_per_frame, cfg.plant.substeps, cfg.plant.step_s
    zero = np.zeros((lay.size, steps * sub))
    x, xs = x0.copy(), [x0[:, None]]
    for k in range(int(round(duration_s / cfg.plant.sensor_period_s))):
        u = np.column_stack([inputs_at((k * steps + j) * h) for j in range(steps)])
        states = np.asarray(frame(x, u, zero, pm.held_parameters(theta, steps)))
        x = states[:, -1]
        xs.append(states)
    return np.hstack(xs)


def stored_by_compression(wm, lay, dx):
    g = wm.geometry
    return (sum(g.annulus_volume_m3[i] / BETA * dx[lay.pressure(i + 1)] for i in range(wm.n))
            + g.string_volume_m3 / BETA * dx[lay.string_pressure])


def test_the_window_is_inert_and_the_law_is_linear_outside_it(cfg, wm):
    f = cfg.well.formation
    assert f.productivity_index_m3_s_pa == PI and f.injectivity_index_m3_s_pa == PI
    inside = hy.formation_flows(np, f, 6.85e7, f.pore_pressure_pa, f.fracture_pressure_pa)
    assert inside == (0.0, 0.0)
    below = hy.formation_flows(np, f, 6.50e7, f.pore_pressure_pa, f.fracture_pressure_pa)
    assert below[0] == pytest.approx(PI * 10.0 * BAR) and below[1] == 0.0    # 10 bar under: 162 L/min
    above = hy.formation_flows(np, f, 7.15e7, f.pore_pressure_pa, f.fracture_pressure_pa)
    assert above[0] == 0.0 and above[1] == pytest.approx(PI * 5.0 * BAR)


def test_a_shut_in_well_settles_at_the_pore_pressure(cfg):
    """Choke shut, pumps off, the static column 637 bar under a 650 bar pore pressure: the
    influx compresses the closed annulus until BHP equals the pore pressure (the shut-in
    principle) with time constant V_annulus / (beta PI), ~7 s, and the surface pressure
    rises as much as the BHP (the column between is static); the influx volume is the mud
    the pressure rise compressed. A mud without yield stress, so that the whole annulus
    takes part (a gelled annulus lets the bottom settle first and the rest creep)."""
    mud = replace(cfg.well.mud, yield_stress_pa=0.0, annulus_yield_stress_pa=0.0)
    well = replace(cfg.well, mud=mud)
    wm = hy.rig_well_model(cfg, well=well)
    frame = pm.build_frame_function(wm, dataclasses.replace(cfg, well=well))
    rest = pm.steady_state(wm, 0.0, 0.0, 0.0)
    lay = pm.PlantLayout(wm.n)
    pore = 6.50e7
    theta = np.array([pore, cfg.well.formation.fracture_pressure_pa, 1.0, *pm.ON_THE_ELEVATOR])
    xs = run(frame, cfg, rest.state, lambda t: [rest.inputs[0], 0.0, 0.0, 0.0], theta, 60.0)
    bhp, surface = xs[lay.pressure(wm.n)], xs[lay.pressure(1)]
    rise = pore - bhp[0]
    assert rise > 10.0 * BAR
    tau = sum(wm.geometry.annulus_volume_m3) / (BETA * PI)
    assert 5.0 < tau < 9.0
    assert abs(bhp[-1] - pore) < 2.0 * np.exp(-60.0 / tau) * rise      # 60 s is > 8 tau
    assert surface[-1] - surface[0] == pytest.approx(bhp[-1] - bhp[0], rel=1e-3)
    one_tau = int(round(tau / cfg.plant.step_s))
    assert pore - bhp[one_tau] == pytest.approx(np.exp(-1.0) * rise, rel=0.1)
    dx = xs[:, -1] - xs[:, 0]
    assert xs[lay.pit_gain, -1] == 0.0                            # nothing left the well
    assert dx[lay.influx_volume] == pytest.approx(stored_by_compression(wm, lay, dx), rel=1e-9)
    assert dx[lay.loss_volume] == 0.0


def test_pit_gain_conserves_mud_with_influx_losses_and_a_trip(cfg, wm, frame):
    """Circulating 1000 L/min while pulling out at 0.3 m/s, first with BHP under the pore
    pressure (influx), then over the fracture pressure (losses): the pit gain equals influx
    - losses - mud stored by compression - the volume the string vacates. The RK map keeps
    this linear invariant stage by stage, so it holds to round-off."""
    lay = pm.PlantLayout(wm.n)
    start = pm.steady_state(wm, 1000.0 / 60000.0, 20.0 * BAR, 0.0)
    bhp0 = start.state[lay.pressure(wm.n)]

    def pulling_out(t):
        return [start.inputs[0] + 0.3 * t, start.inputs[1], 0.0, start.inputs[3]]

    influx = run(frame, cfg, start.state, pulling_out,
                 np.array([bhp0 + 8.0 * BAR, bhp0 + 30.0 * BAR, 1.0, *pm.ON_THE_ELEVATOR]), 5.0)
    losses = run(frame, cfg, influx[:, -1], lambda t: pulling_out(t + 5.0),
                 np.array([bhp0 - 30.0 * BAR, bhp0 - 6.0 * BAR, 1.0, *pm.ON_THE_ELEVATOR]), 5.0)
    dx = losses[:, -1] - start.state
    assert dx[lay.influx_volume] > 1e-3 and dx[lay.loss_volume] > 1e-3     # litres each way
    g = wm.geometry
    vacated = (sum(g.displacement_area_m2) - g.string_top_inner_area_m2) * dx[lay.position]
    expected = dx[lay.influx_volume] - dx[lay.loss_volume] - stored_by_compression(wm, lay, dx) \
        - vacated
    assert dx[lay.pit_gain] == pytest.approx(expected, abs=1e-9 * dx[lay.influx_volume] + 1e-12)


def test_simulator_reports_formation_flows_and_surface_sensors(cfg, wm):
    """Truth and sensors of the simulator: influx rate by the law above, pit volume from its
    configured start, return flow on the choke line; a parameter event takes effect."""
    start = pm.steady_state(wm, 1000.0 / 60000.0, 20.0 * BAR, 0.0)
    sim = PlantSimulator(cfg, start, seed=3)
    held = np.repeat(start.inputs[:, None], cfg.plant.steps_per_frame, axis=1)
    sim.advance(held)
    truth = sim.truth()
    assert truth.influx_m3s == 0.0 and truth.loss_m3s == 0.0
    bhp = truth.state[sim.layout.pressure(wm.n)]
    sim.set_parameter("pore_pressure_pa", bhp + 5.0 * BAR)
    truth = sim.truth()
    assert truth.influx_m3s == pytest.approx(PI * 5.0 * BAR, rel=1e-12)
    noise = cfg.plant.surface_sensor_noise
    m = [sim.measure(True) for _ in range(400)]
    pit = np.array([s.pit_volume_m3 for s in m])
    returns = np.array([s.return_flow_m3s for s in m])
    assert abs(pit.mean() - cfg.plant.active_pit_volume_m3 - truth.pit_gain_m3) < 4 * noise.pit_volume_m3 / 20
    assert pit.std() == pytest.approx(noise.pit_volume_m3, rel=0.15)
    assert abs(returns.mean() - truth.choke_flow_m3s) < 4 * noise.return_flow_m3s / 20
