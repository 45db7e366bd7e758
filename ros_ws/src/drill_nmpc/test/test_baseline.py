"""The PI baseline's control law (drill_nmpc.baseline): the fixed-speed ramp to the target,
the PI choke on the BHP error with anti-windup, a missing BHP holding the choke, and its
tick on a multi-stand trip (drill_nmpc.advisor_ticks)."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand
from drill_core.tripping.sequence import CONNECTION, MOVING, SET_SLIPS, TripStep
from drill_nmpc.advisor_ticks import CONNECTION_BPP_FLOW_M3S, BaselineTick, StartInputs
from drill_nmpc.baseline import Baseline

Q0, KP, TI, Q_MAX = 0.01, 5.0e-9, 5.0, 0.05


def test_the_block_ramps_at_the_trip_speed_and_stops_on_the_target():
    b = Baseline(Q0, KP, TI, Q_MAX, trip_speed_mps=0.5, sample_time_s=1.0)
    refs = []
    for _ in range(5):
        b.step(0.0, 6.85e7, 1.8, 6.85e7)
        refs.append(b.block_ref_m)
    assert refs == pytest.approx([0.5, 1.0, 1.5, 1.8, 1.8])
    b.step(3.0, 6.85e7, 0.0, 6.85e7, enabled=False)       # manual: held where measured
    assert b.block_ref_m == 3.0


def test_the_pi_opens_the_choke_on_a_high_bhp_and_holds_it_without_a_reading():
    b = Baseline(Q0, KP, TI, Q_MAX, trip_speed_mps=0.5, sample_time_s=1.0)
    assert b.step(0.0, 6.85e7 + 1.0e5, 0.0, 6.85e7)
    # 1 bar high: kp (1 bar + 1 bar s / Ti) = 30 + 6 L/min more
    assert b.choke_ref_m3s == pytest.approx(Q0 + KP * (1.0e5 + 1.0e5 / TI))
    held = b.choke_ref_m3s
    assert not b.step(0.0, math.nan, 0.0, 6.85e7) and b.choke_ref_m3s == held
    assert not b.step(0.0, 6.85e7, 0.0, None) and b.choke_ref_m3s == held


def test_the_integral_stops_at_the_range():
    b = Baseline(Q0, KP, TI, Q_MAX, trip_speed_mps=0.5, sample_time_s=1.0)
    for _ in range(50):
        b.step(0.0, 6.85e7 - 50.0e5, 0.0, 6.85e7)          # far too low: shut
    assert b.choke_ref_m3s == 0.0
    b.step(0.0, 6.85e7, 0.0, 6.85e7)                        # on the reference again
    assert b.choke_ref_m3s > 0.0                            # no wound-up integral holds it shut


def test_the_ramp_goes_on_from_the_reference_the_protection_applied():
    b = Baseline(Q0, KP, TI, Q_MAX, trip_speed_mps=0.5, sample_time_s=1.0)
    for _ in range(4):
        b.step(0.0, 6.85e7, 8.0, 6.85e7)
    assert b.block_ref_m == pytest.approx(2.0)
    b.adopt_applied(2.0 + 0.5e-3)           # the protection's echo of ours: nothing changes
    assert b.block_ref_m == pytest.approx(2.0)
    b.adopt_applied(1.2)                    # it held the trip at 1.2 m: the ramp goes on from there
    b.step(0.0, 6.85e7, 8.0, 6.85e7)
    assert b.block_ref_m == pytest.approx(1.7)
    b.adopt_applied(math.nan)               # no answer: our own ramp
    b.step(0.0, 6.85e7, 8.0, 6.85e7)
    assert b.block_ref_m == pytest.approx(2.2)


def test_the_integral_stands_while_the_choke_does_not_deliver_the_flow_asked():
    """A choke stuck 200 L/min short of the reference: once that has stood 3 samples, while
    the BHP stays high the integral does not wind on (the reference moves by the
    proportional part alone); a shortfall inside 100 L/min, or one the integral would
    reduce, integrates as before."""
    def after(return_flows, bhp_pa=6.85e7 + 1.0e5):
        b = Baseline(Q0, KP, TI, Q_MAX, trip_speed_mps=0.5, sample_time_s=1.0)
        for flow in return_flows:
            b.step(0.0, bhp_pa, 0.0, 6.85e7, return_flow_m3s=flow)
        return b.pi.integral_pa_s
    stuck = Q0 - 200.0 / 60000.0                   # the meter reads the stuck choke's flow
    assert after([math.nan] + [stuck] * 9) == pytest.approx(3 * 1.0e5)   # then stands
    assert after([math.nan] * 10) == pytest.approx(10 * 1.0e5)       # no reading: no judgement
    following = [Q0 + KP * 1.0e5 * (1.0 + k / TI) - 50.0 / 60000.0 for k in range(10)]
    assert after([math.nan] + following[:-1]) == pytest.approx(10 * 1.0e5)
    # BHP low, the reference going down: a choke passing less than asked integrates, one
    # passing more (it does not close) stands
    assert after([stuck] * 10, bhp_pa=6.85e7 - 1.0e5) == pytest.approx(-10 * 1.0e5)
    assert after([math.nan] + [Q0 + 200.0 / 60000.0] * 9, bhp_pa=6.85e7 - 1.0e5) \
        == pytest.approx(-3 * 1.0e5)


def test_on_a_multi_stand_trip_the_ramp_follows_the_floor_and_the_pump_carries_the_connection(cfg):
    """Moving, the ramp goes to the stand's end in the present string's frame and slows
    onto it; while the floor has the string the reference waits at the string, and through
    the connection's pump ramps the back-pressure pump runs."""
    def floor(phase, pulled):
        return FloorCommand(TripStep(phase, 2, phase != MOVING, True, 1.0, 56.0, pulled),
                            math.nan, None, None)
    tick = BaselineTick(cfg, 0.5, StartInputs(Q0, 2.0e6, 0.0, 1.0e7, True), trip=TripProgramme(
        direction="out", stands=3))
    sp = SimpleNamespace(block_position_target_m=math.nan, bhp_ref_pa=6.85e7,
                         controller_enabled=True, mud_pump_on=True)
    refs = []
    for _ in range(80):
        cmd, _ = tick.step(refs[-1] if refs else 0.0, 6.85e7, sp, True, math.nan,
                           floor=floor(MOVING, 1))
        refs.append(cmd.block_position_ref_m)
        assert cmd.bpp_flow_m3s == 0.0
    assert refs[-1] == pytest.approx(28.0)                    # 56 m bit height, a stand pulled
    assert max(np.diff(refs)) == pytest.approx(0.5) and np.diff(refs)[-3] < 0.5  # slowing
    cmd, _ = tick.step(27.6, 6.85e7, sp, True, math.nan, floor=floor(SET_SLIPS, 1))
    assert cmd.block_position_ref_m == pytest.approx(27.6)   # waits at the string
    cmd, _ = tick.step(27.6, 6.85e7, sp, True, math.nan, floor=floor(CONNECTION, 1))
    assert cmd.bpp_flow_m3s == CONNECTION_BPP_FLOW_M3S


def test_the_tick_reads_a_frozen_bhp_gauge_as_a_dropout_and_holds_the_choke(cfg):
    """A BHP sample repeating at the next sample is a frozen gauge (a live one's noise never
    repeats a float): the PI holds its choke reference as without a reading, instead of
    winding up on a value that no longer moves."""
    tick = BaselineTick(cfg, 0.5, StartInputs(Q0, 2.0e6, 0.0, 1.0e7, True))
    sp = SimpleNamespace(block_position_target_m=0.0, bhp_ref_pa=6.85e7,
                         controller_enabled=True, mud_pump_on=True)
    cmd, ok = tick.step(0.01, 6.95e7, sp, True, math.nan, 0.01)
    assert ok and cmd.choke_flow_ref_m3s > Q0                 # 1 bar high: opens
    held = cmd.choke_flow_ref_m3s
    cmd, ok = tick.step(0.02, 6.95e7, sp, True, math.nan, 0.0101)    # the same BHP: frozen
    assert not ok and cmd.choke_flow_ref_m3s == held
    cmd, ok = tick.step(0.03, 6.951e7, sp, True, math.nan, 0.0102)   # it moves again
    assert ok and cmd.choke_flow_ref_m3s > held
