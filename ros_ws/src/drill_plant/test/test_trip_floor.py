"""Two stands pulled out of the truth plant by the rig floor (drill_core.tripping.rig_floor)
on its own instruments: the drawworks (its string loop while moving, its encoder in the
slips) and the mud pump ramped for each connection, the slips and the elevator, the
string racked at each connection, the trip tank lined up and the trip sheet keeping the
fill. The choke is held at its opening: nothing here holds the BHP (the controllers do,
in the graph)."""

import math

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import build_well_model
from drill_core.rig_root import config_dir
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import RigFloor
from drill_core.tripping.sequence import DONE, MOVING
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import TripSheet, stands_per_hour
from drill_plant import plant_model as pm
from drill_plant.actuators import Drawworks, Pump
from drill_plant.simulator import PlantSimulator

STAND_M = 28.0
TRIP_SPEED_MPS = 0.5
SETTLE_S = 180.0             # after the trip, the pump at its rate and the block held
BHP_REF_PA = 6.85e7


@pytest.fixture(scope="module")
def trip():
    cfg = load_rig(config_dir())
    wm = build_well_model(cfg.well, cfg.plant.yield_regularisation_velocity_mps,
                          cfg.plant.choke_regularisation_pa)
    start = pm.steady_state(wm, 1000.0 / 60000.0, 2.0e6, 0.0)
    sim = PlantSimulator(cfg, start, seed=12)
    sim.line_up_trip_tank(True)
    steps, step_s = sim.steps_per_frame, cfg.plant.step_s
    frame_s = steps * step_s
    programme = TripProgramme(direction="out", stands=2, stand_length_m=STAND_M)
    floor = RigFloor(cfg.well, programme, 0.0)
    drawworks = Drawworks(cfg.actuators, wm.geometry.static_stretch_m, start.inputs[0])
    spp_pa = start.inputs[3]
    mud_pump = Pump(cfg.actuators.mud_pump, spp_pa)
    sheet = TripSheet(programme, StandVolumes.of(wm.geometry, STAND_M), 2.0e5)
    u = start.inputs.copy()
    reference_m, alarms, log, settled = 0.0, [], [], None
    tank_start_m3 = sim.measure(True).trip_tank_volume_m3
    for k in range(int(round(1200.0 / frame_s))):
        t = k * frame_s
        m = sim.measure(sim.inputs[3] > 0.0)
        command = floor.step(t, m.hook_load_n, m.block_position_m, drawworks.lag.rate_per_s)
        step = command.step
        alarms += sheet.observe(t, step, m.bhp_pa, BHP_REF_PA, m.trip_tank_volume_m3)
        log.append((t, step.phase, step.stand, sim.line_tension_n(),
                    sim.state[sim.layout.velocity],
                    sim.wm.geometry.bit_above_bhp_node_m + sim.state[sim.layout.position]))
        if step.phase == DONE:
            if settled is None:
                settled = t + SETTLE_S
            elif t >= settled:
                break
        if command.racked_to_m is not None:
            sim.rack_string(command.racked_to_m)
        sim.set_hoisting(step.latched, step.slips_set)
        if step.phase == MOVING:             # the controller's part: 0.5 m/s to the stand's top,
            target = step.bit_height_target_m - floor.pulled_m      # braking at 0.05 m/s^2
            speed = min(TRIP_SPEED_MPS, math.sqrt(2.0 * 0.05 * max(target - reference_m, 0.0)))
            reference_m = min(reference_m + speed * frame_s, target)
            block = drawworks.frame(reference_m, m.block_position_m, step_s, steps)
        else:
            reference_m = m.block_position_m
            block = drawworks.drive_block(command.block_target_m
                                          if step.phase != DONE else drawworks.lag.value,
                                          step_s, steps)
        pump = mud_pump.frame(spp_pa * step.pump_factor, step_s, steps)
        rows = np.repeat(u[:, None], steps, axis=1)
        rows[0], rows[3] = block.output, pump.output
        sim.advance(rows)
    tank_end_m3 = float(np.mean([sim.measure(True).trip_tank_volume_m3 for _ in range(50)]))
    return sim, floor, sheet, alarms, log, tank_start_m3 - tank_end_m3


def test_two_stands_come_out_and_the_string_is_two_stands_shorter(trip):
    sim, floor, sheet, alarms, log, drawn_m3 = trip
    assert log[-1][1] == DONE and floor.stands_pulled == 2
    assert sim.wm.geometry.bit_above_bhp_node_m == 2 * STAND_M
    assert log[-1][5] == pytest.approx(2 * STAND_M, abs=0.1)      # the bit two stands up
    assert [row.stand for row in sheet.rows] == [1, 2]


def test_the_string_never_drops_and_the_line_never_jumps(trip):
    sim, floor, sheet, alarms, log, drawn_m3 = trip
    tension = np.array([row[3] for row in log])
    velocity = np.array([row[4] for row in log])
    assert velocity.min() > -0.05                                 # [m/s]: never let fall
    # a frame's change of pull: the block's rate limit over the string's stiffness, 0.6 m/s
    # * 0.1 s * 563 kN/m = 34 kN, is the most the drawworks can give
    assert np.abs(np.diff(tension)).max() < 40.0e3


def test_a_connection_at_a_held_choke_lets_the_well_flow_and_the_trip_sheet_books_it(trip):
    """With the choke held (no back-pressure for the lost friction: the conventional
    connection), each pump stop takes BHP about 29 bar down, under the 660 bar pore
    pressure, and the formation flows. Settled after the trip, the trip tank has given the
    steel of two stands less what the formation gave; the trip sheet's rows (slips to
    slips, each ending 30 s into the pump's restart, the well still filling its
    compression) book a gain of the influx's size."""
    sim, floor, sheet, alarms, log, drawn_m3 = trip
    steel = sheet.volumes.steel_m3
    influx_m3 = sim.truth().influx_volume_m3
    assert [row.expected_fill_m3 for row in sheet.rows] == pytest.approx([steel, steel])
    assert influx_m3 > 0.05 and sim.truth().loss_volume_m3 == 0.0
    assert drawn_m3 == pytest.approx(2 * steel - influx_m3, abs=0.015)
    assert all(row.gain_m3 > 0.0 for row in sheet.rows)
    assert sheet.cumulative_gain_m3 == pytest.approx(influx_m3, abs=0.05)
    rate = stands_per_hour(sheet.rows)
    # a stand: the move (56 s at 0.5 m/s, braking) and 150 s of ramps and connection
    assert 10.0 < rate < 3600.0 / (STAND_M / TRIP_SPEED_MPS + 150.0)
    assert all(row.out_of_slips_s > STAND_M / TRIP_SPEED_MPS for row in sheet.rows)
