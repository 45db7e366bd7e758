"""The emergency stop at the machines (drill_plant.actuators) on the truth plant: the
drawworks brake takes the block to rest at its deceleration limit (v / a of time,
v^2 / 2a of travel) and holds it; the string rides the stop out within 0.3 m of where it
was; the choke's BHP loop holds the BHP against a trip's swab and, after the stop, the BHP
measured then, the BHP gauge out or not; the release hands the block back to its
controller without a jump."""
from __future__ import annotations

import math

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_plant.actuators import Choke, Drawworks, FirstOrderLag
from drill_plant.plant_model import steady_state
from drill_plant.simulator import PlantSimulator

CONFIG_DIR = config_dir()
FLOW = 1000.0 / 60000.0
STOP_S = 40.0            # pulled out from 0 s, stopped here
SPEED_MPS = 0.3          # the pull-out's speed
BPP = 240.0 / 60000.0    # back-pressure pump flow [m^3/s]


@pytest.fixture(scope="module")
def config():
    return load_rig(CONFIG_DIR)


def test_the_brake_decelerates_at_its_limit_and_holds(config):
    lag = FirstOrderLag(config.actuators.drawworks, 0.0)
    decel = config.actuators.brake_deceleration_mps2
    for _ in range(200):                                    # 20 s toward 30 m: the 0.6 m/s limit
        lag.advance(30.0, 0.01, 10)
    speed, start = lag.rate_per_s, lag.value
    assert speed == pytest.approx(config.actuators.drawworks.rate_limit_per_s)
    out = np.concatenate([lag.decelerate(decel, 0.01, 10) for _ in range(20)] + [[lag.value]])
    rates = np.diff(out) / 0.01
    assert np.all(np.diff(rates) >= -decel * 0.01 - 1e-9)   # never harder than the limit
    at_rest = int(np.argmax(rates == 0.0))
    assert at_rest * 0.01 == pytest.approx(speed / decel, abs=0.011)            # v / a
    assert out[-1] - start == pytest.approx(speed ** 2 / (2 * decel), abs=0.01)  # v^2 / 2a
    assert np.all(out[at_rest:] == out[-1]) and lag.rate_per_s == 0.0


def _pull_out_and_stop(config, bhp_gauge_out: bool = False, seconds: float = 110.0):
    """The plant pulled out (the block reference at 0.1 m/s^2 to 0.3 m/s) with the choke
    holding the starting BHP against the swab on its BHP loop and the back-pressure pump
    giving it 240 L/min (a managed-pressure trip), the brake set at STOP_S and the choke
    from then on holding the BHP measured at the stop (the BHP gauge out from then on if
    asked); per 0.1 s frame: time, true string position, block, true BHP, true choke dp;
    the BHP measured at the stop, the BHP at the start and the drawworks."""
    wm = hy.rig_well_model(config)
    op = steady_state(wm, FLOW, 2.0e6, BPP)
    sim = PlantSimulator(config, op, 5)
    a, step, n = config.actuators, config.plant.step_s, config.plant.steps_per_frame
    drawworks = Drawworks(a, wm.geometry.static_stretch_m, float(op.inputs[0]))
    choke = Choke(a, sim.wm, float(op.inputs[1]))
    lay = sim.layout
    rows, stop_bhp, start_bhp = [], math.nan, float(sim.state[lay.pressure(wm.n)])
    reference, speed = 0.0, 0.0
    for k in range(int(round(seconds / config.plant.sensor_period_s))):
        t = k * config.plant.sensor_period_s
        m = sim.measure(True)
        stopped = t >= STOP_S - 1e-9
        if stopped and math.isnan(stop_bhp):
            stop_bhp = m.bhp_pa
            choke.pressure_mode = ""           # the stop: a new BHP target, entered afresh
        speed = min(SPEED_MPS, speed + 0.1 * config.plant.sensor_period_s)
        reference += speed * config.plant.sensor_period_s
        gauge = math.nan if stopped and bhp_gauge_out else m.bhp_pa
        block = drawworks.brake(step, n) if stopped else \
            drawworks.frame(reference, m.block_position_m, step, n)
        valve = choke.bhp_frame(stop_bhp if stopped else start_bhp, gauge, math.nan,
                                FLOW + BPP, m.choke_dp_pa, step, n)
        sim.advance(np.vstack([block.output, valve.output, np.full(n, BPP),
                               np.full(n, op.inputs[3])]))
        rows.append((t + config.plant.sensor_period_s, sim.state[lay.position],
                     drawworks.lag.value, sim.state[lay.pressure(wm.n)],
                     sim.state[lay.pressure(1)] - config.well.choke_downstream_pressure_pa))
    return np.array(rows), stop_bhp, start_bhp, drawworks


@pytest.fixture(scope="module")
def stop(config):
    return _pull_out_and_stop(config)


def test_the_bhp_loop_holds_the_bhp_against_the_swab(stop):
    rows, _, start_bhp, _ = stop
    t, _, _, bhp, _ = rows.T
    pulling = (t > 20.0) & (t < STOP_S)             # at 0.3 m/s from 3 s on
    assert np.abs(bhp[pulling] - start_bhp).max() < 2.0e5


def test_a_stop_brakes_the_block_and_the_string_stays_where_it_stopped(config, stop):
    rows, _, _, _ = stop
    t, string, block, _, _ = rows.T
    a = config.actuators
    speed = np.diff(block) / np.diff(t)
    pressed = np.searchsorted(t, STOP_S)
    assert speed[pressed - 2] == pytest.approx(SPEED_MPS, rel=0.05)
    brake_s = SPEED_MPS / a.brake_deceleration_mps2
    rest = t[1:][(speed == 0.0) & (t[1:] > STOP_S)].min()
    assert rest - STOP_S <= brake_s + 0.1 + 1e-9                     # at rest within the brake
    assert np.all(block[t >= rest] == block[-1])                     # and held there
    travel = block[-1] - block[pressed]
    assert travel <= SPEED_MPS ** 2 / (2 * a.brake_deceleration_mps2) + 0.1 * SPEED_MPS + 1e-9
    # the string (hanging from the block on its elastic stretch) rides the stop out within
    # 0.3 m of where it was at the stop, settles as far as the block went, and stays
    after = t >= STOP_S
    assert np.abs(string[after] - string[pressed]).max() < 0.3
    assert abs(string[-1] - string[pressed] - travel) < 0.05
    assert np.ptp(string[t > t[-1] - 30.0]) < 0.01


def test_after_a_stop_the_choke_holds_the_bhp_of_the_stop(stop):
    """The swab goes with the string faster than the choke (its 2 s lag) and the pressure
    wave from it (about 2 s to the bottom) can answer, and the string rings on its
    stretch: a transient of several bar, then the BHP of the stop."""
    rows, stop_bhp, _, _ = stop
    t, _, _, bhp, _ = rows.T
    held = (t >= STOP_S) & (t <= STOP_S + 60.0)
    assert np.abs(bhp[held] - stop_bhp).max() < 8.0e5                 # the transient
    assert np.abs(bhp[held & (t >= STOP_S + 20.0)] - stop_bhp).max() < 2.0e5
    assert abs(np.mean(bhp[t > STOP_S + 40.0]) - stop_bhp) < 1.0e5    # and settled on it


def test_with_the_bhp_gauge_out_the_choke_dp_of_the_stop_is_held(config):
    rows, _, _, _ = _pull_out_and_stop(config, bhp_gauge_out=True, seconds=STOP_S + 40.0)
    t, _, _, _, dp = rows.T
    at_stop = dp[np.searchsorted(t, STOP_S) - 1]
    late = dp[t > STOP_S + 10.0]           # the string's ringing and the sensor's noise on it
    assert abs(np.mean(late) - at_stop) < 0.5e5 and np.abs(late - at_stop).max() < 2.5e5


def test_the_release_hands_the_block_back_without_a_jump(config):
    _, _, _, drawworks = _pull_out_and_stop(config, seconds=STOP_S + 5.0)
    held = drawworks.lag.value
    step, n = config.plant.step_s, config.plant.steps_per_frame
    out = drawworks.frame(held - 3.0, held - 2.0, step, n)   # a reference and string elsewhere
    assert out.command == pytest.approx(held, abs=1e-12) and out.output[-1] == pytest.approx(held)
    assert not drawworks.off_loop


def test_a_bad_sample_at_the_release_holds_the_block_and_the_next_one_hands_back(config):
    _, _, _, drawworks = _pull_out_and_stop(config, seconds=STOP_S + 5.0)
    held = drawworks.lag.value
    step, n = config.plant.step_s, config.plant.steps_per_frame
    out = drawworks.frame(math.nan, held - 2.0, step, n)           # no reference yet: held
    assert out.output[-1] == pytest.approx(held) and drawworks.off_loop
    out = drawworks.frame(held - 3.0, held - 2.0, step, n)         # then bumpless
    assert out.command == pytest.approx(held, abs=1e-12) and not drawworks.off_loop


def test_the_bhp_loop_enters_bumpless_and_a_bad_sample_changes_nothing(config):
    wm = hy.rig_well_model(config)
    choke = Choke(config.actuators, wm, 0.3)
    flow = float(hy.choke_flow(wm, 0.3, 2.0e6))
    out = choke.bhp_frame(6.85e7, 6.85e7, math.nan, flow, 2.0e6, 0.01, 10)   # on target
    assert out.command == pytest.approx(0.3) and out.reference == pytest.approx(2.0e6)
    integral, setpoint = choke.pressure_integral, choke.bhp_dp_setpoint_pa
    out = choke.bhp_frame(6.85e7, math.nan, math.nan, flow, 2.0e6, 0.01, 10)  # BHP gauge out
    assert choke.bhp_dp_setpoint_pa == setpoint                       # the set-point stands
    out = choke.bhp_frame(6.85e7, 6.80e7, math.nan, flow, math.nan, 0.01, 10)   # no choke dp
    assert out.command == pytest.approx(0.3) and choke.pressure_integral == integral


def test_the_bhp_loop_takes_the_valve_where_it_is_not_where_it_was_going(config):
    """A choke closing on its flow loop when the stop comes: the BHP loop starts from the
    valve's opening at that moment (the valve stops there), not from the flow loop's last
    command, which the valve's lag would have gone on closing to."""
    wm = hy.rig_well_model(config)
    choke = Choke(config.actuators, wm, 0.3)
    flow = float(hy.choke_flow(wm, 0.3, 2.0e6))
    choke.frame(0.5 * flow, 2.0e6, 0.01, 10, return_flow_m3s=flow)    # closing
    moving_to, at = choke.opening_command, choke.lag.value
    assert moving_to < at - 1e-3
    out = choke.bhp_frame(6.85e7, 6.85e7, math.nan, flow, 2.0e6, 0.01, 10)   # on target
    assert out.command == pytest.approx(at, abs=1e-9)
