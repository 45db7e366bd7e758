"""The protection's tick (drill_protection.tick) beyond the limiter: the operator's
buttons and the scenario's actions pressing them, the pore/fracture window's exits, and
the machine command it sends under an emergency stop."""
from __future__ import annotations

import dataclasses
import itertools
import math
from types import SimpleNamespace

import pytest

from drill_core.operating_point import initial_operating_point
from drill_core.operator_actions import OperatorAction
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario
from drill_protection.surface_bhp import SurfaceBhp
from drill_protection.tick import MachineCommand, ProtectionTick

CONFIG = config_dir()


@pytest.fixture()
def setup(cfg, wm):
    config = cfg
    scenario = load_scenario(CONFIG / "scenarios" / "short_trip.yaml")[0]
    scenario = dataclasses.replace(scenario, operator=(
        OperatorAction(time_s=2.0, action="emergency_stop"),
        OperatorAction(time_s=1.0, action="automation_level", level="advisory")))
    op = initial_operating_point(wm, scenario.initial)
    return config, ProtectionTick(config, wm, scenario, op), op


def test_scenario_actions_press_the_buttons_in_time_order_once(setup):
    _, tick, _ = setup
    assert tick.press_due(0.5) == []
    assert [n.code for n in tick.press_due(2.0)] == ["automation_level", "estop_engaged"]
    assert tick.protection.emergency_stop and tick.protection.automation_level == "advisory"
    assert tick.press_due(3.0) == []
    assert tick.set_emergency_stop(True) == []                   # already engaged: no notice
    assert [n.code for n in tick.set_emergency_stop(False)] == ["estop_released"]


def test_an_unknown_automation_level_is_refused_and_changes_nothing(setup):
    _, tick, _ = setup
    [notice] = tick.set_automation_level("autopilot")
    assert notice.code == "level_refused" and "autopilot" in notice.text
    assert tick.protection.automation_level == "closed_loop"


def test_the_window_is_left_and_reentered_once_each(setup):
    config, tick, op = setup
    f = config.well.formation

    def window(bhp_pa):
        return tick.check_window(dataclasses.replace(sample(op), bhp_pa=bhp_pa))
    assert window(0.5 * (f.pore_pressure_pa + f.fracture_pressure_pa)) == []
    [out] = window(f.pore_pressure_pa - 1.0e5)
    assert out.code == "window_exit" and out.value == f.pore_pressure_pa - 1.0e5
    assert window(math.nan) == [] and window(f.pore_pressure_pa - 2e5) == []
    assert [n.code for n in window(f.pore_pressure_pa)] == ["window_return"]
    assert tick.window_exits == 1


def test_a_frozen_bhp_gauge_is_no_window_reading(setup):
    """A gauge repeating its value is read as a dropout (drill_protection.reading): the
    window is judged on the next live reading."""
    config, tick, op = setup
    low = config.well.formation.pore_pressure_pa
    codes = [n.code for k in range(8) for n in tick.observe(
        k * 100_000_000, dataclasses.replace(sample(op), bhp_pa=low - 1.0e5))]
    assert codes.count("gauge_frozen") == 1
    assert tick.check_window(dataclasses.replace(sample(op), bhp_pa=low - 1.0e5)) == []
    assert [n.code for n in tick.check_window(dataclasses.replace(sample(op),
                                                                  bhp_pa=low - 2.0e5))] == []
    live = dataclasses.replace(sample(op), bhp_pa=low - 3.0e5)
    assert "gauge_live" in [n.code for n in tick.observe(800_000_000, live)]
    assert [n.code for n in tick.check_window(live)] == ["window_exit"]


_SAMPLES = itertools.count()     # each sample's gauges move a little: a live gauge's noise


@dataclasses.dataclass(frozen=True)
class Sample:
    """drill_msgs/RigMeasurement's fields the protection reads (SI)."""
    return_flow_m3s: float
    string_flow_m3s: float
    string_flow_valid: bool
    bpp_flow_m3s: float
    block_position_m: float
    choke_dp_pa: float
    bhp_pa: float
    pit_volume_m3: float
    trip_tank_volume_m3: float


def sample(op):
    live = 1.0e-9 * next(_SAMPLES)
    return Sample(return_flow_m3s=float(op.choke_flow_m3s) + live, string_flow_m3s=float(op.string_flow_m3s),
                  string_flow_valid=True, bpp_flow_m3s=live, block_position_m=live,
                  choke_dp_pa=2.0e6 + live, bhp_pa=6.85e7 + live, pit_volume_m3=live,
                  trip_tank_volume_m3=6.0)


def advisor_request(**fields):
    """An advisor's command, as drill_msgs/RigCommand carries it (SI)."""
    return SimpleNamespace(**{**dict(
        block_position_ref_m=3.0, choke_flow_ref_m3s=0.0167, bpp_flow_m3s=0.0, spp_pa=2.0e7,
        mud_pump_on=True, choke_manual=False, choke_opening_ref=0.0,
        choke_pressure_control=False, choke_dp_ref_pa=0.0, choke_dp_ref_rate_pa_s=0.0,
        bhp_ref_pa=6.85e7, bhp_window_low_pa=math.nan, bhp_window_high_pa=math.nan,
        trip_speed_limit_in_mps=math.nan, trip_speed_limit_out_mps=math.nan), **fields})


def test_without_a_bhp_reading_the_guard_judges_the_bhp_from_the_surface(setup, wm):
    """A BHP gauge out: the window guard reads the BHP as the mud column, the measured choke
    dp and the model's annular friction at the measured flow up the annulus (return flow
    less the back-pressure pump's), and relieves a BHP it puts over the fracture edge; a
    choke dp that puts it inside leaves the choke alone."""
    config, _, op = setup
    _, high = config.pressure_window_pa
    surface = SurfaceBhp(wm)
    over_dp = high + 1.0e5 - surface.column_pa - surface.friction_pa(op.choke_flow_m3s, 0.0)

    scenario = load_scenario(CONFIG / "scenarios" / "short_trip.yaml")[0]

    def guarded(choke_dp_pa):
        tick = ProtectionTick(config, wm, scenario, op)
        for k in range(12):
            last = dataclasses.replace(sample(op), bhp_pa=math.nan, choke_dp_pa=choke_dp_pa + k)
            tick.observe(k * 100_000_000, last)
        decision = tick.limit(advisor_request(choke_flow_ref_m3s=float(op.choke_flow_m3s)),
                              last, 11 * 100_000_000, 0.5)
        return decision, [c for c in decision.clamps if c.code == "window_guard"]
    decision, guard = guarded(over_dp)
    assert guard and guard[0].value == pytest.approx(high + 1.0e5, abs=0.1e5)
    assert decision.command[1] > op.choke_flow_m3s                 # the choke lets more out
    assert guarded(2.0e6)[1] == []


def test_under_the_emergency_stop_the_machine_command_starts_the_choke_bhp_loop(setup):
    _, tick, op = setup
    request = advisor_request()
    for k in range(12):
        tick.observe(k * 100_000_000, sample(op))
    free = tick.machine_command(tick.limit(request, sample(op), 11 * 100_000_000, 0.5), request)
    assert not free.emergency_stop and not free.choke_pressure_control
    tick.set_emergency_stop(True)
    d = tick.limit(request, sample(op), 12 * 100_000_000, 0.5)
    stop = tick.machine_command(d, request)
    assert stop.emergency_stop and stop.emergency_bhp_pa == pytest.approx(6.85e7)
    assert stop.choke_dp_ref_pa == d.emergency_dp_start_pa and math.isfinite(stop.choke_dp_ref_pa)
    assert MachineCommand.as_requested(request).emergency_stop is False
