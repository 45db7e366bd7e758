"""The quasi-steady surge/swab model against the estimation model's own balances: at the
flows and pressures it computes for a constant string speed, every mass and momentum
balance of the shared drift is at rest."""

import numpy as np
import pytest

from drill_core.backend import NUMPY
from drill_core.config import load_rig
from drill_core.estimation_model import build_estimation_model, drift, path_friction
from drill_core.rig_root import config_dir
from drill_core.surge_swab import SurgeSwabModel

CONFIG_DIR = config_dir()
BIT_FLOW = 1000.0 / 60000.0          # 1000 L/min
CHOKE_DP = 2.0e6


@pytest.fixture(scope="module")
def em():
    return build_estimation_model(load_rig(CONFIG_DIR))


def _steady_state(em, model, theta, velocity):
    """The estimation model's state that the surge/swab model describes: flows from the
    steady mass balance, pressures from the choke up plus column and friction per path."""
    wm, g = em.wm, em.wm.geometry
    rho_g = wm.well.mud.density_kgm3 * wm.well.gravity_mps2
    flows = model.path_flows_m3s(BIT_FLOW, velocity)
    x = np.zeros(em.size)
    x[1] = velocity
    pressure = wm.well.choke_downstream_pressure_pa + CHOKE_DP
    x[em.pressure(1)] = pressure
    for i in range(2, em.n + 1):
        x[em.flow(i)] = flows[i - 2]
        pressure += rho_g * (g.node_depth_m[i - 1] - g.node_depth_m[i - 2]) \
            + path_friction(NUMPY, em, i - 2, flows[i - 2], velocity, theta[i - 2])
        x[em.pressure(i)] = pressure
    for k, i in enumerate(range(2, em.n + 1)):
        x[em.theta(i)] = theta[k]
    return x


@pytest.mark.parametrize("velocity", [-0.5, -0.2, 0.0, 0.3, 0.5])
def test_flows_and_pressures_are_a_steady_state_of_the_shared_model(em, velocity):
    model = SurgeSwabModel(em)
    theta = np.array([1.1, 0.9, 1.0])
    x = _steady_state(em, model, theta, velocity)
    choke = model.choke_flow_m3s(BIT_FLOW, 0.0, velocity)
    # the string side is not part of this model: feed the bit exactly the steady bit flow
    rates = drift(NUMPY, em, x, [0.0, choke, 0.0, 0.0])
    for i in range(1, em.n + 1):
        if i < em.n:
            assert rates[em.pressure(i)] == pytest.approx(0.0, abs=1e-3)     # Pa/s
        assert i == 1 or rates[em.flow(i)] == pytest.approx(0.0, abs=1e-9)   # m^3/s^2
    # the BHP the model reports is the one these pressures give
    bhp = x[em.pressure(em.n)]
    dp = model.choke_dp_for_bhp(bhp, theta, BIT_FLOW, velocity, 0.0)
    assert dp == pytest.approx(CHOKE_DP, abs=1e-3)


def test_swab_lowers_and_surge_raises_bhp_and_the_choke_passes_the_displacement(em):
    model = SurgeSwabModel(em)
    theta = np.ones(em.n - 1)
    assert model.bhp_change_pa(theta, BIT_FLOW, 0.0) == 0.0
    swab = [model.bhp_change_pa(theta, BIT_FLOW, v) for v in (0.1, 0.3, 0.5)]
    surge = [model.bhp_change_pa(theta, BIT_FLOW, -v) for v in (0.1, 0.3, 0.5)]
    assert swab[0] < 0.0 and np.all(np.diff(swab) < 0.0)       # more swab the faster
    assert surge[0] > 0.0 and np.all(np.diff(surge) > 0.0)
    # pulling out at v: the choke passes the bit flow less the steel volume withdrawn
    g = em.wm.geometry
    withdrawn = sum(g.displacement_area_m2) * 0.5
    assert model.choke_flow_m3s(BIT_FLOW, 1.0e-3, 0.5) == pytest.approx(BIT_FLOW + 1.0e-3 - withdrawn)
    # the bit flow of a state: the pump's flow plus the mud the string carries
    assert model.bit_flow_m3s(BIT_FLOW, 0.5) == pytest.approx(BIT_FLOW + g.string_top_inner_area_m2 * 0.5)


def test_an_array_of_speeds_gives_each_speed_s_own_answer(em):
    """The automated-MPD envelope evaluates a whole speed grid at once: the same numbers
    as one speed at a time, to the bit."""
    model = SurgeSwabModel(em)
    theta = (1.03, 0.97, 1.01)
    speeds = np.linspace(-0.6, 0.6, 121)
    grid = model.choke_dp_for_bhp(6.85e7, theta, BIT_FLOW, speeds, 0.0)
    one_by_one = [model.choke_dp_for_bhp(6.85e7, theta, BIT_FLOW, float(v), 0.0) for v in speeds]
    assert grid.shape == speeds.shape and np.array_equal(grid, np.array(one_by_one))
    assert isinstance(one_by_one[0], float)
