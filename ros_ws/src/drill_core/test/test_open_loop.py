"""The open-loop command sequence (drill_core.open_loop) against hand-computed values, and
the scenario loader's refusals of bad open-loop schedules (key path and allowed range named)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from drill_core.config import ConfigError
from drill_core.open_loop import OpenLoopPlan, start_command
from drill_core.rig_root import rig_root
from drill_core.scenario import ActiveSetpoints, Initial, SetpointChange, load_scenario, setpoints_at

ROOT = rig_root()
LPM = 1.0 / 60000.0
STILL = Initial(circulation_m3s=0.0, choke_dp_pa=0.0, bpp_flow_m3s=0.0)
CIRCULATING = Initial(circulation_m3s=1000.0 * LPM, choke_dp_pa=2.0e6, bpp_flow_m3s=0.0)


def plan(*entries: SetpointChange, initial: Initial = STILL) -> OpenLoopPlan:
    return OpenLoopPlan(entries, start_command(initial, choke_flow_m3s=0.01, spp_pa=1.0e7))


def block_at(p: OpenLoopPlan, *times: float) -> list[float]:
    return [p.command_at(t).block_position_ref_m for t in times]


# ----------------------------------------------------------------------- block reference
def test_run_in_follows_the_trapezoid():
    # 28 m down at 0.4 m/s, 0.1 m/s^2 from t = 5 s: 4 s to full speed, 70 s cruise, 4 s to stop
    p = plan(SetpointChange(time_s=0.0, block_speed_mps=0.4, block_acceleration_mps2=0.1),
             SetpointChange(time_s=5.0, block_position_target_m=-28.0))
    assert p.moves[0].duration_s == pytest.approx(74.0)
    assert block_at(p, 0.0, 5.0, 7.0, 9.0, 15.0, 77.0, 79.0, 300.0) == pytest.approx(
        [0.0, 0.0, -0.2, -0.8, -3.2, -27.8, -28.0, -28.0])


def test_short_move_never_reaches_cruise_speed():
    # 1 m at up to 0.5 m/s with 0.1 m/s^2: a triangle, peak sqrt(a d) = 0.316 m/s at mid-move
    p = plan(SetpointChange(time_s=0.0, block_position_target_m=1.0, block_speed_mps=0.5,
                            block_acceleration_mps2=0.1))
    half = math.sqrt(10.0)
    assert p.moves[0].duration_s == pytest.approx(2.0 * half)
    assert block_at(p, half, 2.0 * half) == pytest.approx([0.5, 1.0])


def test_speed_changes_per_command_period_stay_below_the_acceleration():
    # process protection compares the speed of consecutive 1 s commands with its limit
    p = plan(SetpointChange(time_s=0.0, block_speed_mps=0.5, block_acceleration_mps2=0.05),
             SetpointChange(time_s=3.0, block_position_target_m=-28.0),
             SetpointChange(time_s=100.0, block_position_target_m=2.0))
    speeds = np.diff(block_at(p, *np.arange(0.0, 200.0, 1.0)))
    assert np.abs(np.diff(speeds)).max() <= 0.05 + 1e-12
    assert np.abs(speeds).max() == pytest.approx(0.5)
    assert block_at(p, 199.0) == pytest.approx([2.0])


# ------------------------------------------------------------- pumps and choke
def test_bpp_ramp_and_a_ramp_that_starts_midway():
    p = plan(SetpointChange(time_s=0.0),
             SetpointChange(time_s=120.0, bpp_flow_m3s=400.0 * LPM, bpp_ramp_s=10.0),
             SetpointChange(time_s=125.0, bpp_flow_m3s=0.0, bpp_ramp_s=4.0))
    flows = [p.command_at(t).bpp_flow_m3s / LPM for t in (0.0, 120.0, 122.5, 125.0, 127.0, 129.0, 200.0)]
    assert flows == pytest.approx([0.0, 0.0, 100.0, 200.0, 100.0, 0.0, 0.0])


def test_bpp_step_without_ramp():
    p = plan(SetpointChange(time_s=0.0), SetpointChange(time_s=10.0, bpp_flow_m3s=0.005))
    assert [p.command_at(t).bpp_flow_m3s for t in (9.9, 10.0)] == [0.0, 0.005]


def test_choke_manual_then_back_to_pi_and_mud_pump_off():
    p = plan(SetpointChange(time_s=0.0, choke_opening=0.5),
             SetpointChange(time_s=10.0, choke_flow_ref_m3s=0.02),
             SetpointChange(time_s=20.0, mud_pump_on=False), initial=CIRCULATING)
    start, manual, pi, pump_off = (p.command_at(t) for t in (0.0, 5.0, 10.0, 20.0))
    assert start.choke_manual and start.choke_opening == 0.5 and start.mud_pump_on
    assert manual == start
    assert not pi.choke_manual and pi.choke_flow_ref_m3s == 0.02
    assert not pump_off.mud_pump_on and pump_off.spp_pa == 1.0e7


def test_without_choke_entries_the_pi_keeps_the_initial_choke_flow():
    command = plan(SetpointChange(time_s=0.0)).command_at(50.0)
    assert not command.choke_manual and command.choke_flow_ref_m3s == 0.01


# ------------------------------------------------------------------ the shipped study
def test_shipped_estimation_study():
    scenario, overrides = load_scenario(ROOT / "config" / "scenarios" / "estimation_study.yaml")
    assert scenario.controller == "open_loop" and scenario.initial.circulation_m3s == 0.0
    assert overrides["actuators"]["drawworks"]["minimum"] < -28.0      # the block can run 28 m in
    p = OpenLoopPlan(scenario.schedule, start_command(scenario.initial, 0.0, 0.0))
    assert all(p.command_at(t).choke_manual and p.command_at(t).choke_opening == 0.5
               for t in (0.0, 150.0, 300.0))
    assert not p.command_at(0.0).mud_pump_on
    assert block_at(p, 0.0, scenario.duration_s) == pytest.approx([0.0, -28.0])
    bpp = [p.command_at(t).bpp_flow_m3s / LPM for t in (119.0, 120.0, scenario.duration_s)]
    assert bpp == pytest.approx([0.0, 0.0, 400.0], abs=0.01)
    assert p.moves[0].start_s + p.moves[0].duration_s < scenario.duration_s


def test_absent_pump_field_keeps_the_pump_state():
    scenario, _ = load_scenario(ROOT / "config" / "scenarios" / "case2.yaml")
    start = ActiveSetpoints(bhp_ref_pa=6.85e7, bhp_band_pa=2e5, choke_dp_ref_pa=2e6,
                            choke_dp_band_pa=5e5, block_position_target_m=0.0,
                            trip_speed_limit_mps=0.5, controller_enabled=True, mud_pump_on=False)
    active = setpoints_at(scenario, 400.0, start)
    assert active.mud_pump_on is False and active.block_position_target_m == 0.0


# --------------------------------------------------------------------- refusals
BASE = {"name": "study", "description": "d", "duration_s": 300.0, "seed": 1,
        "controller": "open_loop",
        "initial": {"circulation_m3s": 0.0, "choke_dp_pa": 0.0, "bpp_flow_m3s": 0.0},
        "schedule": [{"time_s": 0.0, "block_speed_mps": 0.3, "block_acceleration_mps2": 0.05}]}


def load_error(tmp_path: Path, schedule: list, controller: str = "open_loop") -> str:
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump({**BASE, "controller": controller, "schedule": schedule}))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    return str(info.value)


@pytest.mark.parametrize("entry, parts", [
    ({"choke_opening": 1.5}, ["schedule[0].choke_opening", "1.5", "[0, 1]"]),
    ({"bpp_flow_m3s": -0.001}, ["schedule[0].bpp_flow_m3s", "[0, 0.1] m^3/s"]),
    ({"block_speed_mps": 0.0}, ["schedule[0].block_speed_mps", "(0, 5] m/s"]),
    ({"bpp_ramp_s": 5.0}, ["schedule[0].bpp_ramp_s", "needs its bpp_flow_m3s"]),
    ({"choke_opening": 0.5, "choke_flow_ref_m3s": 0.01}, ["schedule[0].choke_flow_ref_m3s",
                                                          "exclude each other"]),
    ({"mud_pump_on": True}, ["schedule[0].mud_pump_on", "circulation off"]),
    ({"mud_pump_on": "yes"}, ["schedule[0].mud_pump_on", "true or false"]),
    ({"bhp_ref_pa": 6.85e7}, ["schedule[0].bhp_ref_pa", "not used with controller open_loop"]),
])
def test_bad_open_loop_entry(tmp_path, entry, parts):
    message = load_error(tmp_path, [{"time_s": 0.0, **entry}])
    assert all(part in message for part in parts), message


def test_block_move_needs_speed_and_acceleration(tmp_path):
    message = load_error(tmp_path, [{"time_s": 0.0, "block_position_target_m": -28.0,
                                     "block_speed_mps": 0.3}])
    assert "schedule[0].block_acceleration_mps2" in message and "a block move needs" in message


def test_new_block_move_while_moving(tmp_path):
    # the 28 m move at 0.3 m/s, 0.05 m/s^2 runs from 5 s to 104.3 s
    message = load_error(tmp_path, [BASE["schedule"][0],
                                    {"time_s": 5.0, "block_position_target_m": -28.0},
                                    {"time_s": 60.0, "block_position_target_m": 0.0}])
    assert "schedule[2].time_s" in message and "until 104.3 s" in message


def test_open_loop_field_refused_for_a_closed_loop_controller(tmp_path):
    message = load_error(tmp_path, [{"time_s": 0.0, "bpp_flow_m3s": 0.005}], controller="nmpc")
    assert "schedule[0].bpp_flow_m3s" in message and "only used with controller open_loop" in message
