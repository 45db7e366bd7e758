"""The plant's and the actuators' tick classes (drill_plant.plant_tick,
drill_plant.actuator_tick), the per-frame rules the nodes and the in-process bench share:
a scenario's actuator faults, the command watchdog, a bad frame held at the last input,
the events announced once as they start and end."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from drill_core.events import ACTUATORS, ScenarioEvent
from drill_core.operating_point import initial_operating_point
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario
from drill_plant.actuator_tick import ActuatorTick
from drill_plant.plant_model import EVENT_PARAMETERS, PARAMETER_NAMES
from drill_plant.plant_tick import PlantTick
from tick_inputs import command, measurement

FRAME_NS = 100_000_000          # the sensor period's stamps (0.1 s frames)


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(config_dir() / "scenarios" / "short_trip.yaml")[0]


@pytest.fixture(scope="module")
def op(wm, scenario):
    return initial_operating_point(wm, scenario.initial)


def run_frames(tick, op, frames: int, cmd=None, first: int = 0):
    """``frames`` frames from stamp ``first``; ``cmd`` fed at each (None: no command)."""
    steps = []
    for k in range(first, first + frames):
        stamp = k * FRAME_NS
        if cmd is not None:
            tick.command(cmd, stamp, stamp)
        steps.append(tick.step(measurement(op), stamp, stamp, stamp * 1e-9))
    return steps


def test_a_stuck_choke_holds_its_opening_whatever_it_is_commanded(cfg, wm, op, scenario):
    stuck = ScenarioEvent(time_s=1.0, kind="stuck", target="choke", duration_s=2.0)
    tick = ActuatorTick("choke", cfg, wm, op, (stuck,))
    run_frames(tick, op, 10, command(op))                          # 0-1 s: following
    opening = tick.model.lag.value
    held = run_frames(tick, op, 20, command(op, choke_manual=True, choke_opening_ref=0.9),
                      first=10)                                    # 1-3 s: stuck
    assert all(s.fault == "stuck" for s in held)
    assert np.all(np.concatenate([s.output.output for s in held]) == opening)
    after = run_frames(tick, op, 10, command(op, choke_manual=True, choke_opening_ref=0.9),
                       first=30)
    assert after[0].fault == "" and after[-1].output.output[-1] > opening + 0.05


def test_a_tripped_mud_pump_spins_down_whatever_it_is_commanded(cfg, wm, op):
    trip = ScenarioEvent(time_s=0.0, kind="trip", target="mud_pump")
    tick = ActuatorTick("mud_pump", cfg, wm, op, (trip,))
    start = tick.model.lag.value
    steps = run_frames(tick, op, 100, command(op, spp_pa=3.0e7))
    out = np.concatenate([s.output.output for s in steps])
    assert all(s.fault == "trip" and s.output.command == 0.0 for s in steps)
    assert out[0] == start and np.all(np.diff(out) <= 0.0) and out[-1] < 0.5 * start


def test_a_silent_command_stream_holds_the_safe_state_and_says_so_once(cfg, wm, op):
    tick = ActuatorTick("drawworks", cfg, wm, op, ())
    run_frames(tick, op, 1, command(op, block_position_ref_m=5.0))
    timeout_frames = int(cfg.actuators.watchdog_timeout_s * 1e9 / FRAME_NS)
    silent = run_frames(tick, op, timeout_frames + 5, first=1)
    tripped = [s for s in silent if s.watchdog_active]
    assert [s.watchdog_active for s in silent] == [False] * timeout_frames + [True] * 5
    assert sum(s.fell_silent for s in silent) == 1 and silent[0].fell_silent is False
    held = {s.output.reference for s in tripped}            # one safe reference, not the command's
    assert len(held) == 1 and held != {5.0}
    assert run_frames(tick, op, 1, command(op), first=timeout_frames + 6)[0].watchdog_active is False


def test_an_unknown_actuator_is_refused(cfg, wm, op):
    with pytest.raises(ValueError, match="not one of drawworks, choke, bpp, mud_pump"):
        ActuatorTick("top_drive", cfg, wm, op, ())


def frames_at(plant, value_by_name=None):
    steps = plant.sim.steps_per_frame
    held = {name: np.full(steps, plant.sim.inputs[i]) for i, name in enumerate(ACTUATORS)}
    rows = {**held, **(value_by_name or {})}
    return {name: (rows[name], rows[name][-1]) for name in ACTUATORS}


def test_a_bad_frame_is_held_at_the_last_input_and_reported(cfg, op, scenario):
    plant = PlantTick(cfg, op, scenario, seed=3)
    before = plant.sim.inputs.copy()
    bad = np.full(plant.sim.steps_per_frame, np.nan)
    errors = plant.advance(frames_at(plant, {"choke": bad, "bpp": np.zeros(3)}))
    assert errors == [f"choke: bad frame ({bad.size} samples); holding last input",
                      "bpp: bad frame (3 samples); holding last input"]
    assert np.array_equal(plant.sim.inputs, before) and np.all(np.isfinite(plant.sim.state))


def test_events_are_announced_once_as_they_start_and_end_and_act_as_they_start(cfg, op, scenario):
    kick = ScenarioEvent(time_s=0.2, kind="pore_pressure", value=6.9e7)
    dropout = ScenarioEvent(time_s=0.1, kind="dropout", target="bhp_pa", duration_s=0.2)
    plant = PlantTick(cfg, op, dataclasses.replace(scenario, events=(kick, dropout)), seed=3)
    pore = PARAMETER_NAMES.index(EVENT_PARAMETERS["pore_pressure"])
    codes, readings = [], []
    for k in range(5):
        notices, m = plant.sample(k * 0.1)
        codes.append([n.code for n in notices])
        readings.append(m.bhp_pa)
        if k == 1:
            assert plant.sim.parameters[pore] != 6.9e7        # not before its time
        plant.advance(frames_at(plant))
    assert plant.sim.parameters[pore] == 6.9e7
    assert [len(c) for c in codes] == [0, 1, 1, 1, 0]        # dropout starts, kick starts, dropout ends
    assert math.isnan(readings[1]) and math.isnan(readings[2]) and math.isfinite(readings[3])
