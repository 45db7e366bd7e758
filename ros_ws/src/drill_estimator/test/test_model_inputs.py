"""The UKF's model inputs from actuator frames (drill_estimator.model_inputs)."""
from types import SimpleNamespace

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.backend import NUMPY
from drill_core.config import load_rig
from drill_core.estimation_model import build_estimation_model, drift
from drill_core.rig_root import config_dir
from drill_estimator.initial_state import initial_state
from drill_estimator.model_inputs import ModelInputs

CONFIG_DIR = config_dir()
CIRCULATION = 1000.0 / 60000.0      # 1000 L/min


@pytest.fixture(scope="module")
def em():
    return build_estimation_model(load_rig(CONFIG_DIR))


FROZEN_AFTER = 5


def _frame(samples, reference=0.0):
    return SimpleNamespace(output=list(samples), reference=reference)


def _started(em, block_input="block_position"):
    y = [0.0, 20.0e5, 6.6e7, CIRCULATION]
    x0 = initial_state(em, 1.0, y, True, np.zeros((em.size, em.size)), 1.0e10)   # known parameters
    inputs = ModelInputs(em, block_input, FROZEN_AFTER)
    inputs.start(x0, y[1])
    return inputs, x0


def test_steady_inputs_hold_the_initial_state(em):
    """With the held inputs the model's string flow and pressure do not move (the pump
    pressure balances the string column and friction; the choke opening passes the flow)."""
    inputs, x0 = _started(em)
    u, problems = inputs.frame({}, 10)
    assert problems == [] and u.shape == (4, 10)
    assert u[1, 0] == pytest.approx(CIRCULATION, rel=1e-9)        # valve law at the held opening
    rate = drift(NUMPY, em, x0, [u[0, 0] - em.wm.geometry.static_stretch_m, *u[1:, 0]])
    assert abs(rate[em.string_flow]) < 1e-9
    assert abs(rate[em.string_pressure]) < 1.0                      # Pa/s, of 1e7 Pa


def test_bad_frame_holds_its_actuator_only_and_says_so(em):
    inputs, _ = _started(em)
    good = {"drawworks": _frame([1.0, 2.0]), "choke": _frame([0.3] * 3),
            "bpp": _frame([0.004] * 3), "mud_pump": _frame([2.0e7] * 3)}
    u, problems = inputs.frame(good, 3)
    assert problems == []
    assert list(u[0]) == [1.0, 2.0, 2.0]                  # a short frame holds its last sample
    bad = dict(good, choke=_frame([0.5, float("nan"), 0.5]))
    u, problems = inputs.frame(bad, 3)
    assert problems == ["choke: bad frame (3 samples); holding input"]
    expected = hy.choke_flow(em.wm, 0.3, inputs.choke_dp_pa)
    assert np.allclose(u[1], expected) and np.all(np.isfinite(u))
    assert list(u[2]) == [0.004] * 3 and list(u[3]) == [2.0e7] * 3


def test_reference_mode_takes_the_drawworks_reference(em):
    inputs, _ = _started(em, "reference")
    u, _ = inputs.frame({"drawworks": _frame([5.0, 5.0], reference=7.5)}, 4)
    assert list(u[0]) == [7.5] * 4
    with pytest.raises(ValueError, match="block_input"):
        ModelInputs(em, "hook_load", FROZEN_AFTER)


def test_choke_flow_is_the_return_flow_sample_and_the_valve_law_only_while_it_is_bad(em):
    """A plugging choke passes less than the valve law says: the meter's sample is the
    model's choke flow; a NaN, inf or frozen sample falls back to the valve law, counted."""
    inputs, _ = _started(em)
    choke = {"choke": _frame([0.3] * 3)}
    valve_law = hy.choke_flow(em.wm, 0.3, inputs.choke_dp_pa)
    inputs.observe_return_flow(0.1, 0.5 * valve_law, True)
    u, _ = inputs.frame(choke, 3)
    assert np.allclose(u[1], 0.5 * valve_law) and inputs.valve_law_frames == 0
    for time_s, bad in ((0.2, float("nan")), (0.3, float("inf"))):
        inputs.observe_return_flow(time_s, bad, True)
        u, _ = inputs.frame(choke, 3)
        assert np.allclose(u[1], valve_law)
    assert inputs.valve_law_frames == 2
    for k in range(FROZEN_AFTER):                 # the same float FROZEN_AFTER times: frozen
        inputs.observe_return_flow(0.4 + 0.1 * k, 0.01, True)
    u, _ = inputs.frame(choke, 3)
    assert np.allclose(u[1], valve_law) and inputs.valve_law_frames == 3
    inputs.observe_return_flow(1.0, 0.02, True)   # it moves again: back on the meter
    u, _ = inputs.frame(choke, 3)
    assert np.allclose(u[1], 0.02)
    inputs.observe_return_flow(1.1, 0.03, False)  # not trusted (a tripped pump): the valve law
    u, _ = inputs.frame(choke, 3)
    assert np.allclose(u[1], valve_law)


def test_the_valve_law_calibrated_on_the_meter_stands_in_through_a_planned_stop(em):
    """A choke 10 % tighter than its data sheet: over the frames the meter is the input its
    flow over the law's goes into the calibration (each frame with its weight); without
    circulation the law stands in, times that calibration only where asked (a connection's
    planned pump stop), as is after a trip."""
    y = [0.0, 20.0e5, 6.6e7, CIRCULATION]
    x0 = initial_state(em, 1.0, y, True, np.zeros((em.size, em.size)), 1.0e10)
    inputs = ModelInputs(em, "block_position", FROZEN_AFTER, calibration_gain=0.5)
    inputs.start(x0, y[1])
    choke = {"choke": _frame([0.3] * 3)}
    law = float(hy.choke_flow(em.wm, 0.3, inputs.choke_dp_pa))
    for k in range(3):
        inputs.observe_return_flow(0.1 * k, 0.9 * law * (1.0 + 1e-6 * k), True)   # not frozen
        inputs.frame(choke, 3)
    assert inputs.valve_law_factor == pytest.approx(1.0 - 0.1 * (1.0 - 0.5 ** 3), rel=1e-5)
    inputs.observe_return_flow(0.3, 0.9 * law, False)
    calibrated, _ = inputs.frame(choke, 3, calibrated=True)
    plain, _ = inputs.frame(choke, 3)
    assert np.allclose(calibrated[1], inputs.valve_law_factor * law)
    assert np.allclose(plain[1], law) and inputs.valve_law_frames == 2
