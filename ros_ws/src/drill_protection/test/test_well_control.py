"""The protection's answer to a kick or losses alarm (drill_protection.well_control): the
window's edge stepped from the BHP the well flowed at while the flow judged after each step
says it still flows, a margin once it does not, never past the other edge's gap or the
configured window; and the limiter holding BHP in the narrowed window."""

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import WellControl, load_rig
from drill_core.rig_root import config_dir
from drill_protection.protection import ProcessProtection
from drill_protection.well_control import Hold, WindowResponse

CONFIG = config_dir()
WINDOW_PA = (6.65e7, 7.05e7)
THRESHOLD_M3S = 3.3e-4
STEP = WellControl(step_pa=2.5e5, interval_s=15.0, settle_s=5.0, kick_margin_pa=1.0e5,
                   losses_margin_pa=0.0, gap_pa=5.0e5, offset_time_constant_s=10.0)
PERIOD_S = 0.1


class Well:
    """Feeds a WindowResponse samples every 0.1 s with the excess volume of a given flow."""

    def __init__(self, response: WindowResponse):
        self.r, self.t, self.volume_m3 = response, 0.0, 0.0

    def feed(self, seconds: float, bhp_pa: float, alarm: str, excess_m3s,
             reference_pa: float = float("nan")) -> list[tuple[float, str]]:
        """``excess_m3s`` a flow or a function of the time since this call began; the
        events with their times."""
        events, start = [], self.t
        while self.t < start + seconds - 1e-9:
            flow = excess_m3s(self.t - start) if callable(excess_m3s) else excess_m3s
            self.volume_m3 += flow * PERIOD_S
            notice = self.r.observe(self.t, bhp_pa, 2.0e6, alarm, self.volume_m3, THRESHOLD_M3S,
                                  reference_pa)
            if notice:
                assert notice.code == "window_narrowed"
                events.append((round(self.t, 1), notice.text))
            self.t += PERIOD_S
        return events


def test_no_alarm_leaves_the_configured_window():
    r = WindowResponse(STEP, WINDOW_PA)
    assert Well(r).feed(60.0, 6.85e7, "", 0.0) == []
    assert r.window_pa == WINDOW_PA


def test_a_kick_raises_the_low_edge_in_steps_while_the_well_flows_then_a_margin():
    r = WindowResponse(STEP, WINDOW_PA)
    well = Well(r)
    well.feed(2.0, 6.85e7, "", 0.0)
    events = well.feed(31.0, 6.85e7, "kick", 2 * THRESHOLD_M3S)
    # at the alarm, and after 15 s and 30 s judged flowing: BHP + 2.5, + 5, + 7.5 bar
    assert [t for t, _ in events] == [2.0, 17.0, 32.0]
    assert r.low_pa == pytest.approx(6.85e7 + 3 * STEP.step_pa)
    assert "low edge raised to 692.5 bar" in events[-1][1] and "+40 L/min" in events[-1][1]
    assert r.high_pa == WINDOW_PA[1]
    # the flow has stopped (under half the threshold): one margin, then no more steps;
    # the margin is taken though the detector's alarm has cleared meanwhile
    events = well.feed(14.0, 6.93e7, "kick", 0.4 * THRESHOLD_M3S)
    events += well.feed(60.0, 6.93e7, "", 0.0)
    assert [t for t, _ in events] == [47.0] and "a margin" in events[0][1]
    assert r.low_pa == pytest.approx(6.85e7 + 3 * STEP.step_pa + STEP.kick_margin_pa)
    assert well.feed(30.0, 6.93e7, "", 0.0) == []          # and none given back


def test_the_flow_is_judged_after_the_step_has_settled():
    """A flow that lasts only through the settling after the step is not judged flowing;
    the judgement is the volume's slope after it, whatever went before."""
    r = WindowResponse(STEP, WINDOW_PA)
    well = Well(r)
    events = well.feed(30.0, 6.85e7, "kick",
                       lambda since: 10 * THRESHOLD_M3S if since < STEP.settle_s else 0.0)
    assert [t for t, _ in events] == [0.0, 15.0] and "a margin" in events[1][1]
    assert r.low_pa == pytest.approx(6.85e7 + STEP.step_pa + STEP.kick_margin_pa)


def test_the_first_step_starts_from_the_reference_when_it_is_further():
    """The well flowed at the reference in force as much as at a passing BHP wave: a kick
    steps from the higher of the two, losses from the lower."""
    kick = WindowResponse(STEP, WINDOW_PA)
    Well(kick).feed(0.5, 6.85e7, "kick", THRESHOLD_M3S, reference_pa=6.87e7)
    assert kick.low_pa == pytest.approx(6.87e7 + STEP.step_pa)
    losses = WindowResponse(STEP, WINDOW_PA)
    Well(losses).feed(0.5, 6.885e7, "losses", -THRESHOLD_M3S, reference_pa=6.85e7)
    assert losses.high_pa == pytest.approx(6.85e7 - STEP.step_pa)


def test_losses_lower_the_high_edge_never_closer_than_the_gap():
    r = WindowResponse(STEP, WINDOW_PA)
    well = Well(r)
    well.feed(1.0, 6.80e7, "losses", -2 * THRESHOLD_M3S)
    assert r.high_pa == pytest.approx(6.80e7 - STEP.step_pa)
    well.feed(120.0, 6.80e7, "losses", -2 * THRESHOLD_M3S)
    assert r.high_pa == pytest.approx(WINDOW_PA[0] + STEP.gap_pa)     # 670 bar, no lower
    assert r.low_pa == WINDOW_PA[0]


def test_a_bhp_over_the_window_starts_the_kick_edge_inside_it():
    r = WindowResponse(STEP, WINDOW_PA)
    Well(r).feed(1.0, 7.20e7, "kick", 2 * THRESHOLD_M3S)
    assert r.low_pa == pytest.approx(WINDOW_PA[1] - STEP.gap_pa)


def test_non_finite_bhp_samples_are_left_out_of_the_median():
    r = WindowResponse(STEP, WINDOW_PA)
    Well(r).feed(0.5, 6.85e7, "", 0.0)
    r.observe(0.5, float("nan"), 2.0e6, "kick", 0.0, THRESHOLD_M3S)
    assert r.low_pa == pytest.approx(6.85e7 + STEP.step_pa)


def test_the_choke_is_held_at_the_setpoint_that_puts_bhp_at_the_target():
    """BHP - dp low-passed: a step in the pressures moves the set-point only by the
    filter's share; the target is half a step inside the moved edge."""
    r = WindowResponse(STEP, WINDOW_PA)
    assert r.hold() is None
    Well(r).feed(30.0, 6.85e7, "", 0.0)                     # BHP - dp = 665 bar
    assert r.hold() is None                                 # window as configured
    r.observe(30.0, 6.85e7, 2.0e6, "kick", 0.0, THRESHOLD_M3S)
    hold = r.hold()
    assert hold.target_bhp_pa == r.target_bhp_pa == pytest.approx(6.85e7 + 1.5 * STEP.step_pa)
    assert hold.choke_dp_pa == pytest.approx(r.target_bhp_pa - (6.85e7 - 2.0e6))
    assert "well control: choke held" in hold.reason
    r.observe(30.1, 6.95e7, 2.0e6, "kick", 0.0, THRESHOLD_M3S)       # a 10 bar wave
    moved = hold.choke_dp_pa - r.hold().choke_dp_pa
    assert moved == pytest.approx(1.0e6 * 0.1 / STEP.offset_time_constant_s)


def test_the_limiter_holds_the_choke_until_the_advisor_aims_inside_the_window():
    """With a well-control hold and the advisor's reference outside the narrowed window the
    choke goes on its pressure loop at the hold's set-point, with the measured return flow
    as feed-forward, and the reference in force is the hold's target; once the advisor aims
    inside the window its choke passes; the trip-speed limits keep to the narrowed window
    either way; outside closed loop nothing is applied."""
    config = load_rig(CONFIG)
    wm = hy.rig_well_model(config)
    start = np.array([0.0, 0.0167, 0.0, 1.06e7])
    protection = ProcessProtection(config, wm, start)
    request = [0.0, 0.0167, 0.0, 1.06e7]
    free = protection.apply(request, 0.0, 0.0, 6.85e7, 0.0167, 0.6, surface_flows=(0.016, 0.0),
                            advisor_bhp_ref_pa=6.85e7)
    assert free.choke_dp_setpoint is None and free.bhp_ref_pa == 6.85e7
    protection.well_control = Hold(3.0e6, 6.8825e7, "well control: test")
    protection.window_pa = (6.87e7, config.pressure_window_pa[1])
    held = protection.apply(request, 0.0, 0.0, 6.85e7, 0.0167, 0.6, surface_flows=(0.016, 0.0),
                            advisor_bhp_ref_pa=6.85e7)
    assert held.choke_dp_setpoint == (3.0e6, 0.0)
    assert held.command[1] == pytest.approx(0.016)
    assert [("well_control_hold", "well control: test")] == [(c.code, c.text) for c in held.clamps] and held.bhp_ref_pa == 6.8825e7
    handed = protection.apply(request, 0.0, 0.0, 6.85e7, 0.0167, 0.6,
                              surface_flows=(0.016, 0.0), advisor_bhp_ref_pa=6.8825e7)
    assert handed.choke_dp_setpoint is None and handed.bhp_ref_pa == 6.8825e7
    assert handed.command[1] == pytest.approx(0.0167) \
        and not any(c.code == "well_control_hold" for c in handed.clamps)
    assert handed.trip_speed_limits_mps == held.trip_speed_limits_mps
    # a BHP 2 bar under the raised edge: pulling out (swab) is limited, running in is not
    assert held.trip_speed_limits_mps[1] < free.trip_speed_limits_mps[1]
    protection.automation_level = "advisory"
    manual = protection.apply(request, 0.0, 0.0, 6.85e7, 0.0167, 0.6, surface_flows=(0.016, 0.0))
    assert not any("well control" in c.text for c in manual.clamps)
