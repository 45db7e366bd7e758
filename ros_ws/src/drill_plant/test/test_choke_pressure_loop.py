"""The choke's pressure mode (drill_plant.actuators.Choke.pressure_frame) on the truth
plant: it takes the choke dp to its set-point and follows a ramp, it enters from the
opening in force without a kick, and a bad sample leaves its state as it was."""
from __future__ import annotations

import math

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_plant.actuators import Choke
from drill_plant.plant_model import steady_state
from drill_plant.simulator import PlantSimulator

CONFIG_DIR = config_dir()
FLOW = 1000.0 / 60000.0


@pytest.fixture(scope="module")
def config():
    return load_rig(CONFIG_DIR)


def _closed_loop(config, setpoints, seconds: float, seed: int = 3):
    """Plant with the pumps held and the choke in pressure mode; the measured choke dp per
    frame and the set-point in force."""
    wm = hy.rig_well_model(config)
    op = steady_state(wm, FLOW, 2.0e6, 0.0)
    sim = PlantSimulator(config, op, seed)
    choke = Choke(config.actuators, sim.wm, float(op.inputs[1]))
    step, n = config.plant.step_s, config.plant.steps_per_frame
    dps, refs = [], []
    for k in range(int(round(seconds / config.plant.sensor_period_s))):
        t = k * config.plant.sensor_period_s
        m = sim.measure(True)
        dp_ref, rate, since = setpoints(t)
        out = choke.pressure_frame(dp_ref, rate, since, FLOW, m.choke_dp_pa, step, n)
        rows = np.vstack([np.full(n, op.inputs[0]), out.output, np.zeros(n),
                          np.full(n, op.inputs[3])])
        sim.advance(rows)
        dps.append(m.choke_dp_pa)
        refs.append(out.reference)
    return np.array(dps), np.array(refs), choke


def test_pressure_mode_takes_the_choke_dp_to_a_new_set_point(config):
    dps, refs, _ = _closed_loop(config, lambda t: (2.0e6 if t < 5.0 else 2.5e6, 0.0, 0.0), 40.0)
    assert np.all(refs[50:] == 2.5e6)
    settled = dps[-100:]                                   # last 10 s, sensor noise 0.25 bar
    assert abs(np.mean(settled) - 2.5e6) < 0.1e5
    # the shipped gains overshoot a 5 bar step by ~1.7 bar; the sensor adds up to ~0.8 bar
    assert np.max(dps) < 2.5e6 + 3.0e5


def test_pressure_mode_follows_a_ramping_set_point(config):
    # 0.5 bar/s for 10 s from t = 5 s, each 1 s command ramping from its own stamp
    def ramp(t):
        start = min(max(math.floor(t) - 5.0, 0.0), 10.0)
        rate = 0.5e5 if 5.0 <= t < 15.0 else 0.0
        return 2.0e6 + 0.5e5 * start, rate, t - math.floor(t)
    dps, refs, _ = _closed_loop(config, ramp, 30.0)
    assert refs[149] == pytest.approx(2.0e6 + 0.5e5 * 9.9, rel=1e-9)
    lag = np.mean(refs[100:150] - dps[100:150])            # during the ramp's second half
    assert 0.0 < lag < 1.0e5                                # within a bar of the moving target
    assert abs(np.mean(dps[-50:]) - 2.5e6) < 0.15e5


def test_pressure_mode_entry_is_bumpless_and_a_bad_sample_changes_nothing(config):
    _, _, choke = _closed_loop(config, lambda t: (2.0e6, 0.0, 0.0), 5.0)
    opening, integral = choke.opening_command, choke.pressure_integral
    out = choke.pressure_frame(2.0e6, 0.0, 0.0, FLOW, math.nan, 0.01, 10)
    assert out.command == opening and choke.pressure_integral == integral
    out = choke.pressure_frame(math.inf, 0.0, 0.0, FLOW, 2.0e6, 0.01, 10)
    assert out.command == opening and choke.pressure_integral == integral
    # from the flow loop: the first pressure frame at zero error keeps the opening
    fresh = Choke(config.actuators, choke.wm, 0.3)
    flow = float(hy.choke_flow(choke.wm, 0.3, 2.0e6))
    assert fresh.pressure_frame(2.0e6, 0.0, 0.0, flow, 2.0e6, 0.01, 10).command == pytest.approx(0.3)


def test_a_frozen_choke_dp_gauge_holds_the_pressure_loop_as_a_dropout_does(config):
    """The same choke-dp sample frame after frame (a frozen gauge) reads as a NaN from the
    count on (drill_plant.actuators.Choke.gauges): the loop holds its opening instead of
    integrating against a gauge that no longer moves; a moving gauge is read again."""
    _, _, choke = _closed_loop(config, lambda t: (2.0e6, 0.0, 0.0), 5.0)
    n = config.actuators.choke_gauges_frozen_after_samples
    for k in range(n - 1):
        dp, bhp = choke.gauges(2.6e6, 6.85e7 + k)
        assert dp == 2.6e6 and bhp == 6.85e7 + k
    dp, bhp = choke.gauges(2.6e6, 6.9e7)
    assert math.isnan(dp) and bhp == 6.9e7
    opening, integral = choke.opening_command, choke.pressure_integral
    out = choke.pressure_frame(2.0e6, 0.0, 0.0, FLOW, dp, 0.01, 10)
    assert out.command == opening and choke.pressure_integral == integral
    assert choke.gauges(2.61e6, 6.9e7 + 1.0)[0] == 2.61e6
