"""A two-stand trip on the rig floor in plain Python: the sequencer walks each stand
through its phases on the string's measurements, the hoist holds the string on the slips
or the elevator, the trip tank fills the hole, and the trip sheet books every stand."""

import math

import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario
from drill_core.tripping.hoist import buoyed_weight_n, hoist_forces
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import (ARRIVAL_TOLERANCE_M, CONNECTION, DONE, MOVING,
                                          PICK_UP, PUMP_DOWN, PUMP_UP, SET_SLIPS,
                                          StandSequencer, position_after_connection,
                                          pump_factor_ahead)
from drill_core.tripping.stands import StandVolumes, tripped_geometry
from drill_core.tripping.trip_sheet import TripSheet, stands_per_hour
from drill_core.tripping.trip_tank import TripTank

DT_S = 0.05
STAND_M = 28.0
BLOCK_SPEED_MPS = 0.5
PICKUP_SPEED_MPS = 0.2
BHP_REF_PA = 6.85e7
BAND_PA = 2.0e5


@pytest.fixture(scope="module")
def well():
    return load_rig(config_dir()).well


def run_trip(well, direction, influx_m3_per_stand=0.0, stands_pulled=0):
    """Drive the floor with a simple driller: the block takes the weight, moves the stand
    at up to 0.5 m/s, slacks off, and is latched slack to the new top after the
    connection. The hole takes the steel the string moves from the tank; an influx comes
    back in proportion to the string's rise. BHP swabs 3 bar while moving up fast."""
    programme = TripProgramme(direction=direction, stands=2, stand_length_m=STAND_M)
    geometry = tripped_geometry(well, stands_pulled, STAND_M)
    steel_m2 = geometry.string_outer_area_at_top_m2 - geometry.string_top_inner_area_m2
    sequencer = StandSequencer(programme, buoyed_weight_n(geometry, well.gravity_mps2), 0.0,
                               stands_pulled)
    sheet = TripSheet(programme, StandVolumes.of(geometry, STAND_M), BAND_PA)
    tank = TripTank(area_m2=1.0, volume_m3=6.0)
    x = v = u_b = 0.0
    tension = 0.0
    log, alarms, t = [], [], 0.0
    step = sequencer.step(t, geometry.bit_above_bhp_node_m + x, v, tension)
    while step.phase != DONE and t < 3600.0:
        if step.stands_pulled != sequencer_pulled(log, stands_pulled):
            x = position_after_connection(x, sequencer_pulled(log, stands_pulled) * STAND_M,
                                          step.stands_pulled * STAND_M)
            geometry = tripped_geometry(well, step.stands_pulled, STAND_M)
            sequencer.weight_n = buoyed_weight_n(geometry, well.gravity_mps2)
            u_b = x                                   # latched to the new top, slack
        u_b += DT_S * driller_speed(step, geometry, x, u_b, well)
        f = hoist_forces(geometry, well.gravity_mps2, well.hoist_damping_n_s_m, 3.0e5, x, v, u_b,
                         step.latched, step.slips_set)
        x_before = x
        if f.held:
            v = 0.0
        else:
            v += f.acceleration_mps2 * DT_S
            x += v * DT_S
        moving = step.phase == MOVING
        influx = influx_m3_per_stand * max(x - x_before, 0.0) / STAND_M / DT_S
        # the hole takes (out) or gives back (in) the steel the string moves
        tank = tank.step(influx + max(x_before - x, 0.0) * steel_m2 / DT_S,
                         max(x - x_before, 0.0) * steel_m2 / DT_S, DT_S)
        t += DT_S
        bhp = BHP_REF_PA - (3.0e5 if moving and v > 0.2 else 0.0)
        alarms += sheet.observe(t, step, bhp, BHP_REF_PA, tank.volume_m3)
        log.append((t, step))
        tension = f.line_tension_n
        step = sequencer.step(t, geometry.bit_above_bhp_node_m + x, v, tension)
    alarms += sheet.observe(t + DT_S, step, BHP_REF_PA, BHP_REF_PA, tank.volume_m3)
    log.append((t + DT_S, step))
    return programme, sheet, alarms, log, geometry, x


def sequencer_pulled(log, start):
    return log[-1][1].stands_pulled if log else start


def driller_speed(step, geometry, x, u_b, well):
    """The block's speed [m/s] the test's driller asks for in each phase."""
    if step.phase == PICK_UP:
        return PICKUP_SPEED_MPS
    if step.phase == MOVING:
        block_target = step.bit_height_target_m - geometry.bit_above_bhp_node_m \
            + geometry.static_stretch_m
        return max(-BLOCK_SPEED_MPS, min(BLOCK_SPEED_MPS, 0.5 * (block_target - u_b)))
    if step.phase == SET_SLIPS:
        return -PICKUP_SPEED_MPS
    return 0.0


def phases_in_order(log):
    out = []
    for _, step in log:
        if not out or out[-1] != (step.stand, step.phase):
            out.append((step.stand, step.phase))
    return out


def durations(log, phase):
    spans, start = [], None
    for (t, step) in log:
        if step.phase == phase and start is None:
            start = t
        elif step.phase != phase and start is not None:
            spans.append(t - start)
            start = None
    return spans


def test_pulling_out_walks_each_stand_through_its_phases(well):
    programme, sheet, alarms, log, geometry, x = run_trip(well, "out")
    cycle = [PICK_UP, MOVING, SET_SLIPS, PUMP_DOWN, CONNECTION, PUMP_UP]
    assert phases_in_order(log) == [(s, p) for s in (1, 2) for p in cycle] + [(2, DONE)]
    for phase, seconds in ((PUMP_DOWN, 30.0), (CONNECTION, 90.0), (PUMP_UP, 30.0)):
        assert durations(log, phase) == [pytest.approx(seconds, abs=1.5 * DT_S)] * 2
    assert log[-1][1].stands_pulled == 2
    # the bit ends two stands up, at rest within the arrival tolerance
    assert geometry.bit_above_bhp_node_m + x == pytest.approx(2 * STAND_M, abs=ARRIVAL_TOLERANCE_M)


def test_the_pump_ramps_linearly_to_off_through_each_connection(well):
    _, _, _, log, _, _ = run_trip(well, "out")
    ramp = [(t, s.pump_factor) for t, s in log if s.phase == PUMP_DOWN and s.stand == 1]
    t0 = ramp[0][0]
    for t, factor in ramp:
        assert factor == pytest.approx(max(0.0, 1.0 - (t - t0) / 30.0), abs=2 * DT_S / 30.0)
    assert all(s.pump_factor == 0.0 for _, s in log if s.phase == CONNECTION)
    assert all(s.pump_factor == 1.0 for _, s in log if s.phase in (MOVING, PICK_UP))


def test_the_trip_sheet_books_each_stand_against_its_steel(well):
    programme, sheet, alarms, _, _, _ = run_trip(well, "out")
    steel = StandVolumes.of(tripped_geometry(well, 0, STAND_M), STAND_M).steel_m3
    assert [r.stand for r in sheet.rows] == [1, 2]
    for row in sheet.rows:
        # the hole took the steel of the stand's travel, the arrival tolerance aside
        assert row.measured_fill_m3 == pytest.approx(steel, abs=0.05 / STAND_M * steel * 2)
        assert row.expected_fill_m3 == steel
        assert abs(row.gain_m3) < 1e-3
        assert row.peak_swab_pa == pytest.approx(3.0e5) and row.peak_surge_pa == 0.0
        # swabbed 3 bar above 0.2 m/s: outside the 2 bar band for most of the move
        assert 0.0 < row.outside_band_s < row.out_of_slips_s
        assert row.in_slips_s > 150.0      # ramps and the connection, 30 + 90 + 30 s
    assert alarms == []
    span = sheet.rows[-1].end_s - sheet.rows[0].start_s
    assert stands_per_hour(sheet.rows) == pytest.approx(2 * 3600.0 / span)


def test_a_swabbed_influx_raises_the_trip_tank_alarm_once(well):
    _, sheet, alarms, _, _, _ = run_trip(well, "out", influx_m3_per_stand=0.2)
    assert [r.gain_m3 for r in sheet.rows] == [pytest.approx(0.2, abs=2e-3)] * 2
    assert [a.code for a in alarms] == ["trip_tank_gain"]
    assert alarms[0].value == pytest.approx(0.4, abs=4e-3)


def test_running_in_makes_up_before_each_stand_and_the_tank_gets_the_steel_back(well):
    programme, sheet, alarms, log, geometry, x = run_trip(well, "in", stands_pulled=5)
    cycle = [PUMP_DOWN, CONNECTION, PUMP_UP, PICK_UP, MOVING, SET_SLIPS]
    assert phases_in_order(log) == [(s, p) for s in (1, 2) for p in cycle] + [(2, DONE)]
    assert log[-1][1].stands_pulled == 3
    assert geometry.bit_above_bhp_node_m + x == pytest.approx(3 * STAND_M, abs=ARRIVAL_TOLERANCE_M)
    steel = StandVolumes.of(geometry, STAND_M).steel_m3
    for row in sheet.rows:
        assert row.expected_fill_m3 == -steel
        assert abs(row.gain_m3) < 1e-3
    assert alarms == []


def test_a_connection_waits_for_the_block_at_the_new_top(well):
    """The elevator latches only where the string is: past its programmed time a
    connection goes on until the floor says the block is at the new top."""
    programme = TripProgramme(direction="in", stands=1, connection_s=90.0, pump_ramp_down_s=30.0)
    sequencer = StandSequencer(programme, 1.0e6, 0.0, stands_pulled=1)
    assert sequencer.step(0.0, STAND_M, 0.0, 0.0).phase == PUMP_DOWN
    assert sequencer.step(30.0, STAND_M, 0.0, 0.0).phase == CONNECTION
    late = sequencer.step(300.0, STAND_M, 0.0, 0.0, block_ready=False)
    assert late.phase == CONNECTION and late.stands_pulled == 1 and not late.latched
    ready = sequencer.step(300.1, STAND_M, 0.0, 0.0, block_ready=True)
    assert ready.phase == PUMP_UP and ready.stands_pulled == 0 and ready.latched


@pytest.mark.parametrize("change, key, words", [
    ({"controller": "open_loop", "schedule": [{"time_s": 0.0, "choke_opening": 0.5}]},
     "trip", "automated_mpd, not open_loop"),
    ({"schedule": [{"time_s": 0.0, "bhp_ref_pa": 6.85e7, "block_position_target_m": 28.0}]},
     "schedule[0].block_position_target_m", "the rig floor's"),
    ({"trip": {"direction": "up", "stands": 2}}, "trip.direction", "out, in"),
])
def test_a_scenarios_trip_programme_is_refused_where_it_cannot_run(tmp_path, change, key, words):
    import yaml

    from drill_core.config import ConfigError
    from drill_core.scenario import load_scenario
    data = yaml.safe_load((config_dir() / "scenarios" / "trip_out.yaml").read_text())
    path = tmp_path / "trip.yaml"
    path.write_text(yaml.safe_dump({**data, **change}))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert key in str(info.value) and words in str(info.value), str(info.value)


def test_a_run_in_starts_with_its_stands_racked_and_a_pull_out_with_none():
    """trip_in starts on a string its stands short, the bit that much off the bottom, and
    ends on the configured string; trip_out starts on the configured string."""
    run_in = TripProgramme(direction="in", stands=10, stand_length_m=28.0)
    assert (run_in.stands_pulled_at_start, run_in.pulled_at_start_m) == (10, 280.0)
    assert TripProgramme(direction="out", stands=10).pulled_at_start_m == 0.0
    scenarios = config_dir() / "scenarios"
    assert load_scenario(scenarios / "trip_in.yaml")[0].pulled_at_start_m == 280.0
    assert load_scenario(scenarios / "case2.yaml")[0].pulled_at_start_m == 0.0


def test_the_pump_share_ahead_follows_the_programmed_ramps_and_connection():
    """Hand-worked on 30 s ramps and a 90 s connection, 10 s into the ramp-down: 5 s on,
    half the rate; 25 s on, 5 s into the connection (none); 130 s on, 20 s into the
    ramp-up (two thirds); 200 s on, picking up (all of it). A phase of no set time (setting
    the slips) is taken to last."""
    out = TripProgramme(direction="out", stands=2, connection_s=90.0, pump_ramp_down_s=30.0,
                        pump_ramp_up_s=30.0)
    ahead = [pump_factor_ahead(out, PUMP_DOWN, 10.0, s) for s in (0.0, 5.0, 25.0, 130.0, 200.0)]
    assert ahead == pytest.approx([2.0 / 3.0, 0.5, 0.0, 2.0 / 3.0, 1.0])
    assert pump_factor_ahead(out, SET_SLIPS, 3.0, 500.0) == 1.0
    running_in = TripProgramme(direction="in", stands=2, connection_s=90.0)
    assert pump_factor_ahead(running_in, CONNECTION, 80.0, 15.0) == pytest.approx(5.0 / 30.0)


def test_a_ramp_down_shaped_for_the_flow_falls_to_its_stop_share_then_stops():
    """With ``pump_stop_share`` s0 the pressure share falls as s0 + (1 - s0)(1 - t/T)^2:
    from the full rate, its slope zero at the ramp's end where it reaches s0, and the
    pump off from the connection on; the plan ahead reads the same shape."""
    from drill_core.tripping.sequence import pump_factor
    shaped = TripProgramme(direction="out", stands=2, pump_ramp_down_s=30.0,
                           pump_stop_share=0.4)
    assert [pump_factor(shaped, PUMP_DOWN, t) for t in (0.0, 15.0, 27.0)] == pytest.approx(
        [1.0, 0.4 + 0.6 * 0.25, 0.4 + 0.6 * 0.01])
    assert pump_factor(shaped, PUMP_DOWN, 30.0) == 0.0
    assert pump_factor(shaped, CONNECTION, 1.0) == 0.0
    assert pump_factor_ahead(shaped, PUMP_DOWN, 10.0, 5.0) == pytest.approx(0.4 + 0.6 * 0.25)
    assert pump_factor_ahead(shaped, PUMP_DOWN, 10.0, 25.0) == 0.0     # in the connection
    linear = TripProgramme(direction="out", stands=2, pump_ramp_down_s=30.0)
    assert pump_factor(linear, PUMP_DOWN, 15.0) == 0.5


def test_the_floor_has_the_pump_stopped_through_the_connection_only(well):
    """What the estimator is told: the pump stopped by plan through every tick of the
    connection (and the ramps' ends at share 0), never while the string moves or the slips
    are set with the pump on."""
    from drill_core.tripping.rig_floor import FloorCommand
    _, _, _, log, _, _ = run_trip(well, "out")
    stopped = [FloorCommand(s, math.nan, None, None).pump_stopped for _, s in log]
    phases = [s.phase for _, s in log]
    assert all(held for held, phase in zip(stopped, phases) if phase == CONNECTION)
    assert {phase for held, phase in zip(stopped, phases) if held} <= {PUMP_DOWN, CONNECTION,
                                                                       PUMP_UP}
