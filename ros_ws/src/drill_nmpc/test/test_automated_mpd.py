"""Automated MPD core: the trip's motion profile, the model-based choke-dp set-point and
its managed-pressure connection on a multi-stand trip."""
import dataclasses
import math

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.estimation_model import build_estimation_model
from drill_core.operating_point import operating_point
from drill_core.rig_root import config_dir
from drill_core.scenario import ActiveSetpoints
from drill_core.surge_swab import SurgeSwabModel
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand
from drill_core.tripping.sequence import (CONNECTION, MOVING, PICK_UP, PUMP_DOWN, PUMP_UP,
                                          SET_SLIPS, TripStep)
from drill_nmpc.advisor_ticks import CONNECTION_BPP_FLOW_M3S, AutomatedMpdTick, StartInputs
from drill_nmpc.automated_mpd import AutomatedMpd, EstimateView
from drill_nmpc.motion_profile import MotionProfile
from drill_nmpc.setpoint_book import HELD_TRIP_PLAN_SPEED_MPS, within_speed_limits

CONFIG_DIR = config_dir()
FLOW = 1000.0 / 60000.0


def test_profile_is_trapezoidal_within_its_limits_and_stops_on_target():
    p = MotionProfile(0.0)
    positions, speeds = [0.0], [0.0]
    for _ in range(80):
        p.step(28.0, 0.5, 0.1, 1.0)
        positions.append(p.position_m)
        speeds.append(p.speed_mps)
    assert positions[-1] == 28.0 and speeds[-1] == 0.0
    assert max(speeds) == pytest.approx(0.5)
    assert np.all(np.abs(np.diff(speeds)) <= 0.1 + 1e-12)       # the protection's acceleration
    assert np.all(np.diff(positions) >= 0.0)                    # never backs up
    # each sample moves by that sample's speed: 1.5 m in the first 5 s (0.1 + ... + 0.5)
    assert positions[5] == pytest.approx(1.5)
    arrival = next(k for k, x in enumerate(positions) if x == 28.0)
    # cruise 0.5 m/s with 5 s to speed up and 5 s to brake: 28/0.5 + 5 s, within a sample
    assert abs(arrival - 61) <= 1
    # within 0.5 m of the target (a trip leg's end in the report): no earlier than a string
    # at 0.5 m/s from rest at 0.1 m/s^2 could be there, 0.5 / 0.2 + 27.5 / 0.5 = 57.5 s
    near = next(k for k, x in enumerate(positions) if x >= 27.5)
    assert near == 58 and near >= 0.5 / (2 * 0.1) + 27.5 / 0.5


def test_profile_preview_does_not_move_the_profile():
    p = MotionProfile(3.0, 0.2)
    ahead = p.ahead(0.0, 0.5, 0.1, 1.0, 30)
    assert (p.position_m, p.speed_mps) == (3.0, 0.2)
    assert ahead[0].position_m == 3.0 and ahead[-1].position_m == 0.0
    assert max(s.position_m for s in ahead) > 3.0                # it brakes before it turns
    assert p.speeds_ahead(0.0, 0.5, 0.1, 1.0, 30) == [s.speed_mps for s in ahead]


@pytest.fixture(scope="module")
def rig():
    return load_rig(CONFIG_DIR)


@pytest.fixture(scope="module")
def em(rig):
    return build_estimation_model(rig)


def _setpoints(target=0.0, upper=0.0):
    return ActiveSetpoints(bhp_ref_pa=6.85e7, bhp_band_pa=2.0e5, choke_dp_ref_pa=2.0e6,
                           choke_dp_band_pa=5.0e5, block_position_target_m=target,
                           trip_speed_limit_mps=0.5, controller_enabled=True, mud_pump_on=True,
                           choke_dp_band_upper_pa=upper)


def _estimate(em, bhp_pa, position=0.0, velocity=0.0):
    return EstimateView(bhp_pa=bhp_pa, string_position_m=position, string_velocity_mps=velocity,
                        string_flow_m3s=FLOW, friction_factor=(1.0,) * (em.n - 1))


def test_at_rest_the_set_point_is_the_steady_dp_of_the_reference(rig, em):
    """At rest the set-point is the choke dp whose steady U-tube balance (the closed-form
    operating point: each node its mud column and its path's friction) puts the BHP on the
    reference."""
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    c = mpd.step(_estimate(em, 6.85e7), _setpoints(), 6.85e7)
    balance = operating_point(em.wm, FLOW, c.choke_dp_ref_pa, 0.0)
    assert balance.annulus_pressure_pa[-1] == pytest.approx(6.85e7, abs=0.01e5)
    assert c.choke_dp_ref_rate_pa_s == 0.0 and c.trim_pa == 0.0
    assert c.choke_flow_feedforward_m3s == pytest.approx(FLOW)
    assert (c.bpp_flow_m3s, c.spp_pa) == (0.0, 1.06e7)          # the pumps hold


def test_the_flow_filter_holds_while_the_meter_reads_and_lets_go_when_it_reads_nothing(rig, em):
    """A pump trip: the estimated flow falls to a tenth. While the meter reads, the set-point
    moves by the filter's first step only; once it reads nothing, it is the steady dp of the
    fallen flow at once (the friction is gone with the pump)."""
    filtered, unfiltered = AutomatedMpd(rig, em, 0.0, 1.06e7), AutomatedMpd(rig, em, 0.0, 1.06e7)
    sp = _setpoints(upper=6.63e7)                       # Case 2's band: no cap at 25 bar
    for mpd in (filtered, unfiltered):
        mpd.step(_estimate(em, 6.85e7), sp, 6.85e7)
    fallen = dataclasses.replace(_estimate(em, 6.85e7), string_flow_m3s=FLOW / 10)
    held = filtered.step(fallen, sp, 6.85e7).choke_dp_ref_pa
    let_go = unfiltered.step(dataclasses.replace(fallen, string_flow_observable=False),
                             sp, 6.85e7).choke_dp_ref_pa
    # the closed-form U-tube balance of the fallen flow (the mud report's exact friction)
    # puts the BHP on the reference; 0.11 bar is the smoothing of the estimation model's
    # yield jump at 100 L/min
    assert operating_point(em.wm, FLOW / 10, let_go, 0.0).annulus_pressure_pa[-1] == \
        pytest.approx(6.85e7, abs=0.15e5)
    at_full_flow = operating_point(em.wm, FLOW, held, 0.0).annulus_pressure_pa[-1]
    assert at_full_flow > 6.85e7                          # held above the full flow's dp ...
    assert held < let_go - 5.0e5                          # ... keeping most of the friction


def test_pulling_out_raises_the_set_point_by_the_swab_ahead_of_the_string(rig, em):
    """At cruise the set-point is the quasi-steady choke dp of 0.5 m/s, the one whose flows
    and pressures drill_core/test/test_surge_swab.py finds a steady state of the shared
    drift (every balance at rest) with the BHP on the reference."""
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    model = SurgeSwabModel(em)
    est = _estimate(em, 6.85e7)
    sp = _setpoints(target=28.0, upper=6.63e7)
    commands = [mpd.step(est, sp, 6.85e7) for _ in range(40)]
    dp = np.array([c.choke_dp_ref_pa for c in commands])
    assert np.all(np.diff(dp[:15]) >= -1e-6)                     # rising while speeding up
    cruise = model.choke_dp_for_bhp(6.85e7, (1.0,) * 3, FLOW, 0.5, 0.0)
    assert dp[-1] == pytest.approx(cruise, abs=0.05e5)           # the steady swab at 0.5 m/s
    assert dp[-1] - dp[0] > 4.0e5                                # several bar
    # the set-point leads: the string (lagging the reference by the drawworks) is slower
    # than the reference speed, but the set-point uses the speed feedforward_lead_s later
    assert commands[3].choke_dp_ref_rate_pa_s > 0.0
    assert all(c.block_position_ref_m <= 28.0 for c in commands)


def test_the_dp_band_caps_the_set_point_and_the_trip_speed(rig, em):
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    sp = _setpoints(target=28.0)                                 # symmetric +-5 bar band
    model = SurgeSwabModel(em)
    out_limit, in_limit = mpd.speed_envelope(6.85e7, (1.0,) * 3, FLOW, 0.5, 15.0e5, 21.0e5)
    assert 0.0 < out_limit < 0.5 and in_limit == 0.5
    dp_at_limit = model.choke_dp_for_bhp(6.85e7, (1.0,) * 3, FLOW, out_limit, 0.0)
    assert dp_at_limit <= 21.0e5
    c = None
    for _ in range(30):
        c = mpd.step(_estimate(em, 6.85e7), sp, 6.85e7)
    assert c.choke_dp_ref_pa <= 25.0e5 + 1e-6


def test_trim_integrates_the_estimated_error_and_is_limited(rig, em):
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    cfg = rig.automated_mpd
    low = 6.85e7 - 1.0e5                                          # BHP estimated 1 bar low
    c = mpd.step(_estimate(em, low), _setpoints(), 6.85e7)
    per_sample_pa = 1.0e5 * rig.nmpc.sample_time_s / cfg.trim_time_constant_s
    assert c.trim_pa == pytest.approx(per_sample_pa)
    for _ in range(math.ceil(cfg.trim_limit_pa / per_sample_pa) + 10):    # past the limit
        c = mpd.step(_estimate(em, low), _setpoints(), 6.85e7)
    assert c.trim_pa == pytest.approx(cfg.trim_limit_pa)
    nan = mpd.step(_estimate(em, math.nan), _setpoints(), 6.85e7)   # a NaN BHP changes nothing
    assert nan.trim_pa == c.trim_pa and math.isfinite(nan.choke_dp_ref_pa)


def test_manual_hands_the_string_back_where_it_is(rig, em):
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    sp = dataclasses.replace(_setpoints(target=28.0), controller_enabled=False)
    c = mpd.step(_estimate(em, 6.85e7, position=3.2), sp, 6.85e7)
    assert c.block_position_ref_m == 3.2


def test_the_plan_goes_on_from_the_block_reference_the_protection_applied(rig, em):
    """A held trip: the profile continues from the applied reference at the applied speed,
    instead of running on ahead of the string (it then overshot the target once let go)."""
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    sp = _setpoints(target=8.0, upper=6.63e7)
    sent = []
    for _ in range(6):
        mpd.adopt_applied(sent[-1] if sent else math.nan)    # the protection passes ours
        sent.append(mpd.step(_estimate(em, 6.85e7), sp, 6.85e7).block_position_ref_m)
    assert sent[-1] > sent[-2] > 0.0
    held = sent[-2]                                           # it held the last one back
    mpd.adopt_applied(held)
    assert mpd.profile.position_m == held and mpd.profile.speed_mps == 0.0
    ahead = mpd.step(_estimate(em, 6.85e7), sp, 6.85e7).block_position_ref_m
    assert held < ahead <= held + mpd.acceleration * mpd.sample_s ** 2 + 1e-12   # from rest
    for _ in range(200):
        mpd.adopt_applied(mpd.profile.position_m)
        last = mpd.step(_estimate(em, 6.85e7), sp, 6.85e7).block_position_ref_m
    assert last == 8.0                                        # on target, not past it


def test_the_plan_keeps_to_the_protections_standing_trip_speed_limits(rig, em):
    """within_speed_limits: the smaller of the operator's limit and the protection's standing
    limit the trip heads into; a held trip (0) is planned at a crawl, none (NaN) changes
    nothing; the book's setpoints stay the operator's."""
    sp = _setpoints(target=8.0)
    assert within_speed_limits(sp, (math.nan, math.nan), 0.0) is sp
    assert within_speed_limits(sp, (0.0, 0.6), 0.0) is sp            # pulling out: 0.5 stands
    assert within_speed_limits(sp, (0.6, 0.2), 0.0).trip_speed_limit_mps == 0.2
    held = within_speed_limits(sp, (0.5, 0.0), 0.0)
    assert held.trip_speed_limit_mps == HELD_TRIP_PLAN_SPEED_MPS
    assert within_speed_limits(sp, (0.0, 0.5), 10.0).trip_speed_limit_mps == HELD_TRIP_PLAN_SPEED_MPS
    assert sp.trip_speed_limit_mps == 0.5
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    for _ in range(10):
        c = mpd.step(_estimate(em, 6.85e7), held, 6.85e7)
    assert c.block_position_ref_m <= 10 * HELD_TRIP_PLAN_SPEED_MPS + 1e-12


def _held(em, bhp_pa, bottom_flow_m3s):
    """An estimate with the string in the slips: its top draining backwards (a broken
    connection), the annulus's bottom flow ``bottom_flow_m3s``."""
    return dataclasses.replace(_estimate(em, bhp_pa), string_flow_m3s=-80.0 / 60000.0,
                               string_flow_observable=False,
                               bottom_annulus_flow_m3s=bottom_flow_m3s)


def test_in_the_slips_the_set_point_takes_the_bottom_flow_at_once_and_not_below_nothing(rig, em):
    """While the floor has the string the friction is that of the annulus's bottom flow,
    unfiltered, not of the string's top flow; a flow down the annulus counts as none."""
    model = SurgeSwabModel(em)
    sp = _setpoints(upper=6.63e7)
    for bottom, friction_flow in ((300.0 / 60000.0, 300.0 / 60000.0), (-40.0 / 60000.0, 0.0)):
        mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
        mpd.step(_estimate(em, 6.85e7), sp, 6.85e7)              # circulating, moving
        mpd.string_held = True
        c = mpd.step(_held(em, 6.85e7, bottom), sp, 6.85e7)
        assert c.choke_dp_ref_pa == pytest.approx(model.choke_dp_for_bhp(
            6.85e7, (1.0,) * 3, friction_flow, 0.0, 0.0), abs=1.0)
    free = AutomatedMpd(rig, em, 0.0, 1.06e7)                   # not held: the top flow's
    free.step(_estimate(em, 6.85e7), sp, 6.85e7)
    drained = free.step(_held(em, 6.85e7, 0.0), sp, 6.85e7).choke_dp_ref_pa
    assert drained > model.choke_dp_for_bhp(6.85e7, (1.0,) * 3, 0.0, 0.0, 0.0) + 5.0e5


def test_in_the_slips_the_trim_stands_and_a_connection_overdrives_the_bhp_error(rig, em):
    """Held, a BHP estimated 5 bar low leaves the trim where it was; with the mud pump
    stopped for a connection the set-point rises by held_bhp_gain times the error."""
    sp = _setpoints(upper=6.63e7)
    low = 6.85e7 - 5.0e5
    mpd = AutomatedMpd(rig, em, 0.0, 1.06e7)
    trim = mpd.step(_estimate(em, low), sp, 6.85e7).trim_pa
    assert trim > 0.0
    mpd.string_held = True
    pumping = mpd.step(_held(em, low, 0.0), sp, 6.85e7)
    assert pumping.trim_pa == trim
    mpd.mud_at_rest = True
    at_rest = mpd.step(_held(em, low, 0.0), sp, 6.85e7)
    assert at_rest.trim_pa == trim
    assert at_rest.choke_dp_ref_pa - pumping.choke_dp_ref_pa == pytest.approx(
        rig.automated_mpd.held_bhp_gain * 5.0e5)


def test_the_tick_runs_the_back_pressure_pump_while_the_floor_has_the_string(rig, em):
    """From the slips' setting on, not from the pump's ramp: the pump's lag has passed
    before the mud pump ramps down; the connection itself is the mud at rest."""
    tick = AutomatedMpdTick(rig, em, StartInputs(FLOW, 2.0e6, 0.0, 1.06e7, True),
                            trip=TripProgramme(direction="out", stands=3))
    sp = _setpoints(upper=6.63e7)
    seen = {}
    for phase in (MOVING, SET_SLIPS, PUMP_DOWN, CONNECTION, PUMP_UP, PICK_UP, MOVING):
        floor = FloorCommand(TripStep(phase, 2, phase != MOVING, True, 1.0, 56.0, 1),
                             math.nan, None, None)
        cmd, _ = tick.step(_estimate(em, 6.85e7, position=27.6), sp, True, (0.5, 0.5),
                           math.nan, floor)
        seen[phase] = (cmd.bpp_flow_m3s, tick.controller.string_held,
                       tick.controller.mud_at_rest)
    assert seen[MOVING] == (0.0, False, False)
    for phase in (SET_SLIPS, PUMP_DOWN, PUMP_UP, PICK_UP):
        assert seen[phase] == (CONNECTION_BPP_FLOW_M3S, True, False)
    assert seen[CONNECTION] == (CONNECTION_BPP_FLOW_M3S, True, True)
