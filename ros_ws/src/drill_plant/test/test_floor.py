"""The rig floor's share of the plant's side on a multi-stand trip: the floor tick reading
the block's encoder from the drawworks' frame (drill_plant.floor_tick), the drawworks on its
encoder while the floor has the string and the mud pump at the floor's share of its rate
(drill_plant.actuator_tick), the plant's slips and racked stands (drill_plant.plant_tick),
and the floor's command through its message and back (drill_ros.floor)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from drill_core.operating_point import initial_operating_point
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand
from drill_core.tripping.sequence import CONNECTION, DONE, MOVING, PUMP_DOWN, TripStep
from drill_plant.actuator_tick import ActuatorTick
from drill_plant.floor_tick import FloorTick
from drill_plant.plant_tick import PlantTick
from drill_ros.floor import floor_command, floor_message, floor_programme
from builtin_interfaces.msg import Time

from tick_inputs import command, measurement

PROGRAMME = TripProgramme(direction="out", stands=2)


def floor(phase: str, block_target_m: float = math.nan, pump_factor: float = 1.0,
          racked=(None, None), latched: bool = True, slips_set: bool = False) -> FloorCommand:
    step = TripStep(phase=phase, stand=1, slips_set=slips_set, latched=latched,
                    pump_factor=pump_factor, bit_height_target_m=28.0, stands_pulled=0)
    return FloorCommand(step, block_target_m, *racked)


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(config_dir() / "scenarios" / "trip_out.yaml")[0]


@pytest.fixture(scope="module")
def op(wm, scenario):
    return initial_operating_point(wm, scenario.initial)


def test_the_floor_reads_the_block_at_the_end_of_the_drawworks_frame(cfg):
    tick = FloorTick(cfg.well, PROGRAMME, 1.6, cfg.plant.step_s)
    tick.drawworks_frame(1.6 + 0.005 * np.arange(10))       # 0.5 m/s over the frame
    assert tick.block_speed_mps == pytest.approx(0.5)
    assert tick.block_m == pytest.approx(1.6 + 0.05)         # the next step's sample
    tick.drawworks_frame([math.nan] * 10)                    # a bad frame: the last reading
    assert tick.block_m == pytest.approx(1.65)
    hook = cfg.well.travelling_block_weight_n + 1.0e6       # the string on the elevator
    assert tick.step(0.0, hook, 0.0).step.phase == MOVING    # picked up: off it goes


def test_the_drawworks_drives_the_block_on_its_encoder_while_the_floor_has_the_string(
        cfg, wm, op, scenario):
    tick = ActuatorTick("drawworks", cfg, wm, op, scenario.events)
    tick.command(command(op, block_position_ref_m=5.0), 0, 0)
    start = tick.model.lag.value
    held = tick.step(measurement(op), 0, 0, 0.0, floor(CONNECTION, start - 28.0))
    assert math.isnan(held.output.reference)                 # no block reference followed
    assert held.output.output[-1] < start                    # down toward the new top
    done = tick.step(measurement(op), 1, 1, 0.1, floor(DONE, 0.0))
    assert np.ptp(done.output.output) < 0.1                  # braking to where it is
    moving = tick.step(measurement(op), 2, 2, 0.2, floor(MOVING))
    assert moving.output.reference == 5.0                    # the string's loop again


def test_the_mud_pump_runs_at_the_floors_share_of_its_command(cfg, wm, op, scenario):
    full = ActuatorTick("mud_pump", cfg, wm, op, scenario.events)
    half = ActuatorTick("mud_pump", cfg, wm, op, scenario.events)
    for tick in (full, half):
        tick.command(command(op, spp_pa=1.0e7), 0, 0)
    assert full.step(measurement(op), 0, 0, 0.0, floor(MOVING)).output.command == 1.0e7
    assert half.step(measurement(op), 0, 0, 0.0,
                     floor(PUMP_DOWN, pump_factor=0.5)).output.command == 5.0e6


def test_the_plant_lines_up_the_trip_tank_and_takes_the_floors_slips_and_stands(
        cfg, op, scenario):
    plant = PlantTick(cfg, op, scenario, seed=4)
    assert plant.sim.trip_tank_lined_up
    plant.floor(floor(CONNECTION, latched=False, slips_set=True))
    assert plant.sim.line_tension_n() == 0.0                 # the elevator let go
    before = plant.sim.state[plant.sim.layout.position]
    plant.floor(floor(CONNECTION, latched=False, slips_set=True, racked=(0.0, 28.0)))
    assert plant.sim.state[plant.sim.layout.position] == pytest.approx(before - 28.0)


def test_the_floors_command_goes_through_its_message_unchanged():
    for sent in (floor(MOVING), floor(CONNECTION, -26.4, 0.0, (28.0, 56.0), False, True)):
        msg = floor_message(sent, PROGRAMME, Time(sec=3))
        assert msg.direction == "out" and msg.stand_length_m == 28.0
        back = floor_command(msg)
        assert back.step == sent.step and back.racked_to_m == sent.racked_to_m
        assert back.racked_from_m == sent.racked_from_m
        assert (math.isnan(back.block_target_m) and math.isnan(sent.block_target_m)) \
            or back.block_target_m == sent.block_target_m


def test_the_floors_message_carries_what_the_trip_sheet_needs_of_its_programme():
    """A recording's trip sheet is the live one: the same stands and alarm limit."""
    programme = TripProgramme(direction="in", stands=4, stand_length_m=27.0,
                              discrepancy_alarm_m3=0.1, connection_s=60.0)
    back = floor_programme(floor_message(floor(MOVING), programme, Time(sec=3)))
    assert (back.direction, back.stands, back.stand_length_m, back.discrepancy_alarm_m3) == \
        ("in", 4, 27.0, 0.1)
