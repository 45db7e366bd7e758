"""The choke's manual mode (drill_plant.actuators.Choke): the valve goes to the commanded
opening through its lag, the PI flow controller is bypassed, and back in automatic the
velocity-form PI continues from the opening it was left at."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_plant.actuators import Choke

CONFIG_DIR = Path(__file__).resolve().parents[4] / "config"
STEP_S, STEPS = 0.01, 10
DP_PA = 5.0e5


@pytest.fixture(scope="module")
def setup():
    cfg = load_rig(CONFIG_DIR)
    wm = hy.build_well_model(cfg.well, cfg.plant.yield_regularisation_velocity_mps,
                             cfg.plant.choke_regularisation_pa)
    return cfg.actuators, wm


def test_manual_opening_through_the_valve_lag(setup):
    actuators, wm = setup
    choke = Choke(actuators, wm, 0.0)
    first = choke.frame(0.05, DP_PA, STEP_S, STEPS, manual_opening=0.5)
    assert first.command == 0.5 and math.isnan(first.reference)
    # 0.1 s of the 2 s lag from a closed valve: the first sample is still the start value
    assert first.output[0] == 0.0 and 0.0 < first.output[-1] < 0.5
    for _ in range(200):                                          # 20 s = 10 time constants
        out = choke.frame(0.05, DP_PA, STEP_S, STEPS, manual_opening=0.5)
    assert out.output[-1] == pytest.approx(0.5, abs=1e-3)


def test_manual_opening_limited_to_the_valve_range(setup):
    actuators, wm = setup
    out = Choke(actuators, wm, 0.3).frame(0.0, DP_PA, STEP_S, STEPS, manual_opening=1.7)
    assert out.command == actuators.choke.maximum


def test_back_to_automatic_is_bumpless(setup):
    actuators, wm = setup
    choke = Choke(actuators, wm, 0.5)
    choke.frame(0.0, DP_PA, STEP_S, STEPS, manual_opening=0.5)
    flow = float(hy.choke_flow(wm, choke.lag.value, DP_PA))
    # reference = the flow at the held opening: the PI leaves the opening where it is
    assert choke.frame(flow, DP_PA, STEP_S, STEPS).command == pytest.approx(0.5)
    # a reference one flow scale higher (normalised error 1) moves it by the integral term
    # only on the first automatic frame: no proportional kick from the manual period
    choke = Choke(actuators, wm, 0.5)
    choke.frame(0.0, DP_PA, STEP_S, STEPS, manual_opening=0.5)
    step = actuators.choke_kp * STEP_S * STEPS / actuators.choke_ti_s
    out = choke.frame(flow + actuators.choke_flow_scale_m3s, DP_PA, STEP_S, STEPS)
    assert out.command == pytest.approx(0.5 + step)
    assert np.isfinite(out.reference)


def test_one_nan_sample_holds_the_choke_and_does_not_poison_its_controller(setup):
    config, wm = setup
    clean, hit = Choke(config, wm, 0.4), Choke(config, wm, 0.4)
    flow_ref = float(hy.choke_flow(wm, 0.45, DP_PA))
    for k in range(30):
        a = clean.frame(flow_ref, DP_PA, STEP_S, STEPS)
        b = hit.frame(flow_ref, math.nan if k == 10 else DP_PA, STEP_S, STEPS)
        assert np.all(np.isfinite(b.output))
        if k == 10:
            assert b.command == hit.opening_command            # held through the bad sample
    assert math.isfinite(hit.opening_command)
    assert abs(hit.opening_command - clean.opening_command) < 0.05   # and back on track


def test_one_nan_position_holds_the_drawworks_and_keeps_its_integral_finite():
    from drill_plant.actuators import Drawworks
    config = load_rig(CONFIG_DIR).actuators
    dw = Drawworks(config, 1.7, 1.7)
    for k in range(20):
        out = dw.frame(5.0, math.nan if k == 3 else 0.1 * k, STEP_S, STEPS)
        assert np.all(np.isfinite(out.output)) and math.isfinite(dw.integral_m_s)
