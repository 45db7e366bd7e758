"""The actuator watch: an output that does not move while its reference does is caught from
the actuator's frames, held for its hold time, and a following or braked one is not; the
drawworks' own lag (drill_plant.actuators.Drawworks) never trips it on a trip's start, nor
the choke's flow loop (drill_plant.actuators.Choke) on a step of its flow reference."""
import math

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import FollowingWatch as Config
from drill_core.config import PumpWatch
from drill_plant.actuators import Choke, Drawworks, Pump
from drill_protection.actuator_watch import ActuatorWatch, PumpDeliveryWatch, StuckValveWatch

DT = 0.1          # one frame [s]
STEPS = 2         # output samples per frame
CONFIG = Config(window_s=1.5, reference_travel=0.02, output_travel=0.001, response_s=0.5,
                hold_s=5.0)


def feed(watch, t, reference, block):
    watch.frame(t, reference, [block] * STEPS)


def test_a_block_that_stays_while_its_reference_runs_on_is_not_following_for_the_hold():
    watch = ActuatorWatch(CONFIG)
    for k in range(30):             # the reference at 0.5 m/s, the block stuck at 5.47 m
        feed(watch, k * DT, 5.0 + 0.5 * k * DT, 5.47)
    assert watch.not_following(3.0)
    for k in range(30, 100):        # it lets go and follows: still held for 5 s after
        feed(watch, k * DT, 6.5, 5.47 + 0.05 * (k - 29))
        if k * DT + DT < 3.0 + CONFIG.hold_s:
            assert watch.not_following(k * DT + DT)
    assert not watch.not_following(10.0)


def test_a_still_reference_or_a_braked_block_is_not_judged():
    watch = ActuatorWatch(CONFIG)
    for k in range(20):             # at rest: neither moves
        feed(watch, k * DT, 3.0, 4.5)
    assert not watch.not_following(2.0)
    for k in range(20, 40):         # the brake set (reference NaN): its own stop
        feed(watch, k * DT, math.nan, 4.5)
    assert not watch.not_following(4.0)


def test_only_frames_stamped_before_the_judgement_count():
    watch = ActuatorWatch(CONFIG)
    for k in range(15):
        feed(watch, k * DT, 3.0, 4.5)
    feed(watch, 1.5, 3.5, 4.5)      # the frame of the judgement's own stamp: not yet
    assert not watch.not_following(1.5)
    assert watch.has(1.5) and not watch.has(1.6)


def test_the_drawworks_lag_starting_a_trip_from_rest_follows(cfg):
    """The reference accelerating at the protection's limit from rest: the block controller
    and the lag move the block within the window, from the first step on."""
    a = cfg.actuators
    drawworks = Drawworks(a, static_stretch_m=1.0, initial_block_m=1.0)
    watch = ActuatorWatch(cfg.protection.drawworks_watch)
    accel, position = cfg.protection.trip_acceleration_max_mps2, 0.0
    for k in range(300):
        t = k * DT
        speed = min(accel * math.floor(t), 0.5)              # stepped once a second
        reference = 0.5 * accel * math.floor(t) ** 2 if speed < 0.5 else 1.25 + 0.5 * (t - 5.0)
        out = drawworks.frame(reference, position, DT / STEPS, STEPS)
        watch.frame(t, out.reference, out.output)
        position = float(out.output[-1]) - 1.0
        assert not watch.not_following(t + DT), f"flagged at {t:.1f} s"
    assert position > 10.0


def test_the_chokes_flow_loop_answering_a_step_is_not_stuck(cfg):
    """A step of the flow reference from 650 L/min to nothing (the pump trip's trap) with
    the return flow standing: the PI loop moves the valve within the window and then holds
    it at the bottom of its range, where it is not judged."""
    wm = hy.rig_well_model(cfg)
    choke = Choke(cfg.actuators, wm, 0.12)
    watch = StuckValveWatch(cfg.protection.choke_watch, cfg.actuators.choke)
    flow = 650.0 / 60000.0
    for k in range(300):
        reference = flow if k < 30 else 0.0
        out = choke.frame(reference, 25.0e5, DT / STEPS, STEPS, return_flow_m3s=flow)
        watch.frame(k * DT, out.reference - flow, out.output)
        assert not watch.not_following(k * DT + DT), f"flagged at {k * DT:.1f} s"
    assert choke.lag.value < cfg.actuators.choke.minimum + cfg.protection.choke_watch.range_margin


def test_a_stuck_valve_with_its_error_standing_is_caught_and_moving_again_is_seen(cfg):
    watch = StuckValveWatch(cfg.protection.choke_watch, cfg.actuators.choke)
    for k in range(20):                     # 650 L/min asked less, the valve at 0.12
        watch.frame(k * DT, -650.0 / 60000.0, [0.12] * STEPS)
    assert watch.not_following(2.0) and not watch.moving(2.0)
    for k in range(20, 40):                 # freed: the loop closes it
        watch.frame(k * DT, -650.0 / 60000.0, [0.12 - 0.002 * (k - 19)] * STEPS)
    assert watch.moving(4.0) and not watch.not_following(4.0)
    for k in range(40, 60):                 # off the flow loop: not judged
        watch.frame(k * DT, math.nan, [0.08] * STEPS)
    assert not watch.not_following(6.0)


def test_a_pump_that_delivers_through_its_lag_is_never_judged_and_a_tripped_one_is(cfg):
    """The back-pressure pump asked from 0 to 600 L/min: through its 30 s lag its measured
    flow (1 L/min of noise) is never 30 L/min short of the lag's answer; a tripped pump
    (nothing measured) is, 1 s after it falls that far short; a NaN sample is not judged."""
    watch_config = PumpWatch(flow_error_m3s=5.0e-4, window_s=1.0)
    lag = cfg.actuators.bpp
    pump, healthy, tripped = Pump(lag, 0.0), PumpDeliveryWatch(watch_config, lag, 0.0), \
        PumpDeliveryWatch(watch_config, lag, 0.0)
    rng = np.random.default_rng(1)
    short_from = None
    for k in range(600):
        t = k * DT
        out = pump.frame(0.01, 0.01, 10).output
        for w in (healthy, tripped):
            w.command(0.01)
        healthy.observe(t, float(out[0]) + 1.7e-5 * rng.normal())
        tripped.observe(t, 0.0 if k != 50 else math.nan)
        assert not healthy.not_delivering
        if tripped.expected_m3s >= 5.0e-4 and short_from is None:
            short_from = t
        if tripped.not_delivering:
            assert t >= short_from + watch_config.window_s - 1e-9
    assert tripped.not_delivering and short_from is not None
