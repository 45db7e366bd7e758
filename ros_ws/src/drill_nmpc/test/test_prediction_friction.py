"""The NMPC's annular friction law follows the mud pump it plans: the yield jump smoothed
over prediction_friction_smoothing_mps with the pump on, over the wider
pump_off_friction_smoothing_mps with it off (drill_nmpc.prediction_model)."""
import casadi as ca
import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.estimation_model import NominalFriction, build_estimation_model
from drill_core.rig_root import config_dir
from drill_core.scenario import Initial
from drill_nmpc.bench import steady_estimate
from drill_nmpc.prediction_model import (ActuatorLags, PredictionModel, PumpSwitchedFriction,
                                         nmpc_estimation_model)

LPM = 1.0 / 60000.0


@pytest.fixture(scope="module")
def config():
    return load_rig(config_dir())


def _slow_circulation(model: PredictionModel, em):
    """(x, u, par) of the prediction at 30 L/min circulating, 20 bar at the choke: where
    the two friction laws differ."""
    x_em, u = steady_estimate(em, Initial(circulation_m3s=30.0 * LPM, choke_dp_pa=2.0e6,
                                          bpp_flow_m3s=0.0))
    return model.initial_state(x_em, u), u, x_em[model.nd_model:]


def _single_law_model(config, smoothing_mps: float) -> PredictionModel:
    """The prediction model built with one law only, as before the switch existed."""
    em = build_estimation_model(config, smoothing_mps=smoothing_mps)
    return PredictionModel(em, ActuatorLags.from_config(config))


def test_a_number_selects_one_law_and_the_laws_differ_only_near_zero_flow(config):
    em = nmpc_estimation_model(config, "NMPC1")
    switched = em.nominal_friction
    assert isinstance(switched, PumpSwitchedFriction)
    on = NominalFriction(em.wm, config.nmpc.prediction_friction_smoothing_mps)
    assert switched.circulating.smoothing_mps == on.smoothing_mps == 0.01
    assert switched.pump_off.smoothing_mps == config.nmpc.pump_off_friction_smoothing_mps == 0.02
    flows = np.array([-300.0, -20.0, 0.0, 5.0, 20.0, 1000.0]) * LPM
    for k in range(3):
        assert switched.at(1.0).loss(np, k, flows, 0.0) == pytest.approx(on.loss(np, k, flows, 0.0))
        off = switched.at(0.0).loss(np, k, flows, 0.0)
        assert off == pytest.approx(switched.pump_off.loss(np, k, flows, 0.0))
        both = switched.at(1.0).loss(np, k, flows, 0.0)
        assert abs(both[2]) < 1.0 and abs(off[2]) < 1.0              # no friction without flow
        assert both[-1] == pytest.approx(off[-1], rel=1e-6)           # circulating: the same
        assert abs(both[3]) > 1.3 * abs(off[3])                       # near zero: sharper on


def test_the_prediction_step_takes_each_law_with_its_pump_state(config):
    """F(x, u, par, pump_on) of the switched model equals F of a model built with the
    law alone, pump on and pump off (the step's own code, not the law's table), at a
    slow circulation where the two laws differ."""
    em = nmpc_estimation_model(config, "NMPC1")
    switched = PredictionModel(em, ActuatorLags.from_config(config))
    step_s, substeps = config.nmpc.sample_time_s, config.nmpc.substeps
    F = switched.function(step_s, substeps, "rk4")
    x, u, par = _slow_circulation(switched, em)
    alone = {}
    for pump_on, smoothing in ((1.0, config.nmpc.prediction_friction_smoothing_mps),
                               (0.0, config.nmpc.pump_off_friction_smoothing_mps)):
        alone[pump_on] = _single_law_model(config, smoothing).function(step_s, substeps, "rk4")
        expected = np.asarray(alone[pump_on](x, u, par, pump_on)).ravel()
        assert np.asarray(F(x, u, par, pump_on)).ravel() == pytest.approx(expected, rel=1e-9,
                                                                          abs=1e-9)
    sharp, wide = (np.asarray(alone[law](x, u, par, 1.0)).ravel() for law in (1.0, 0.0))
    assert abs(sharp[em.pressure(em.n)] - wide[em.pressure(em.n)]) > 1.0e3    # Pa


def test_a_step_built_for_one_pump_state_is_the_switched_step_at_that_state(config):
    """F built with one pump state's friction law (what the supervisor solves with, one
    problem per pump state) equals the switched F at that state bit for bit, and its
    pump_on parameter still switches the pump: off, the stand-pipe pressure winds down."""
    em = nmpc_estimation_model(config, "NMPC1")
    model = PredictionModel(em, ActuatorLags.from_config(config))
    step_s, substeps = config.nmpc.sample_time_s, config.nmpc.substeps
    switched = model.function(step_s, substeps, "rk4")
    x, u, par = _slow_circulation(model, em)
    for pump_on in (1.0, 0.0):
        fixed = model.function(step_s, substeps, "rk4", friction_pump_on=pump_on)
        assert np.array_equal(np.asarray(fixed(x, u, par, pump_on)),
                              np.asarray(switched(x, u, par, pump_on)))
    on_law = model.function(step_s, substeps, "rk4", friction_pump_on=1.0)
    running, stopping = (np.asarray(on_law(x, u, par, on)).ravel()[model.pump] for on in (1.0, 0.0))
    assert stopping < running


def test_the_supervisor_solves_each_pump_state_with_its_own_problem(config):
    from drill_nmpc.supervisor import Supervisor
    em = nmpc_estimation_model(config, "NMPC1")
    sup = Supervisor(config, em)
    on, off = sup.problem_for(True), sup.problem_for(False)
    assert on is not off
    assert (on.friction_pump_on, off.friction_pump_on) == (1.0, 0.0)


def test_the_stiffness_cap_reads_the_law_in_force(config):
    switched = nmpc_estimation_model(config, "NMPC1").nominal_friction
    for k in range(3):
        on = switched.at(1.0).peak_gain_near(k, 0.0, 1.0e-3)
        off = switched.at(0.0).peak_gain_near(k, 0.0, 1.0e-3)
        assert on == pytest.approx(2.0 * off, rel=0.05)               # 1/smoothing
        symbolic = switched.at(ca.SX.sym("pump_on"))
        assert symbolic.peak_gain_near(k, 0.0, 1.0e-3) == on
