"""Process protection: command it past each limit and check the limit holds and is reported."""
import itertools
import math
import numpy as np
import pytest

from drill_protection.protection import ProcessProtection, surge_swab_pa
from drill_protection.well_control import Hold

CIRCULATION = 1000.0 / 60000.0          # 1000 L/min


@pytest.fixture(scope="module")
def setup(cfg, wm):
    return cfg, wm


def fresh(setup, start=(0.0, CIRCULATION, 0.0, 1.06e7)):
    config, wm = setup
    return ProcessProtection(config, wm, np.array(start))


def test_surge_swab_model_matches_the_yield_dominated_magnitudes(setup):
    _, wm = setup
    # docs/design.md §3: closed-end surge/swab at 0.5 m/s without circulation is about +-26 bar
    change = surge_swab_pa(wm, np.array([-0.5, 0.5]), 0.0)
    assert change[0] == pytest.approx(26e5, rel=0.05)
    assert change[1] == pytest.approx(-26e5, rel=0.05)


def test_machine_range_and_rate_limits(setup):
    config, _ = setup
    p = fresh(setup)
    d = p.apply([0.0, CIRCULATION, 1.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    slew = config.nmpc.input_slew.bpp_flow_m3s
    assert d.command[2] == pytest.approx(slew)           # rate limit from 0 toward 1 m^3/s
    assert any("bpp_flow_m3s" in c.text for c in d.clamps)
    for _ in range(200):
        d = p.apply([0.0, CIRCULATION, 1.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert d.command[2] == pytest.approx(config.actuators.bpp.maximum)   # machine range
    d = p.apply([0.0, CIRCULATION, 0.0, 5.0e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert d.command[3] == pytest.approx(1.06e7 + config.nmpc.input_slew.spp_pa)


def test_operator_trip_speed_and_acceleration_limits(setup):
    config, _ = setup
    p = fresh(setup)
    accel = config.protection.trip_acceleration_max_mps2 * config.protection.command_period_s
    refs, speed = [], 0.0
    for _ in range(15):
        d = p.apply([28.0, CIRCULATION, 0.0, 1.06e7], refs[-1] if refs else 0.0, speed, 6.85e7,
                    CIRCULATION, 0.3)
        refs.append(d.command[0])
    speeds = np.diff([0.0] + refs)
    assert np.all(np.diff(speeds) <= accel + 1e-12)       # acceleration limit while speeding up
    assert speeds.max() == pytest.approx(0.3)             # operator limit, below the machine's 0.6
    assert any(c.code == "speed_clamp" and "operator trip-speed limit" in c.text for c in d.clamps)


def test_model_derived_swab_limit_keeps_bhp_in_window(setup):
    config, wm = setup
    p = fresh(setup, start=(0.0, 0.0, 0.0, 0.0))
    low = config.well.formation.pore_pressure_pa + config.protection.pressure_margin_pa
    bhp_at_rest = low + 10e5                              # only 10 bar above the window edge
    d = p.apply([28.0, 0.0, 0.0, 0.0], 0.0, 0.0, bhp_at_rest, 0.0, 0.5)
    allowed_out = d.trip_speed_limits_mps[1]
    # independent check: the gel-breaking swab alone (about 18.5 bar) exceeds the 10 bar margin
    assert allowed_out < 0.05
    assert bhp_at_rest + surge_swab_pa(wm, np.array([allowed_out]), 0.0)[0] >= low - 1e-6
    assert any("swab model" in c.text for c in d.clamps)
    # running in (surge) raises BHP, still well below fracture: allowed at full speed
    assert d.trip_speed_limits_mps[0] == pytest.approx(0.5)


def test_a_non_finite_bhp_holds_the_trip_and_says_why(setup):
    p = fresh(setup)
    d = p.apply([28.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, float("nan"), CIRCULATION, 0.5)
    assert d.trip_speed_limits_mps == (0.0, 0.0)
    assert d.command[0] == pytest.approx(0.0)                   # the block reference stays put
    assert any("no finite BHP" in c.text for c in d.clamps)
    assert not any("model" in c.text for c in d.clamps)              # not blamed on the surge model


def test_emergency_stop_sets_the_brake_and_holds_the_bhp_at_the_stop(setup):
    p = fresh(setup)
    for _ in range(5):
        p.apply([10.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    held = p.previous.copy()
    p.emergency_stop = True
    d = p.apply([20.0, 0.03, 0.02, 2.0e7], 1.2, 0.3, 6.86e7, CIRCULATION, 0.5,
                choke_dp_setpoint=(2.5e6, 0.0))
    assert d.emergency_stop and d.emergency_bhp_pa == 6.86e7    # the BHP measured at the stop
    assert d.choke_dp_setpoint is None and d.manual_choke_opening is None   # the BHP loop
    assert d.command[0] == pytest.approx(1.2)             # block reference = where the string is
    assert np.allclose(d.command[1:], held[1:])            # pumps and choke feedforward held
    assert any(c.code == "estop_hold" and "brake set" in c.text for c in d.clamps)
    later = p.apply([20.0, 0.03, 0.02, 2.0e7], 1.3, 0.0, 6.80e7, CIRCULATION, 0.5)
    assert later.emergency_bhp_pa == 6.86e7                # held at the stop's, not re-taken
    p.emergency_stop = False
    released = p.apply([20.0, CIRCULATION, 0.0, 1.06e7], 1.3, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert not released.emergency_stop and math.isnan(released.emergency_bhp_pa)
    period = setup[0].protection.command_period_s
    speed = setup[0].protection.trip_acceleration_max_mps2 * period    # one period from rest
    assert released.command[0] == pytest.approx(1.3 + speed * period)  # from the string


def test_emergency_stop_keeps_its_bhp_inside_the_window(setup):
    p = fresh(setup)
    low, high = setup[0].pressure_window_pa
    p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, high + 3.0e5, CIRCULATION, 0.5)
    p.emergency_stop = True
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, float("nan"), CIRCULATION, 0.5)
    assert d.emergency_bhp_pa == high           # the last BHP seen, brought inside the window


def test_emergency_stop_holds_the_median_of_the_last_second_not_one_noisy_sample(setup):
    p = fresh(setup)
    for i, bhp in enumerate((6.851e7, 6.849e7, 6.850e7, 6.853e7, 6.870e7)):   # a 2 bar spike last
        p.observe_bhp(0.1 * i, bhp)
    p.emergency_stop = True
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.870e7, CIRCULATION, 0.5)
    assert d.emergency_bhp_pa == 6.851e7


def test_emergency_stop_during_a_kick_answer_holds_the_answers_target_as_it_steps(setup):
    p = fresh(setup)
    p.emergency_stop = True
    p.observe_bhp(0.0, 6.86e7)
    p.well_control = Hold(2.5e6, 6.89e7, "kick answer")
    first = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.86e7, CIRCULATION, 0.5,
                    choke_dp_pa=2.4e6)
    p.well_control = Hold(2.75e6, 6.915e7, "kick answer, a step on")
    later = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.88e7, CIRCULATION, 0.5,
                    choke_dp_pa=2.6e6)
    assert (first.emergency_bhp_pa, later.emergency_bhp_pa) == (6.89e7, 6.915e7)
    assert later.emergency_dp_start_pa == first.emergency_dp_start_pa == 2.4e6  # at the press


def test_non_finite_request_is_refused(setup):
    p = fresh(setup)
    d = p.apply([float("nan"), CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert np.all(np.isfinite(d.command))
    assert any("non-finite" in c.text for c in d.clamps)


def test_manual_level_holds_everything(setup):
    p = fresh(setup)
    p.apply([3.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    held = p.previous.copy()
    p.automation_level = "manual"
    d = p.apply([20.0, 0.03, 0.02, 2.0e7], 0.5, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert np.allclose(d.command, held)
    assert any(c.code == "level_hold" and "automation level manual" in c.text for c in d.clamps)


def test_manual_choke_opening_passes_inside_the_valve_range(setup):
    config, _ = setup
    p = fresh(setup)
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5,
                manual_choke_opening=0.5)
    assert d.manual_choke_opening == 0.5 and d.clamps == ()
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5,
                manual_choke_opening=1.4)
    assert d.manual_choke_opening == config.actuators.choke.maximum
    assert any(c.code == "machine_limit" and "choke_opening_ref 1.4 -> 1" in c.text for c in d.clamps)
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert d.manual_choke_opening is None                  # back on the PI flow controller


def test_manual_choke_held_on_a_non_finite_request_and_the_emergency_stop_takes_it(setup):
    p = fresh(setup)
    p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5,
            manual_choke_opening=0.4)
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5,
                manual_choke_opening=float("nan"))
    assert d.manual_choke_opening == 0.4
    assert any("non-finite manual choke opening" in c.text for c in d.clamps)
    p.emergency_stop = True
    d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5,
                manual_choke_opening=0.4)
    assert d.manual_choke_opening is None and d.emergency_stop   # the choke's BHP loop holds


def test_choke_dp_set_point_passes_and_a_manual_opening_wins(setup):
    p = fresh(setup)
    cmd = [0.0, CIRCULATION, 0.0, 1.06e7]
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(2.3e6, 1.0e5),
                choke_dp_pa=2.3e6)
    assert d.choke_dp_setpoint == (2.3e6, 1.0e5) and d.clamps == ()
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, manual_choke_opening=0.4,
                choke_dp_setpoint=(2.3e6, 0.0))
    assert d.choke_dp_setpoint is None and d.manual_choke_opening == 0.4
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    assert d.choke_dp_setpoint is None and d.manual_choke_opening is None   # the flow loop


def test_a_choke_dp_set_point_without_a_choke_dp_reading_falls_back_to_the_flow_loop(setup):
    """The choke's pressure loop cannot follow a set-point on a gauge that does not read (a
    dropout, a frozen gauge): the choke goes on its flow loop at the advisor's flow."""
    p = fresh(setup)
    cmd = [0.0, 0.9 * CIRCULATION, 0.0, 1.06e7]
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(2.3e6, 0.0),
                choke_dp_pa=float("nan"))
    assert d.choke_dp_setpoint is None and d.command[1] == pytest.approx(0.9 * CIRCULATION)
    assert [c.code for c in d.clamps] == ["dp_setpoint_unread"]


def test_non_finite_choke_dp_set_point_falls_back_to_the_flow_loop(setup):
    p = fresh(setup)
    cmd = [0.0, CIRCULATION, 0.0, 1.06e7]
    p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(2.3e6, 0.0))
    for bad in ((float("nan"), 0.0), (2.3e6, float("inf"))):
        d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=bad)
        assert d.choke_dp_setpoint is None
        assert any("non-finite choke dp set-point" in c.text for c in d.clamps)


def test_choke_dp_set_point_held_without_its_ramp_outside_closed_loop(setup):
    p = fresh(setup)
    cmd = [0.0, CIRCULATION, 0.0, 1.06e7]
    p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(2.3e6, 1.0e5),
            choke_dp_pa=2.3e6)
    p.automation_level = "advisory"
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(3.0e6, 2.0e5))
    assert d.choke_dp_setpoint == (2.3e6, 0.0)               # held, no longer ramping
    d = p.apply(cmd, 0.0, 0.0, 6.85e7, CIRCULATION, 0.5, choke_dp_setpoint=(float("nan"), 0.0))
    assert d.choke_dp_setpoint == (2.3e6, 0.0)               # the advisor's request is not applied


def test_a_bhp_heading_out_of_the_window_within_the_lead_is_driven_back_already(setup):
    config, _ = setup
    high = config.well.formation.fracture_pressure_pa - config.protection.pressure_margin_pa
    lead = config.protection.window_guard_lead_s
    assert lead > 0.0
    rise_pa_s = 4.0e5                        # a pump ramped up under a closed choke: 4 bar/s
    now_pa = high - 0.5 * rise_pa_s * lead   # crossing in half the lead
    noise = np.random.default_rng(7).normal(0.0, 1.0e5, 200)     # the gauge's 1 bar

    def judged(rise: float, span_s: float, now_pa: float = now_pa):
        p = fresh(setup)
        times = np.arange(-span_s, 1e-9, 0.1)
        for t, n in zip(times, noise):
            p.observe_bhp(float(t), now_pa + rise * t + n)
        d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, now_pa, CIRCULATION, 0.5,
                    surface_flows=(CIRCULATION, 0.0))
        return [c for c in d.clamps if c.code == "window_guard"], d

    heading, d = judged(rise_pa_s, 10.0)
    assert len(heading) == 1 and "BHP heading" in heading[0].text
    assert heading[0].value == pytest.approx(now_pa + rise_pa_s * lead, abs=1.5e5)
    assert d.command[1] > CIRCULATION                      # the choke opens already
    assert judged(-rise_pa_s, 10.0)[0] == []               # heading away from the edge
    assert judged(0.0, 10.0)[0] == []                      # as close, steady: noise only
    assert judged(rise_pa_s, 0.5 * lead)[0] == []          # a gauge just back: no trend yet
    low = config.well.formation.pore_pressure_pa + config.protection.pressure_margin_pa
    falling, d = judged(-rise_pa_s, 10.0, low + 0.5 * rise_pa_s * lead)
    assert len(falling) == 1 and "under the window's pore limit" in falling[0].text
    assert d.command[1] < CIRCULATION                      # the choke closes already
    # already out and still going: the notice names the BHP itself, at its own value
    for rise, out_pa in ((rise_pa_s, high + 1.0e5), (-rise_pa_s, low - 1.0e5)):
        (out,), _ = judged(rise, 10.0, out_pa)
        assert out.text.startswith(f"BHP {out_pa / 1e5:.1f} bar ") and out.value == out_pa


def test_a_bhp_heading_over_the_window_is_relieved_by_its_overshoot(setup):
    """Over the window and climbing (a pump brought back under a choke closed on the lost
    friction), the choke's flow reference goes past the flow by the flow that takes the
    BHP ahead back to the edge over the lead: the annulus's volume over the mud's bulk
    modulus times the overshoot over the lead, where that is more than one slew. A BHP
    coming back fast from under the window, mid-window, is heading over too, but its
    overshoot is small: about one slew, not the valve opened wide. Under the window, one
    slew."""
    config, wm = setup
    high = config.well.formation.fracture_pressure_pa - config.protection.pressure_margin_pa
    low = config.well.formation.pore_pressure_pa + config.protection.pressure_margin_pa
    lead = config.protection.window_guard_lead_s
    slew = config.nmpc.input_slew.choke_flow_m3s
    compliance = sum(wm.geometry.annulus_volume_m3) / config.well.mud.bulk_modulus_pa

    def choke_step(rise_pa_s: float, now_pa: float) -> float:
        p = fresh(setup)
        for t in np.arange(-10.0, 1e-9, 0.1):
            p.observe_bhp(float(t), now_pa + rise_pa_s * t)
        d = p.apply([0.0, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, now_pa, CIRCULATION, 0.5,
                    surface_flows=(CIRCULATION, 0.0))
        assert any(c.code == "window_guard" for c in d.clamps)
        return d.command[1] - CIRCULATION

    climb_pa_s = 3.0e5                                   # 3 bar/s, 1 bar over the edge
    overshoot_pa = 1.0e5 + climb_pa_s * lead             # 13 bar ahead
    relief = choke_step(climb_pa_s, high + 1.0e5)
    assert relief == pytest.approx(compliance * overshoot_pa / lead, rel=1e-6)
    assert relief * 60000.0 == pytest.approx(370.0, abs=5.0)    # L/min on the reference well
    assert relief > 3.0 * slew
    assert choke_step(0.1e5, high + 1.0e5) == pytest.approx(slew)      # 0.1 bar/s: one slew
    recovering = choke_step(6.0e5, high - 20.0e5)        # mid-window, back up at 6 bar/s
    assert slew <= recovering < 1.2 * slew
    assert choke_step(-climb_pa_s, low - 1.0e5) == pytest.approx(-slew)  # falling: one slew


def test_outside_the_window_the_choke_and_pump_are_driven_back_from_where_they_are(setup):
    config, _ = setup
    f, margin = config.well.formation, config.protection.pressure_margin_pa
    slew = config.nmpc.input_slew
    p = fresh(setup, start=(0.0, 0.0, 0.02, 0.0))            # choke shut, bpp commanded 1200 L/min
    held = [0.0, 0.0, 0.02, 0.0]                             # an advisor holding that
    over = f.fracture_pressure_pa - margin + 1.0e5
    flows = (0.001, 0.0125)                                  # measured: 60 L/min out, bpp at 750 L/min
    d = p.apply(held, 0.0, 0.0, over, 0.0, 0.5, manual_choke_opening=0.0, surface_flows=flows)
    # opening the choke from the flow going in (750 L/min), more than the 60 L/min going out
    assert d.command[1] == pytest.approx(0.0125 + slew.choke_flow_m3s)
    assert d.command[2] == pytest.approx(0.0125 - slew.bpp_flow_m3s)       # below the pump, not
    assert d.manual_choke_opening is None                                 # its command
    assert any(c.code == "window_guard" and "over the window's fracture limit 705.0 bar" in c.text for c in d.clamps)
    asked = p.apply([0.0, 0.03, 0.0, 0.0], 0.0, 0.0, over, 0.0, 0.5, surface_flows=flows)
    # an advisor cutting the pump faster (at the machine slew) keeps its cut
    assert asked.command[2] == pytest.approx(0.0125 - 2 * slew.bpp_flow_m3s)
    under = f.pore_pressure_pa + margin - 1.0e5
    p = fresh(setup, start=(0.0, 0.02, 0.005, 0.0))           # an advisor asking for 1200 L/min out
    d = p.apply([0.0, 0.02, 0.0, 0.0], 0.0, 0.0, under, 0.0, 0.5, surface_flows=(0.01, 0.005))
    # closing, not opening: from the 300 L/min going in, under the 600 L/min coming out
    assert d.command[1] == pytest.approx(0.005 - slew.choke_flow_m3s)
    circulating = fresh(setup, start=(0.0, 0.02, 0.005, 0.0)).apply(
        [0.0, 0.02, 0.0, 0.0], 0.0, 0.0, under, 0.016, 0.5, surface_flows=(0.01, 0.005))
    assert circulating.command[1] == pytest.approx(0.01 - slew.choke_flow_m3s)  # out < in: from out
    assert d.command[2] == pytest.approx(0.005 + slew.bpp_flow_m3s)        # pump back up
    assert any("under the window's pore limit 665.0 bar" in c.text for c in d.clamps)
    inside = p.apply([0.0, 0.02, 0.0, 0.0], 0.0, 0.0, 6.85e7, 0.0, 0.5, surface_flows=flows)
    assert not any("window's" in c.text for c in inside.clamps)


def test_a_block_not_following_has_its_reference_held_at_the_string_then_starts_from_rest(setup):
    """While the drawworks watch says the block does not follow, the reference goes to the
    measured string at once (not at the acceleration limit); after it, the advisor's
    reference starts from there at rest, within the acceleration limit."""
    config, _ = setup
    p = fresh(setup)
    for k in range(1, 8):                     # the reference pulled out at 0.5 m/s
        d = p.apply([0.5 * k, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    ahead = d.command[0]
    d = p.apply([ahead + 0.5, CIRCULATION, 0.0, 1.06e7], 1.2, 0.0, 6.85e7, CIRCULATION, 0.5,
                block_not_following=True)
    assert d.command[0] == 1.2 and ahead > 1.2
    assert [c.code for c in d.clamps] == ["drawworks_not_following"] and d.clamps[0].value == 1.2
    d = p.apply([ahead + 1.0, CIRCULATION, 0.0, 1.06e7], 1.2, 0.0, 6.85e7, CIRCULATION, 0.5)
    step = config.protection.trip_acceleration_max_mps2 * config.protection.command_period_s ** 2
    assert d.command[0] == pytest.approx(1.2 + step)


def test_circulation_lost_and_a_stuck_choke_set_the_protective_stop_until_it_moves(setup):
    """The mud pump tripped (a trip action) and the choke not moving on its flow loop: the
    brake set (the decision's emergency stop), the block reference at the string, the
    back-pressure pump at its maximum; kept while the choke stands still, released once it
    moves; a stuck choke with circulation is no stop."""
    from drill_protection.pump_trip import TripAction
    config, _ = setup
    lost = TripAction(choke_flow_m3s=0.0, bpp_flow_min_m3s=0.01, reason="pump trip")
    request = [3.0, CIRCULATION, 0.0, 1.06e7]
    p = fresh(setup)
    d = p.apply(request, 2.0, 0.5, 6.85e7, 0.0, 0.5, choke_not_following=True)
    assert not d.emergency_stop                                  # circulating: no stop
    d = p.apply(request, 2.1, 0.5, 6.85e7, 0.0, 0.5, trip_action=lost, choke_not_following=True,
                choke_moving=False)
    assert d.emergency_stop and "protective_stop" in [c.code for c in d.clamps]
    assert d.command[0] == 2.1 and d.command[2] == config.actuators.bpp.maximum
    d = p.apply(request, 2.1, 0.0, 6.85e7, 0.0, 0.5, trip_action=lost, choke_moving=False)
    assert d.emergency_stop                                      # still standing: kept
    d = p.apply(request, 2.1, 0.0, 6.85e7, 0.0, 0.5, trip_action=lost, choke_moving=True)
    assert not d.emergency_stop and "protective_stop" not in [c.code for c in d.clamps]
    assert not p.emergency_stop                                  # the operator's stop untouched


def test_circulation_lost_while_pulling_faster_than_the_swab_allows_holds_the_string(setup):
    """Pulled at 0.5 m/s when circulation is lost with the BHP without friction at the
    window's low edge (no swab allowed): the block reference goes to the string at once, not
    down the acceleration limit, and the back-pressure pump is commanded to its maximum for
    the string's swab as it stops; then it starts from rest within the limits and the pump
    goes back to the trip's floor."""
    from drill_protection.pump_trip import TripAction
    config, _ = setup
    p = fresh(setup)
    for k in range(1, 8):
        d = p.apply([0.5 * k, CIRCULATION, 0.0, 1.06e7], 0.0, 0.0, 6.85e7, CIRCULATION, 0.5)
    ahead = d.command[0]
    low = config.pressure_window_pa[0]
    lost = TripAction(choke_flow_m3s=0.0, bpp_flow_min_m3s=0.01, reason="pump trip",
                      friction_free_bhp_pa=low)
    d = p.apply([ahead + 0.5, CIRCULATION, 0.0, 1.06e7], 1.5, 0.5, 6.85e7, 0.0, 0.5,
                trip_action=lost)
    assert d.command[0] == 1.5 and "lost_circulation_hold" in [c.code for c in d.clamps]
    assert d.command[2] == config.actuators.bpp.maximum
    assert d.standing_speed_limits_mps[1] == 0.0
    d = p.apply([ahead + 1.0, CIRCULATION, 0.0, 1.06e7], 1.6, 0.0, 6.85e7, 0.0, 0.5,
                trip_action=lost)
    assert d.command[0] == 1.5 and "lost_circulation_hold" not in [c.code for c in d.clamps]
    assert d.command[2] < config.actuators.bpp.maximum


def test_on_a_multi_stand_trip_a_racked_stand_moves_the_references_and_a_connection_is_no_loss(
        cfg, wm):
    """A connection racks a stand: the block reference and the positions the velocity is
    read from count from the new top (no 28 m jump read as a run-in at 28 m/s); the floor
    stopping the mud pump for it is not a lost circulation, the same pump stopped with the
    floor moving the string is."""
    from types import SimpleNamespace

    from drill_core.operating_point import initial_operating_point
    from drill_core.rig_root import config_dir
    from drill_core.scenario import load_scenario
    from drill_core.tripping.rig_floor import FloorCommand
    from drill_core.tripping.sequence import CONNECTION, MOVING, PUMP_UP, TripStep
    from drill_protection.tick import ProtectionTick
    from tick_inputs import command

    scenario = load_scenario(config_dir() / "scenarios" / "trip_out.yaml")[0]
    op = initial_operating_point(wm, scenario.initial)

    def floor(phase, racked=(None, None)):
        return FloorCommand(TripStep(phase, 1, phase != MOVING, phase == MOVING, 0.0, 28.0, 1),
                            0.0, *racked)

    samples = itertools.count()

    def m(position_m, flowing):
        live = 1.0e-9 * next(samples)           # a live gauge's noise: never frozen
        return SimpleNamespace(block_position_m=position_m + live, choke_dp_pa=2.0e6 + live,
                               bhp_pa=6.85e7 + live,
                               string_flow_m3s=CIRCULATION if flowing else math.nan,
                               string_flow_valid=flowing, return_flow_m3s=CIRCULATION + live,
                               pit_volume_m3=50.0 + live, bpp_flow_m3s=live,
                               trip_tank_volume_m3=6.0)

    def pump_stopped(phase):
        """The codes the protection raises when the pump stops in the floor's ``phase``."""
        tick = ProtectionTick(cfg, wm, scenario, op)
        assert tick.watch.trip_tank                   # the detector reads the trip tank
        for k in range(10):
            tick.observe(k * 100_000_000, m(28.05, True))
        tick.floor(floor(phase))
        tick.limit(command(op, block_position_ref_m=28.05), m(28.05, True), 1_000_000_000, 0.5)
        return tick, [n.code for k in range(11, 20)
                      for n in tick.observe(k * 100_000_000, m(28.05, False))]
    assert "circulation_lost" in pump_stopped(MOVING)[1]
    tick, codes = pump_stopped(CONNECTION)
    assert "circulation_lost" not in codes
    previous = tick.protection.previous[0]
    tick.floor(floor(PUMP_UP, (0.0, 28.0)))
    assert tick.protection.previous[0] == pytest.approx(previous - 28.0)
    tick.observe(2_000_000_000, m(0.05, False))
    assert tick.watch.velocity_mps == pytest.approx(0.0, abs=1e-6)


def test_on_a_multi_stand_trip_the_trip_tank_against_the_steel_raises_the_swabbed_kick(cfg, wm):
    """Stand after stand the trip tank gives the hole 60 L less than the stand's steel (the
    formation gives the rest): once the running gain passes the programme's limit (0.1 m^3)
    at a stand's end the protection raises trip_tank_gain, once."""
    from types import SimpleNamespace

    from drill_core.operating_point import initial_operating_point
    from drill_core.rig_root import config_dir
    from drill_core.scenario import load_scenario
    from drill_core.tripping.rig_floor import FloorCommand
    from drill_core.tripping.sequence import MOVING, SET_SLIPS, TripStep
    from drill_protection.tick import ProtectionTick

    scenario = load_scenario(config_dir() / "scenarios" / "trip_out_swabbed_kick.yaml")[0]
    tick = ProtectionTick(cfg, wm, scenario, initial_operating_point(wm, scenario.initial))
    steel_m3 = tick.trip_sheet.volumes.steel_m3
    tank_m3, raised = 6.0, []
    for stand in (1, 2, 3, 4):
        for k, phase in enumerate((MOVING, SET_SLIPS)):
            tick.floor(FloorCommand(TripStep(phase, stand, phase != MOVING, True, 1.0,
                                             28.0 * stand, stand - 1), 0.0, None, None))
            t_ns = (100 * stand + 50 * k) * 1_000_000_000
            m = SimpleNamespace(block_position_m=0.0, choke_dp_pa=2.0e6, bhp_pa=6.85e7,
                                string_flow_m3s=CIRCULATION, string_flow_valid=True,
                                return_flow_m3s=CIRCULATION, pit_volume_m3=50.0,
                                bpp_flow_m3s=0.0, trip_tank_volume_m3=tank_m3)
            raised += [(stand, n.code) for n in tick.observe(t_ns, m)
                       if n.code.startswith("trip_tank")]
        tank_m3 -= steel_m3 - 0.06               # the hole took 60 L less than the steel
    assert raised == [(3, "trip_tank_gain")]     # 120 L over the limit at stand 2's end


def test_circulation_lost_and_a_back_pressure_pump_that_does_not_deliver_stop_the_trip(setup):
    """Nothing then gives the choke a flow: the protective stop sets the brake and the
    choke's BHP loop (as for a stuck choke); a pump that does not deliver while the well
    circulates stops nothing."""
    from drill_protection.pump_trip import TripAction
    p = fresh(setup)
    lost = TripAction(None, 0.01, "circulation lost 3 s ago")
    d = p.apply([0.5, CIRCULATION, 0.01, 1.06e7], 0.0, -0.5, 6.85e7, 0.0, 0.5,
                trip_action=lost, choke_dp_pa=2.0e6, bpp_not_delivering=True)
    assert d.emergency_stop and d.command[0] == 0.0
    [stop] = [c for c in d.clamps if c.code == "protective_stop"]
    assert "back-pressure pump does not deliver" in stop.text
    circulating = fresh(setup).apply([0.5, CIRCULATION, 0.01, 1.06e7], 0.0, 0.0, 6.85e7,
                                     CIRCULATION, 0.5, choke_dp_pa=2.0e6,
                                     bpp_not_delivering=True)
    assert not circulating.emergency_stop
