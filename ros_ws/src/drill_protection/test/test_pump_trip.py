"""The protection's answer to a lost circulation (drill_protection.pump_trip): found from
the command and the string-flow meter only, the back-pressure pump kept going, the choke
held shut once while the BHP without friction is under the window, within the fracture
limit; and how the limiter applies it."""
import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.event_codes import Notice
from drill_protection.protection import ProcessProtection
from drill_protection.pump_trip import PumpTripResponse, TripAction

SPP_PA = 1.06e7
BHP_PA = 6.85e7
PERIOD_S = 0.1


@pytest.fixture(scope="module")
def setup(cfg, wm):
    return cfg, wm


def response(setup) -> PumpTripResponse:
    config, wm = setup
    return PumpTripResponse(config.protection.pump_trip, wm, config.pressure_window_pa)


def pumping(setup, seconds: float, mud_pump_on: bool = True,
            spp_pa: float = SPP_PA) -> tuple[PumpTripResponse, float]:
    """A response whose advisor asked for the pump, after ``seconds`` of circulation read;
    the time reached."""
    r = response(setup)
    r.request(mud_pump_on, spp_pa)
    return r, circulate(r, seconds)


def circulate(r: PumpTripResponse, seconds: float, start_s: float = 0.0) -> float:
    """Circulation read for ``seconds``; the time reached."""
    t = start_s
    while t < start_s + seconds - 1e-9:
        assert r.observe(t, True, 2.0e6, BHP_PA) is None
        t += PERIOD_S
    return t


def dp_for_friction_free_bhp(r: PumpTripResponse, bhp_pa: float) -> float:
    return bhp_pa - r.surface.column_pa


def test_the_mud_column_plus_the_choke_dp_is_the_bhp_without_friction(setup):
    config, wm = setup
    r = response(setup)
    r.observe(0.0, True, 2.0e6, BHP_PA)
    # 1800 kg/m^3 over 3607.8 m: 637 bar; with 20 bar at the choke 657 bar (the 28 bar of
    # annular friction at 1000 L/min make up the 685 bar)
    assert r.friction_free_bhp_pa() == pytest.approx(657.07e5, abs=0.01e5)
    friction = sum(hy.annulus_friction(np, wm, [1000.0 / 60000.0] * (wm.n - 1), 0.0))
    assert r.friction_free_bhp_pa() + friction == pytest.approx(BHP_PA, abs=0.5e5)


def test_a_blank_meter_while_the_pump_is_asked_for_is_a_lost_circulation(setup):
    r, t = pumping(setup, 2.0)
    assert r.action(t) is None                                 # circulating: nothing to do
    assert r.observe(t, False, 2.0e6, BHP_PA).code == "circulation_lost" and r.lost
    assert r.observe(t + PERIOD_S, False, 2.0e6, BHP_PA) is None   # said once
    assert r.action(t + 1.0) is not None
    assert r.observe(t + 2.0, True, 2.0e6, BHP_PA).code == "circulation_restored"
    assert not r.lost and r.action(t + 2.0) is None


@pytest.mark.parametrize("mud_pump_on, spp_pa, circulated_s", [
    (False, SPP_PA, 2.0),      # the advisor stopped the pump (a connection): planned
    (True, 0.0, 2.0),          # no stand-pipe pressure asked for: planned
    (True, SPP_PA, 0.0),       # the meter never read a flow (a run started without circulation)
])
def test_a_planned_stop_or_a_well_never_circulated_is_no_loss(setup, mud_pump_on, spp_pa,
                                                               circulated_s):
    r, t = pumping(setup, circulated_s, mud_pump_on, spp_pa)
    for k in range(20):
        assert r.observe(t + k * PERIOD_S, False, 2.0e6, BHP_PA) is None
    assert not r.lost and r.action(t + 2.0) is None


def test_the_choke_is_held_shut_once_until_the_bhp_without_friction_is_inside(setup):
    config, _ = setup
    c = config.protection.pump_trip
    low, _ = config.pressure_window_pa
    r, t = pumping(setup, 1.0)
    r.observe(t, False, 2.0e6, BHP_PA)                   # lost; without friction 657 bar
    a = r.action(t + 1.0)
    assert a.choke_flow_m3s == 0.0 and a.bpp_flow_min_m3s == c.bpp_flow_m3s
    assert "choke held shut" in a.reason
    # the trapped flow raises the choke dp until the BHP without friction reaches the edge
    r.observe(t + 2.0, False, dp_for_friction_free_bhp(r, low + c.static_margin_pa), BHP_PA)
    a = r.action(t + 2.0)
    assert a.choke_flow_m3s is None and a.bpp_flow_min_m3s == c.bpp_flow_m3s
    # once: a later fall of the choke dp (the advisor's) does not shut it again
    r.observe(t + 3.0, False, 1.0e6, BHP_PA)
    assert r.action(t + 3.0).choke_flow_m3s is None


def test_the_choke_is_not_shut_at_the_fracture_edge_nor_after_its_time(setup):
    config, _ = setup
    c = config.protection.pump_trip
    _, high = config.pressure_window_pa
    r, t = pumping(setup, 1.0)
    r.observe(t, False, 2.0e6, high)                     # BHP at the fracture edge
    assert r.action(t + 1.0).choke_flow_m3s is None      # the window guard's side
    r.observe(t + 1.1, False, 2.0e6, BHP_PA)
    assert r.action(t + 2.0).choke_flow_m3s == 0.0
    assert r.action(t + c.trap_max_s + 1.0).choke_flow_m3s is None   # given up
    assert r.action(t + c.trap_max_s + 2.0).choke_flow_m3s is None


def test_the_limiter_shuts_the_choke_past_its_slew_and_keeps_the_pump_going(setup):
    config, wm = setup
    flow = 1000.0 / 60000.0
    p = ProcessProtection(config, wm, np.array([0.0, flow, 0.0, SPP_PA]))
    action = TripAction(0.0, 0.01, "circulation lost 1 s ago: choke held shut")
    d = p.apply([0.0, flow, 0.0, SPP_PA], 0.0, 0.0, BHP_PA, 0.0, 0.5,
                choke_dp_setpoint=(2.0e6, 0.0), trip_action=action)
    assert d.command[1] == 0.0 and d.choke_dp_setpoint is None     # on its flow loop, shut
    assert d.command[2] == pytest.approx(0.01)                      # past the pump's slew
    assert Notice("pump_trip_response", action.reason) in d.clamps
    assert any(c.text.startswith("bpp_flow_m3s 0 -> 0.01") for c in d.clamps)
    # the advisor's choke again: it moves from the shut choke at its slew
    d = p.apply([0.0, flow, 0.0, SPP_PA], 0.0, 0.0, BHP_PA, 0.0, 0.5,
                trip_action=TripAction(None, 0.01, "circulation lost 2 s ago"))
    assert d.command[1] == pytest.approx(config.nmpc.input_slew.choke_flow_m3s)
    assert d.command[2] == pytest.approx(0.01)


def test_over_the_window_the_guard_relieves_and_the_pump_floor_yields(setup):
    config, wm = setup
    _, high = config.pressure_window_pa
    p = ProcessProtection(config, wm, np.array([0.0, 0.01, 0.01, SPP_PA]))
    d = p.apply([0.0, 0.01, 0.01, SPP_PA], 0.0, 0.0, high + 1.0e5, 0.0, 0.5,
                surface_flows=(0.01, 0.01), trip_action=TripAction(None, 0.01, "lost"))
    assert d.command[2] < 0.01                            # the guard slows the pump


def test_under_an_emergency_stop_only_the_pump_floor_answers(setup):
    """The choke is on its own BHP loop (from the measured choke dp: the steady model's
    swab is not what goes without circulation); the back-pressure pump still gives it a
    flow to hold back-pressure with."""
    config, wm = setup
    p = ProcessProtection(config, wm, np.array([0.0, 0.01, 0.0, SPP_PA]))
    p.emergency_stop = True
    d = p.apply([0.0, 0.01, 0.0, SPP_PA], 0.0, 0.4, BHP_PA, 0.0, 0.5,
                trip_action=TripAction(0.0, 0.01, "lost"), choke_dp_pa=2.0e6)
    assert d.emergency_stop and d.emergency_bhp_pa == BHP_PA and d.emergency_dp_start_pa == 2.0e6
    assert d.command[1] == pytest.approx(0.01) and d.command[2] == pytest.approx(0.01)


def test_while_circulation_is_lost_the_pull_out_limit_stands_on_the_bhp_without_friction(setup):
    """685 bar measured with the winding-down pump's friction, 657 bar without it (under the
    window's 665 bar low edge): no pull-out speed keeps the well inside once the friction
    is gone, so pulling is held - and that limit stands (the advisors plan with it); running
    in is only clamped by the surge model of this reading (no circulation: the mud's yield
    stress makes any speed surge), which does not stand; with circulation the same reading
    allows the operator's speed."""
    config, wm = setup
    p = ProcessProtection(config, wm, np.array([0.0, 0.01, 0.01, SPP_PA]))
    free_bhp = 657.07e5
    lost = p.speed_limits(BHP_PA, 0.0, 0.0, 0.5, friction_free_bhp_pa=free_bhp)
    assert lost.pulling_out[0] == 0.0 and "circulation lost" in lost.pulling_out[1]
    assert lost.running_in[0] < 0.5 and lost.running_in[1].startswith("surge model")
    assert lost.standing_mps == (0.5, 0.0)
    circulating = p.speed_limits(BHP_PA, 0.0, 1000.0 / 60000.0, 0.5)
    assert circulating.pulling_out[0] == 0.5 and circulating.standing_mps == (0.5, 0.5)
    d = p.apply([1.0, 0.01, 0.01, SPP_PA], 0.0, 0.0, BHP_PA, 0.0, 0.5,
                trip_action=TripAction(None, 0.01, "lost", free_bhp))
    assert d.command[0] == 0.0 and d.standing_speed_limits_mps == (0.5, 0.0)


def test_while_circulation_is_lost_running_in_stands_on_the_bhp_without_friction_too(setup):
    """The string just set off downwards (0.035 m/s) with no circulation, 695.5 bar
    measured, the choke holding 711 bar once the surge is gone (over the 705 bar high
    edge): the surge model puts 20.6 bar of yield at that speed and would read the reading
    back to 675 bar, letting the string run in at the operator's 0.5 m/s (26.8 bar); from
    the BHP without friction no run-in keeps the well inside, so running in is held, and
    that limit stands. The fault matrix's pull-out with a mud-pump trip and a position
    dropout went 0.06 bar over the fracture pressure that way under the baseline."""
    config, wm = setup
    p = ProcessProtection(config, wm, np.array([0.0, 0.01, 0.01, SPP_PA]))
    measured, free_bhp = 695.5e5, 711.1e5
    credited = p.speed_limits(measured, -0.035, 0.0, 0.5)
    assert credited.running_in[0] == 0.5                  # the model's referral alone
    lost = p.speed_limits(measured, -0.035, 0.0, 0.5, friction_free_bhp_pa=free_bhp)
    assert lost.running_in[0] == 0.0 and "circulation lost: surge" in lost.running_in[1]
    assert lost.standing_mps[0] == 0.0


def test_a_held_trip_is_a_standing_limit_and_the_surge_clamp_is_not(setup):
    config, wm = setup
    p = ProcessProtection(config, wm, np.array([0.0, 0.01, 0.01, SPP_PA]))
    _, high = config.pressure_window_pa
    edge = p.speed_limits(high - 0.1e5, 0.0, 1000.0 / 60000.0, 0.5)
    assert edge.running_in[0] < 0.05                   # surge would push BHP over the edge
    assert edge.standing_mps == (0.5, 0.5)             # a clamp of this reading, not standing
    p.trip_hold = "kick alarm: trip stopped"
    held = p.speed_limits(BHP_PA, 0.0, 1000.0 / 60000.0, 0.5)
    assert held.running_in == held.pulling_out == (0.0, "kick alarm: trip stopped")
    assert held.standing_mps == (0.0, 0.0)
    p.trip_hold = ""
    unread = p.speed_limits(float("nan"), 0.0, 1000.0 / 60000.0, 0.5)
    assert unread.running_in[0] == unread.pulling_out[0] == 0.0     # held for this reading,
    assert unread.standing_mps == (0.5, 0.5)                         # which does not stand


def test_a_string_coming_to_rest_is_guarded_on_the_bhp_without_friction(setup):
    """Circulation lost, BHP 680 bar held up by the surge of a string still running in, 655
    bar without that friction (under the window's 665 bar low edge): once the block
    reference is at rest the guard closes the choke from the flow going in (600 L/min)
    before the measured BHP falls under; while the reference still moves it does not (an
    advisor running in against the surge with its choke is left to it)."""
    config, wm = setup
    slew = config.nmpc.input_slew.choke_flow_m3s
    lost = TripAction(None, 0.01, "circulation lost 60 s ago", 655.0e5)
    p = ProcessProtection(config, wm, np.array([0.0, 0.02, 0.01, SPP_PA]))
    d = p.apply([0.0, 0.02, 0.01, SPP_PA], 0.0, -0.2, 680.0e5, 0.0, 0.5,
                surface_flows=(0.013, 0.01), trip_action=lost)
    assert d.command[1] == pytest.approx(0.01 - slew)
    assert any(c.text.startswith("BHP without friction 655.0 bar under") for c in d.clamps)
    moving = ProcessProtection(config, wm, np.array([0.0, 0.02, 0.01, SPP_PA]))
    moving.previous_speed_mps = -0.3
    d = moving.apply([-0.3, 0.02, 0.01, SPP_PA], 0.0, -0.3, 680.0e5, 0.0, 0.5,
                     surface_flows=(0.013, 0.01), trip_action=lost)
    assert d.command[1] == pytest.approx(0.02) and not any("window" in c.text for c in d.clamps)


def test_without_the_choke_dp_the_bhp_less_the_model_friction_is_the_bhp_without_friction(setup):
    """A choke-dp gauge that does not read (dropout or frozen): the BHP at 1000 L/min up the
    annulus less the model's 28 bar of friction there, the same 657 bar within the model's
    fit of the measured BHP."""
    r, t = pumping(setup, 1.0)
    r.observe(t, False, float("nan"), BHP_PA, 1000.0 / 60000.0, 0.0)
    assert r.friction_free_bhp_pa() == pytest.approx(657.07e5, abs=0.5e5)
    assert r.action(t + 1.0).choke_flow_m3s == 0.0          # under the window: held shut


def test_without_the_bhp_the_choke_is_still_held_shut_within_the_fracture_edge(setup):
    """A BHP gauge that does not read: the trap judges the fracture edge on the BHP from the
    surface (column + choke dp + the model's friction), so it still holds the choke shut,
    and not once that BHP is at the edge."""
    config, _ = setup
    _, high = config.pressure_window_pa
    r, t = pumping(setup, 1.0)
    r.observe(t, False, 2.0e6, float("nan"), 0.0, 0.0)
    assert r.judged_bhp_pa() == pytest.approx(r.surface.column_pa + 2.0e6, abs=0.1e5)
    assert r.action(t + 1.0).choke_flow_m3s == 0.0
    at_edge, t = pumping(setup, 1.0)
    at_edge.observe(t, False, dp_for_friction_free_bhp(at_edge, high), float("nan"), 0.0, 0.0)
    assert at_edge.action(t + 1.0).choke_flow_m3s is None
