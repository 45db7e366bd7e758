"""The UKF's first state (drill_estimator.initial_state): a steady state of the model that
puts the first BHP reading's departure from the report's profile on the parameters."""

import numpy as np
import pytest

from drill_core.backend import NUMPY
from drill_core.config import load_rig
from drill_core.estimation_model import build_estimation_model, drift
from drill_core.rig_root import config_dir
from drill_estimator.initial_state import initial_state
from drill_estimator.model_inputs import ModelInputs
from drill_estimator.ukf import RigUkf

CONFIG_DIR = config_dir()
CIRCULATION = 1000.0 / 60000.0      # 1000 L/min
CHOKE_DP_PA = 20.0e5


@pytest.fixture(scope="module")
def ukf():
    return RigUkf(load_rig(CONFIG_DIR), jit=False)


def _profile_bhp(ukf, flow):
    """The report's steady BHP at ``flow`` (no departure: every parameter at its prior)."""
    known = np.zeros((ukf.n_x, ukf.n_x))
    x = initial_state(ukf.em, ukf.est.friction_tuning.theta_initial,
                      [0.0, CHOKE_DP_PA, 0.0, flow], flow > 0.0, known, 1.0)
    return x[ukf.em.pressure(ukf.em.n)]


@pytest.mark.parametrize("flow", [CIRCULATION, 0.0])
def test_the_start_is_a_steady_state_of_the_model(ukf, flow):
    """3 bar over the report's profile: every flow and pressure rate of the model is zero
    at the start with the inputs the filter then holds."""
    _assert_steady_start(ukf, flow)


@pytest.mark.parametrize("flow", [CIRCULATION, 0.0])
def test_a_string_ten_stands_short_starts_steady_too(flow):
    """A run-in trip's start (the bit 280 m over the bottom node): the inside of the
    string at the bit carries that much less column."""
    cfg = load_rig(CONFIG_DIR)
    short = RigUkf(cfg, build_estimation_model(cfg, pulled_m=280.0), jit=False)
    _assert_steady_start(short, flow)


def _assert_steady_start(ukf, flow):
    em = ukf.em
    circulating = flow > 0.0
    y = [0.0, CHOKE_DP_PA, _profile_bhp(ukf, flow) + 3.0e5, flow if circulating else np.nan]
    x0 = ukf.initial_state(y, circulating)
    inputs = ModelInputs(em, "block_position", 5)
    inputs.start(x0, CHOKE_DP_PA)
    u, problems = inputs.frame({}, 1)
    assert problems == []
    rate = drift(NUMPY, em, x0, [u[0, 0] - em.wm.geometry.static_stretch_m, *u[1:, 0]])
    flows = [em.flow(i) for i in range(2, em.n + 1)] + [em.string_flow]
    pressures = [em.pressure(i) for i in range(1, em.n + 1)] + [em.string_pressure]
    assert np.max(np.abs(np.asarray(rate)[flows])) < 1e-9          # m^3/s^2
    assert np.max(np.abs(np.asarray(rate)[pressures])) < 1.0       # Pa/s
    assert x0[em.pressure(1)] - em.wm.well.choke_downstream_pressure_pa == pytest.approx(CHOKE_DP_PA)


def test_pump_off_the_density_offset_takes_the_departure_by_the_priors(ukf):
    """No flow, no friction: the departure d goes to the density offset alone, the scalar
    Kalman gain's share s^2 (gH)^2 / (s^2 (gH)^2 + R); the BHP keeps the sensor's share."""
    em, est = ukf.em, ukf.est
    departure = 4.0e5
    y = [0.0, CHOKE_DP_PA, _profile_bhp(ukf, 0.0) + departure, np.nan]
    x0 = ukf.initial_state(y, False)
    g = em.wm.well.gravity_mps2
    gh = g * (em.wm.geometry.node_depth_m[-1] - em.wm.geometry.node_depth_m[0])
    prior = (est.initial_density_offset_std_kgm3 * gh) ** 2
    sensor = est.measurement_noise.bhp_pa ** 2
    assert x0[em.density_offset] * gh == pytest.approx(departure * prior / (prior + sensor), rel=1e-9)
    assert y[2] - x0[em.pressure(em.n)] == pytest.approx(departure * sensor / (prior + sensor), rel=1e-6)
    theta = [x0[em.theta(i)] for i in range(2, em.n + 1)]
    assert theta == [est.friction_tuning.theta_initial] * (em.n - 1)


def test_circulating_the_friction_factor_takes_a_share_too(ukf):
    """Circulating, the same departure is split: the (correlated) friction factors move
    together and the density offset takes less than it does with the pump off."""
    em = ukf.em
    y = [0.0, CHOKE_DP_PA, _profile_bhp(ukf, CIRCULATION) + 4.0e5, CIRCULATION]
    x0 = ukf.initial_state(y, True)
    off = ukf.initial_state([0.0, CHOKE_DP_PA, _profile_bhp(ukf, 0.0) + 4.0e5, np.nan], False)
    theta = np.array([x0[em.theta(i)] for i in range(2, em.n + 1)])
    assert np.all(theta > 1.0) and np.ptp(theta) < 0.01 * (np.mean(theta) - 1.0)
    assert 0.0 < x0[em.density_offset] < off[em.density_offset]


def test_known_parameters_start_on_the_reports_profile():
    """A prior that knows the parameters (zero covariance) moves none of them."""
    em = build_estimation_model(load_rig(CONFIG_DIR))
    x0 = initial_state(em, 1.0, [0.0, CHOKE_DP_PA, 6.9e7, CIRCULATION], True,
                       np.zeros((em.size, em.size)), 1.0e10)
    assert x0[em.density_offset] == 0.0
    assert [x0[em.theta(i)] for i in range(2, em.n + 1)] == [1.0] * (em.n - 1)
