"""The choke (drill_plant.actuators.Choke): in manual mode the valve goes to the commanded
opening through its lag, the PI flow controller is bypassed, and back in automatic the
velocity-form PI continues from the opening it was left at; the flow controller holds the
measured return flow (a plugged choke included) and falls back on the valve law when
that sample is bad."""
from __future__ import annotations

import math

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_plant.actuators import Choke

CONFIG_DIR = config_dir()
STEP_S, STEPS = 0.01, 10
DP_PA = 5.0e5


@pytest.fixture(scope="module")
def setup(cfg, wm):
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
        clean.frame(flow_ref, DP_PA, STEP_S, STEPS)
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


def _plugged_loop(choke: Choke, wm, flow_ref_m3s: float, meter: bool, frames: int = 300):
    """The flow loop on a choke whose valve passes half of the clean law's flow (a plugged
    choke, constant dp); with ``meter`` it reads that flow from the return-flow meter."""
    true_flow = math.nan
    for _ in range(frames):
        true_flow = 0.5 * float(hy.choke_flow(wm, choke.lag.value, DP_PA))
        choke.frame(flow_ref_m3s, DP_PA, STEP_S, STEPS,
                    return_flow_m3s=true_flow if meter else math.nan)
    return true_flow


def test_on_the_return_flow_meter_a_plugged_choke_passes_its_reference(setup):
    actuators, wm = setup
    flow_ref = float(hy.choke_flow(wm, 0.3, DP_PA))
    metered, deceived = Choke(actuators, wm, 0.3), Choke(actuators, wm, 0.3)
    assert _plugged_loop(metered, wm, flow_ref, True) == pytest.approx(flow_ref, rel=1e-3)
    assert metered.lag.value == pytest.approx(0.6, rel=1e-2) and metered.valve_law_frames == 0
    # on the clean valve law the loop believes the reference is met at half of it
    assert _plugged_loop(deceived, wm, flow_ref, False) == pytest.approx(0.5 * flow_ref, rel=1e-3)
    assert deceived.valve_law_frames == 300


def test_a_bad_return_flow_sample_falls_back_on_the_valve_law_and_is_counted(setup):
    actuators, wm = setup
    choke = Choke(actuators, wm, 0.3)
    law = float(hy.choke_flow(wm, 0.3, DP_PA))
    rng = np.random.default_rng(3)
    for value in (law * (1.0 + 1e-3 * rng.normal()) for _ in range(10)):   # a live meter
        assert choke.measured_flow(value, DP_PA) == value
    assert choke.measured_flow(math.nan, DP_PA) == pytest.approx(law)
    assert choke.measured_flow(math.inf, DP_PA) == pytest.approx(law)
    assert choke.valve_law_frames == 2
    frozen = law * 1.2
    seen = [choke.measured_flow(frozen, DP_PA) for _ in range(7)]
    limit = actuators.choke_flow_frozen_after_samples
    assert seen[:limit - 1] == [frozen] * (limit - 1)            # not yet known frozen
    assert seen[limit - 1:] == [pytest.approx(law)] * (8 - limit)  # the same sample again: law
    assert choke.valve_law_frames == 2 + 8 - limit
    assert choke.measured_flow(law, DP_PA) == law                # moving again: the meter
