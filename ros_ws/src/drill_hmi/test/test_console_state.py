"""Plain-Python console state: unit conversion at the display edge, setpoint requests
from form input, trend buffers, events and acknowledgement, automation level."""
import json
import math

import pytest

from drill_hmi import console_state as cs

WINDOW = cs.Window(6.6e7, 7.1e7, 5.0e5, 0.6)
ACTIVE = {"bhp_ref_pa": 6.7e7, "bhp_band_pa": 2.0e5, "choke_dp_ref_pa": 2.0e6, "choke_dp_band_pa": 5.0e5,
          "block_position_target_m": 8.0, "trip_speed_limit_mps": 0.5, "controller_enabled": True,
          "mud_pump_on": True, "source": "scenario"}


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


# --------------------------------------------------------------------------- units
def test_units_round_trip():
    assert cs.bar_to_pa(640.5) == pytest.approx(6.405e7)
    assert cs.pa_to_bar(6.405e7) == pytest.approx(640.5)
    assert cs.lpm_to_m3s(1000.0) == pytest.approx(0.0166667, rel=1e-5)
    assert cs.m3s_to_lpm(cs.lpm_to_m3s(1234.5)) == pytest.approx(1234.5)


# --------------------------------------------------------------------------- form input
def test_request_converts_bar_to_pa_and_keeps_the_rest():
    request = cs.build_request(ACTIVE, {"bhp_bar": "672.5", "dp_bar": 18})
    assert request["bhp_ref_pa"] == pytest.approx(6.725e7)
    assert request["choke_dp_ref_pa"] == pytest.approx(1.8e6)
    for key in ("bhp_band_pa", "choke_dp_band_pa", "block_position_target_m", "trip_speed_limit_mps"):
        assert request[key] == ACTIVE[key]
    assert request["controller_enabled"] is True and request["mud_pump_on"] is True
    assert request["source"] == "operator"
    assert set(request) == set(cs.SETPOINT_FIELDS) | {"source"}


def test_request_accepts_decimal_comma_whitespace_and_empty_fields():
    request = cs.build_request(ACTIVE, {"bhp_bar": " 671,25 ", "dp_bar": "", "target_m": None,
                                        "speed_mps": "0.3"})
    assert request["bhp_ref_pa"] == pytest.approx(6.7125e7)
    assert request["choke_dp_ref_pa"] == ACTIVE["choke_dp_ref_pa"]
    assert request["trip_speed_limit_mps"] == pytest.approx(0.3)


def test_trip_plan_and_flags():
    request = cs.build_request(ACTIVE, {"target_m": "-2.5", "controller_enabled": "off"})
    assert request["block_position_target_m"] == -2.5
    assert request["controller_enabled"] is False
    assert "controller_enabled off" in cs.describe_changes(ACTIVE, request)


@pytest.mark.parametrize("form, message", [
    ({"bhp_bar": "abc"}, "BHP setpoint [bar]: 'abc' is not a number"),
    ({"bhp_bar": "nan"}, "not a finite number"),
    ({"bhp_bar": "inf"}, "not a finite number"),
    ({"bhp_bar": True}, "expected a number"),
    ({"bhp_bar": "-1"}, "must be >= 0"),
    ({"bhp_band_bar": "0"}, "BHP band [bar]: 0 must be > 0"),
    ({"dp_band_bar": "-0.5"}, "must be > 0"),
    ({"speed_mps": "0"}, "trip speed limit [m/s]: 0 must be > 0"),
    ({"controller_enabled": "maybe"}, "is not on/off"),
    ({"bhp_pa": 6.7e7}, "unknown field(s) bhp_pa"),
    ({}, "nothing to change"),
    ({"bhp_bar": "670", "target_m": "8"}, "nothing to change"),
])
def test_bad_form_input_is_refused_with_a_reason(form, message):
    with pytest.raises(cs.FormError, match=None) as err:
        cs.build_request(ACTIVE, form)
    assert message in str(err.value)


def test_no_request_before_setpoints_are_known():
    with pytest.raises(cs.FormError, match="no setpoints in force"):
        cs.build_request(None, {"bhp_bar": "670"})


def test_window_is_left_to_the_service():
    """Above fracture is syntactically fine: the supervisor's service refuses it with its reason."""
    request = cs.build_request(ACTIVE, {"bhp_bar": "800"})
    assert request["bhp_ref_pa"] == pytest.approx(8.0e7)


def test_nan_bhp_reference_is_kept_and_described_as_hold():
    active = dict(ACTIVE, bhp_ref_pa=math.nan)
    request = cs.build_request(active, {"dp_bar": "22"})
    assert math.isnan(request["bhp_ref_pa"])
    assert cs.describe_changes(active, request) == "choke dp setpoint 20 -> 22 bar"
    request = cs.build_request(active, {"bhp_bar": "675"})
    assert cs.describe_changes(active, request) == "BHP setpoint hold -> 675 bar"


def test_stand_targets():
    assert cs.stand_target(ACTIVE, "out") == pytest.approx(36.0)
    assert cs.stand_target(ACTIVE, "in") == pytest.approx(-20.0)
    assert cs.stand_target(dict(ACTIVE, block_position_target_m=math.nan), "out", 27.0) == 27.0
    with pytest.raises(cs.FormError, match="expected 'out'"):
        cs.stand_target(ACTIVE, "up")


def test_levels():
    assert cs.level_or_error("advisory") == "advisory"
    with pytest.raises(cs.FormError, match="manual, advisory, closed_loop"):
        cs.level_or_error("auto")


# --------------------------------------------------------------------------- trends
def test_trend_buffer_is_bounded_and_incremental():
    state = cs.ConsoleState(WINDOW, trend_points=5)
    for k in range(8):
        state.on_measurement(10.0 + 0.1 * k, {"bhp_pa": 6.7e7 + k, "choke_dp_pa": 2e6, "block_position_m": 0.1 * k,
                                              "string_flow_m3s": math.nan, "string_flow_valid": False})
    bhp = state.trend("bhp_measured")
    assert len(bhp) == 5 and bhp[-1] == (10.7, 6.7e7 + 7)
    assert state.trend("flow_measured") == []          # invalid flow is not a point
    snap = state.snapshot(0)
    seq = snap["seq"]
    assert len(snap["trends"]["bhp_measured"]) == 5
    assert state.snapshot(seq)["trends"] == {}
    state.on_estimate(10.8, {"bhp_pa": 6.71e7, "choke_dp_pa": 2.0e6, "string_velocity_mps": -0.01,
                             "string_position_m": 0.7, "nis": 3.2, "nis_dof": 4})
    new = state.snapshot(seq)["trends"]
    assert set(new) == {"bhp_estimate", "dp_estimate", "velocity_estimate", "position_estimate", "nis"}
    assert new["bhp_estimate"] == [[10.8, 6.71e7]]


def test_snapshot_is_strict_json():
    state = cs.ConsoleState(WINDOW)
    state.on_setpoints(dict(ACTIVE, bhp_ref_pa=math.nan))
    state.add_point("x", 1.0, math.nan)                  # dropped
    state.on_nmpc(2.0, {"solve_time_s": 0.01, "bhp_ref_pa": math.inf})
    text = json.dumps(state.snapshot(), allow_nan=False)
    data = json.loads(text)
    assert data["setpoints"]["bhp_ref_pa"] is None
    assert data["nmpc"]["bhp_ref_pa"] is None
    assert data["window"]["fracture_pressure_pa"] == 7.1e7


# --------------------------------------------------------------------------- events
def test_events_collapse_repeats_and_acknowledge():
    state = cs.ConsoleState(WINDOW)
    a = state.on_event("protection", 1.0, "alarm", "window_exit", "BHP 712 bar outside the window", False)
    state.on_event("protection", 2.0, "clamp", "level_hold", "automation level manual: held", True)
    state.on_event("protection", 3.0, "clamp", "level_hold", "automation level manual: held", True)
    state.on_event("operator", 3.5, "setpoint", "operator_setpoints_accepted", "[console] setpoints accepted", True)
    events = state.events()
    assert [e["kind"] for e in events] == ["alarm", "clamp", "setpoint"]
    assert events[1]["count"] == 2 and events[1]["t"] == 3.0
    assert [e["needs_ack"] for e in events] == [True, True, False]
    state.on_event("protection", 4.0, "clamp", "level_hold", "automation level manual: held", True)   # interleaved repeat
    events = state.events()
    assert [e["kind"] for e in events] == ["alarm", "setpoint", "clamp"]
    assert events[-1]["count"] == 3 and events[-1]["t"] == 4.0
    assert state.unacknowledged() == 2
    done = state.acknowledge(a["id"])
    assert [e["id"] for e in done] == [a["id"]] and state.unacknowledged() == 1
    with pytest.raises(cs.FormError, match="already acknowledged"):
        state.acknowledge(a["id"])
    with pytest.raises(cs.FormError, match="not in the recent events"):
        state.acknowledge(999)
    assert len(state.acknowledge(None)) == 1 and state.unacknowledged() == 0


def test_the_rigs_faults_and_formation_changes_are_alarms_to_acknowledge():
    state = cs.ConsoleState(WINDOW)
    state.on_event("rig", 60.0, "fault", "trip", "mud_pump trip: starts", True)
    state.on_event("rig", 90.0, "formation", "pore_pressure", "pore_pressure to 6.9e+07 Pa: starts", True)
    state.on_event("operator", 95.0, "setpoint", "operator_setpoints_accepted", "[console] setpoints accepted", True)
    assert [e["needs_ack"] for e in state.events()] == [True, True, False]
    assert state.unacknowledged() == 2


# --------------------------------------------------------------------------- level
def test_level_in_force_is_the_protections_while_it_is_alive():
    clock = FakeClock()
    state = cs.ConsoleState(WINDOW, clock=clock)
    assert state.level_in_force()["level"] == "closed_loop"
    assert "default" in state.level_in_force()["source"]
    state.on_level("advisory")
    forced = state.level_in_force()
    assert (forced["level"], forced["source"], forced["requested"]) == ("advisory", "latched request",
                                                                       "advisory")
    state.on_level_in_force("manual")                      # latched /protection/automation_level
    state.on_status("protection", {"mode": "realtime/manual", "healthy": True})
    assert state.level_in_force()["level"] == "manual"
    assert state.level_in_force()["source"] == "protection"
    clock.now += cs.STALE_AFTER_S + 1                      # protection went silent
    assert state.level_in_force()["level"] == "advisory"
    state.on_estop_in_force(True)
    state.on_status("protection", {"mode": "realtime/emergency_stop", "healthy": True})
    forced = state.level_in_force()
    assert forced["emergency_stop"] is True
    assert forced["level"] == "manual", "the level the protection applies stays shown under the stop"
    assert "emergency stop" in forced["source"]
    state.on_estop(False)
    state.on_estop_in_force(False)
    assert state.level_in_force()["emergency_stop"] is False


def test_result_is_reported():
    state = cs.ConsoleState(WINDOW)
    state.set_result("setpoints", False, "BHP above fracture")
    assert state.snapshot()["result"]["reason"] == "BHP above fracture"


def test_the_mpd_view_of_a_measurement():
    window = cs.Window(6.6e7, 7.1e7, 5.0e5, 0.6, bhp_depth_m=3600.0, gravity_mps2=9.81)
    state = cs.ConsoleState(window)
    sample = {"bhp_pa": 6.85e7, "choke_dp_pa": 2.0e6, "block_position_m": 0.0,
              "string_flow_m3s": 0.0160, "string_flow_valid": True, "return_flow_m3s": 0.0170,
              "pit_volume_m3": 40.0, "bpp_flow_m3s": 0.0005}
    state.on_measurement(0.0, sample)
    state.on_measurement(0.1, dict(sample, pit_volume_m3=40.25))
    m = state.snapshot()["measurement"]
    assert m["ecd_kgm3"] == pytest.approx(6.85e7 / (9.81 * 3600.0))      # 1939.6 kg/m^3
    assert m["delta_flow_m3s"] == pytest.approx(0.0170 - 0.0160 - 0.0005)
    assert m["pit_gain_m3"] == pytest.approx(0.25)
    state.on_measurement(0.2, dict(sample, string_flow_valid=False, string_flow_m3s=math.nan))
    assert state.snapshot()["measurement"]["delta_flow_m3s"] is None   # pump off: no balance


def test_the_ecd_at_the_casing_shoe_comes_from_the_estimates_pressures():
    """Nodes at 0 / 1638 / 2730 / 3607.8 m, the shoe at 3276 m (0.622 of the way from the
    third node to the fourth): a static 1800 kg/m^3 column reads 1800 there; 20 bar at
    the choke and 150 Pa/m of friction, 1800 + (20e5 + 150 * 3276) / (9.81 * 3276)."""
    depths = (0.0, 1638.0, 2730.0, 3607.8)
    window = cs.Window(6.6e7, 7.1e7, 5.0e5, 0.6, bhp_depth_m=3607.8, gravity_mps2=9.81,
                       shoe_depth_m=3276.0, node_depth_m=depths)
    state = cs.ConsoleState(window)
    estimate = {"bhp_pa": 6.4e7, "choke_dp_pa": 0.0, "string_velocity_mps": 0.0}
    state.on_estimate(0.0, dict(estimate, annulus_pressures_pa=[1800.0 * 9.81 * d for d in depths]))
    assert state.snapshot()["estimate"]["shoe_ecd_kgm3"] == pytest.approx(1800.0)
    circulating = [2.0e6 + 1800.0 * 9.81 * d + 150.0 * d for d in depths]
    state.on_estimate(0.1, dict(estimate, annulus_pressures_pa=circulating))
    assert state.snapshot()["estimate"]["shoe_ecd_kgm3"] == pytest.approx(
        1800.0 + (2.0e6 + 150.0 * 3276.0) / (9.81 * 3276.0))              # 1877.5 kg/m^3
    state.on_estimate(0.2, dict(estimate, annulus_pressures_pa=[]))      # no pressures named
    assert state.snapshot()["estimate"]["shoe_ecd_kgm3"] is None
    unknown = cs.ConsoleState(cs.Window(6.6e7, 7.1e7, node_depth_m=depths))   # no shoe reported
    unknown.on_estimate(0.0, dict(estimate, annulus_pressures_pa=circulating))
    assert unknown.snapshot()["estimate"]["shoe_ecd_kgm3"] is None


def test_the_display_unit_systems_convert_from_si():
    units = cs.ConsoleState(WINDOW).snapshot()["display_units"]
    field, metric = units["field"], units["metric"]
    assert 1.0e5 * field["pressure"][1] == pytest.approx(14.5038, rel=1e-5)      # psi per bar
    assert (1000.0 / 60000.0) * field["flow"][1] == pytest.approx(264.172, rel=1e-5)  # gpm
    assert 1000.0 * field["density"][1] == pytest.approx(8.34540, rel=1e-5)     # ppg per s.g.
    assert field["length"][1] == pytest.approx(3.28084, rel=1e-5)               # ft per m
    assert field["volume"][1] == pytest.approx(6.28981, rel=1e-5)               # bbl per m^3
    assert 1000.0 * field["force"][1] == pytest.approx(0.224809, rel=1e-5)      # klbf per kN
    assert (metric["pressure"], metric["density"]) == (["bar", 1e-5], ["s.g.", 1e-3])
    assert metric["force"] == ["kN", 1e-3]


def test_the_trip_sheet_is_kept_from_the_floor_and_the_measurements():
    """On a multi-stand trip the console keeps the trip sheet as the report does: each
    measurement with the floor's step for the frame before it, the band from the setpoints
    in force; none before the floor speaks."""
    from drill_core.tripping.programme import TripProgramme
    from drill_core.tripping.sequence import CONNECTION, MOVING, TripStep
    from drill_core.tripping.sheet_feed import TripSheetFeed
    from drill_core.tripping.stands import StandVolumes

    frame_ns = 100_000_000
    volumes = StandVolumes(steel_m3=0.1, closed_end_m3=0.36, contents_m3=0.26)
    state = cs.ConsoleState(WINDOW)
    sample = {"bhp_pa": 6.7e7, "choke_dp_pa": 2.0e6, "block_position_m": 0.0,
              "string_flow_m3s": 0.016, "string_flow_valid": True, "return_flow_m3s": 0.016,
              "pit_volume_m3": 40.0, "bpp_flow_m3s": 0.0, "trip_tank_volume_m3": 6.0}
    state.on_measurement(0.0, sample, 0)
    assert state.snapshot()["trip_sheet"] is None
    state.on_setpoints(dict(ACTIVE))
    start = lambda: TripSheetFeed(TripProgramme(direction="out", stands=2), volumes, frame_ns)
    for k in range(30):           # stand 1: 20 frames moving, 10 in its connection; then stand 2
        stand, phase = (1, MOVING) if k < 20 else (1, CONNECTION) if k < 28 else (2, MOVING)
        state.on_floor(k * frame_ns, TripStep(phase=phase, stand=stand, slips_set=phase == CONNECTION,
                                              latched=True, pump_factor=1.0, bit_height_target_m=0.0,
                                              stands_pulled=stand - 1), start)
        bhp = 6.7e7 - (3.0e5 if 5 <= k < 15 else 0.0)   # 1 s swabbed past the 2 bar band
        state.on_measurement((k + 1) * 0.1, dict(sample, bhp_pa=bhp, trip_tank_volume_m3=6.0 - 0.004 * k),
                             (k + 1) * frame_ns)
    sheet = json.loads(json.dumps(state.snapshot()))["trip_sheet"]
    assert (sheet["direction"], sheet["stands"], sheet["stand"], sheet["phase"]) == ("out", 2, 2, MOVING)
    [row] = sheet["rows"]
    assert row["stand"] == 1 and row["peak_swab_pa"] == pytest.approx(3.0e5)
    assert row["outside_band_s"] == pytest.approx(0.7)   # the gauge's 1 s mean: frames 11-17
    assert row["out_of_slips_s"] == pytest.approx(2.0 - 0.1)       # 20 frames, the first untimed
    assert row["measured_fill_m3"] == pytest.approx(0.004 * 28)
    assert row["gain_m3"] == pytest.approx(0.1 - 0.004 * 28)
    assert sheet["cumulative_gain_m3"] == pytest.approx(row["gain_m3"])
