"""Annular friction laws of the shared estimation model (drill_core.estimation_model):
scaled_rheology against the truth's Herschel-Bulkley friction (values and flow gain), the
quadratic law (paper eq. 46) unchanged, and both laws stable under RK4 at the NMPC's and the
UKF's steps over a 15 s horizon at rest and while tripping."""
from __future__ import annotations

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import ConfigError, load_rig, replace
from drill_core.estimation_model import (annulus_friction, build_discrete_model,
                                         build_estimation_model, fitted_friction_parameters,
                                         friction_flow_gain_bound)
from drill_core.rig_root import config_dir

CONFIG_DIR = config_dir()
LPM = 1.0 / 60000.0
BAR = 1.0e5
NMPC_STEP_S = 0.04          # 1 s sample / 25 RK4 steps (config/nmpc.yaml, checked below)
UKF_STEP_S = 0.05           # 0.1 s frame / 2 RK4 steps (config/estimator.yaml)


def _model(law: str):
    cfg = load_rig(CONFIG_DIR)
    cfg = replace(cfg, estimator=replace(cfg.estimator, annular_friction_law=law))
    return build_estimation_model(cfg)


@pytest.fixture(scope="module")
def scaled():
    return _model("scaled_rheology")


@pytest.fixture(scope="module")
def predicting():
    """The NMPC's copies: the same law with its yield jump while the pump is on and off."""
    cfg = load_rig(CONFIG_DIR)
    return tuple(build_estimation_model(cfg, smoothing_mps=s)
                 for s in (cfg.nmpc.prediction_friction_smoothing_mps,
                           cfg.nmpc.pump_off_friction_smoothing_mps))


@pytest.fixture(scope="module")
def quadratic():
    return _model("quadratic")


def _state(em, flow_m3s: float, theta) -> np.ndarray:
    x = np.zeros(em.size)
    for i in range(2, em.n + 1):
        x[em.flow(i)] = flow_m3s
        x[em.theta(i)] = theta[i - 2] if np.ndim(theta) else theta
    return x


def _friction(em, flow_m3s: float, velocity_mps: float = 0.0, theta=1.0) -> np.ndarray:
    x = _state(em, flow_m3s, theta)
    x[1] = velocity_mps
    return np.array([float(v) for v in annulus_friction(np, em, x)])


def test_scaled_rheology_with_unit_theta_is_the_truths_friction(scaled):
    # the truth's per-path friction at 1000 L/min, string still (Case 2 circulation)
    assert _friction(scaled, 1000.0 * LPM) / BAR == pytest.approx([12.47, 8.31, 7.08], abs=0.01)
    for q, v_s in ((500.0, 0.0), (2200.0, 0.0), (1000.0, 0.5), (1000.0, -0.5), (3000.0, 0.3)):
        truth = np.array(hy.annulus_friction(np, scaled.wm, [q * LPM] * 3, v_s), dtype=float)
        assert _friction(scaled, q * LPM, v_s) == pytest.approx(truth, rel=2e-3), (q, v_s)
    assert scaled.nominal_friction.max_error_pa < 0.01 * BAR       # table vs its exact law
    assert _friction(scaled, 1000.0 * LPM, theta=1.2) == pytest.approx(
        1.2 * _friction(scaled, 1000.0 * LPM))


def test_scaled_rheology_flow_gain_matches_the_truth_where_the_quadratic_does_not(scaled, quadratic):
    q, dq = 1000.0 * LPM, 50.0 * LPM

    def gain(fn):
        return (fn(q + dq) - fn(q - dq)) / (2.0 * dq)

    truth = gain(lambda f: np.array(hy.annulus_friction(np, scaled.wm, [f] * 3, 0.0), dtype=float))
    model = gain(lambda f: _friction(scaled, f))
    theta = fitted_friction_parameters(quadratic, [q] * 3, _friction(scaled, q))
    quad = gain(lambda f: _friction(quadratic, f, theta=theta))
    assert np.all(model / truth > 0.8) and np.all(model / truth < 1.25)
    assert np.all(quad / truth > 10.0)          # 2F/q: the wrong-sign choke channel (docs/nmpc.md)


def test_stiffness_bound_is_the_peak_gain_only_near_zero_relative_flow(scaled, predicting, quadratic):
    """The NMPC caps theta_i so that theta_i dF_i/dq_i h / M_i stays inside RK4's region
    (2.8): at theta 1 its peak is 1.2 of it with the pump on, 0.6 with the pump off; the
    UKF's jump, as sharp as the circulating prediction's, at its longer step is there too."""
    nmpc = load_rig(CONFIG_DIR).nmpc
    assert nmpc.sample_time_s / nmpc.substeps == NMPC_STEP_S
    predicting, pump_off = predicting
    peak = np.array(predicting.nominal_friction.peak_flow_gain)
    inertance = np.array(predicting.wm.geometry.annulus_inertance_kg_m4)
    assert NMPC_STEP_S * peak / inertance == pytest.approx([1.18, 1.18, 1.24], abs=0.02)
    off_peak = np.array(pump_off.nominal_friction.peak_flow_gain)
    assert NMPC_STEP_S * off_peak / inertance == pytest.approx([0.60, 0.60, 0.63], abs=0.02)
    ukf_peak = np.array(scaled.nominal_friction.peak_flow_gain)
    assert UKF_STEP_S * ukf_peak / inertance == pytest.approx([1.47, 1.47, 1.56], abs=0.02)
    assert friction_flow_gain_bound(predicting, _state(predicting, 0.0, 1.0), 0.1) == pytest.approx(peak)
    circulating = friction_flow_gain_bound(predicting, _state(predicting, 1000.0 * LPM, 1.0), 0.1)
    assert np.all(circulating < 0.05 * peak)
    x = _state(quadratic, 1000.0 * LPM, 1.0)
    v_e = 1000.0 * LPM / np.array(quadratic.wm.geometry.main_flow_area_m2)
    assert friction_flow_gain_bound(quadratic, x, 0.1) == pytest.approx(
        2.0 * v_e / np.array(quadratic.wm.geometry.main_flow_area_m2))


def test_quadratic_law_is_eq_46(quadratic):
    g = quadratic.wm.geometry
    x = _state(quadratic, 1000.0 * LPM, [3.0e6, 4.0e6, 5.0e6])
    x[1] = 0.3
    v_e = np.array([1000.0 * LPM / a - k * 0.3 for a, k in zip(g.main_flow_area_m2, g.main_clinging)])
    assert _friction(quadratic, 1000.0 * LPM, 0.3, [3.0e6, 4.0e6, 5.0e6]) == pytest.approx(
        np.array([3.0e6, 4.0e6, 5.0e6]) * np.abs(v_e) * v_e)
    assert quadratic.names[quadratic.theta(2)] == "friction_parameter_2_pa_s2_m2"


def _rest(em):
    """Pump off, string hanging still, mud static (exactly steady for any theta)."""
    w, g = em.wm.well, em.wm.geometry
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    x = _state(em, 0.0, 1.0)
    for i in range(1, em.n + 1):
        x[em.pressure(i)] = rho_g * g.node_depth_m[i - 1]
    x[em.string_pressure] = rho_g * g.bit_depth_m
    return x, np.zeros(4)


def _circulating(em, flow_m3s: float, choke_dp_pa: float):
    """Steady circulation of the scaled_rheology model with theta = 1 (hand balance)."""
    w, g = em.wm.well, em.wm.geometry
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    x = _state(em, flow_m3s, 1.0)
    friction = _friction(em, flow_m3s)
    x[em.pressure(1)] = w.choke_downstream_pressure_pa + choke_dp_pa
    for i in range(2, em.n + 1):
        x[em.pressure(i)] = x[em.pressure(i - 1)] + rho_g * (g.node_depth_m[i - 1]
                                                             - g.node_depth_m[i - 2]) + friction[i - 2]
    x[em.string_flow] = flow_m3s
    bit = w.bha_loss_coefficient_pa_s_m3 * flow_m3s \
        + 0.5 * w.mud.density_kgm3 * (flow_m3s / w.bit_nozzle_coefficient_m2) ** 2
    x[em.string_pressure] = x[em.pressure(em.n)] + bit
    pump = x[em.string_pressure] - rho_g * g.bit_depth_m + float(hy.string_friction(np, em.wm, flow_m3s, 0.0))
    return x, np.array([0.0, flow_m3s, 0.0, pump])


def _simulate(em, x0, u0, step_s: float, trip_speed_mps: float, horizon_s: float = 15.0):
    F = build_discrete_model(em, step_s)
    x, out = x0.copy(), []
    for k in range(int(round(horizon_s / step_s))):
        u = u0.copy()
        u[0] = trip_speed_mps * (k + 0.5) * step_s           # block reference ramp (pull out)
        x = np.asarray(F(x, u), dtype=float).ravel()
        out.append(x.copy())
    return np.array(out)


@pytest.mark.parametrize("case", ["rest", "trip"])
def test_scaled_rheology_is_stable_under_rk4_at_the_nmpc_and_ukf_steps(scaled, predicting, case):
    """The UKF's model at its step, the NMPC's (both its laws) at its own."""
    if case == "rest":
        x0, u0 = _rest(scaled)
        speed = 0.0
    else:
        x0, u0 = _circulating(scaled, 1000.0 * LPM, 2.0e6)
        speed = 0.5
    bhp = scaled.pressure(scaled.n)
    # the abrupt 0.5 m/s block ramp (no drawworks lag) swings the string to 0.94 m/s and
    # the BHP by -26 bar
    for em, step, tolerance in ((predicting[0], NMPC_STEP_S, 0.05 * BAR),
                                (predicting[1], NMPC_STEP_S, 0.05 * BAR),
                                (scaled, UKF_STEP_S, 0.05 * BAR)):
        reference = _simulate(em, x0, u0, 0.005, speed)
        run = _simulate(em, x0, u0, step, speed)
        assert np.all(np.isfinite(run)), step
        stride = int(round(step / 0.005))
        err = np.max(np.abs(run[:, bhp] - reference[stride - 1::stride, bhp]))
        assert err < tolerance, (step, err)
    if case == "rest":
        assert np.max(np.abs(reference[:, bhp] - x0[bhp])) < 1.0          # steady to 1 Pa
    else:
        assert np.max(reference[:, 0]) > 5.0                                # the string moved
        assert np.max(np.abs(reference[:, bhp] - x0[bhp])) < 30.0 * BAR      # a swab, bounded


def test_law_is_validated_by_name():
    with pytest.raises(ConfigError, match="annular_friction_law.*quadratic, scaled_rheology"):
        load_rig(CONFIG_DIR, {"estimator": {"annular_friction_law": "cubic"}})
    with pytest.raises(ConfigError, match="annular_friction_smoothing_mps"):
        load_rig(CONFIG_DIR, {"estimator": {"annular_friction_smoothing_mps": 0.0}})


def test_the_measurement_is_the_state_map_the_ukf_uses(scaled):
    from drill_core.estimation_model import MEASUREMENT_NAMES, measurement, measurement_map
    index, offset = measurement_map(scaled)
    assert len(index) == len(MEASUREMENT_NAMES)
    x = np.arange(scaled.size, dtype=float) * 1.0e3
    y = measurement(scaled, x, circulating=True)
    assert y == pytest.approx(list(x[index] - offset))
    assert y[1] == x[scaled.pressure(1)] - scaled.wm.well.choke_downstream_pressure_pa
    assert len(measurement(scaled, x, circulating=False)) == 3          # no q_d without flow
