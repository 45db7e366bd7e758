"""The UKF's first state: a steady state of the estimation model consistent with one
measurement and the filter's prior."""
from __future__ import annotations

import numpy as np

from drill_core.backend import NUMPY
from drill_core.estimation_model import EstimationModel, path_friction


def initial_state(em: EstimationModel, theta_initial: float, y, circulating: bool,
                  prior_covariance, bhp_variance_pa2: float) -> np.ndarray:
    """A steady state of ``em`` from y = [z1 m, choke dp Pa, BHP Pa, q_d m^3/s] (SI).

    String at rest at the measured position; all flows equal the measured string flow (0
    with the pump off); p_1 from the measured choke dp. The measured BHP's departure from
    the model's profile with the prior parameters (every theta at ``theta_initial``, the
    density offset 0, the string friction and bulk modulus factors 1) goes to the parameters that carry model
    error, theta_i and the density offset, as their prior's conditional mean given that one
    reading: a Kalman update of the parameter block of ``prior_covariance`` (SI, the
    filter's P0) with the sensitivities dp_n/dtheta_i = f_i(q) and dp_n/d(delta_rho) =
    g (z_n - z_1), and the BHP sensor's variance. The pressures then follow the model's
    steady profile from p_1 down with those parameters, so every flow and pressure rate is
    zero at the start and no state has to absorb a start-up transient (what is left of the
    departure, the sensor's share, the filter's first updates take). p_I: the bit's
    pressure drop over the annulus pressure at the bit (circulating), or the string's
    hydrostatic column capped at the BHP (pump off).
    """
    g, w = em.wm.geometry, em.wm.well
    y = np.asarray(y, dtype=float)
    x = np.zeros(em.size)
    sensed = em.sensed_states(y, w.choke_downstream_pressure_pa)     # the inverse of h(x)
    x[em.position] = sensed[em.position]
    flow = float(y[3]) if circulating and len(y) > 3 and np.isfinite(y[3]) else 0.0
    flow = max(flow, 0.0)
    for i in range(2, em.n + 1):
        x[em.flow(i)] = flow
        x[em.theta(i)] = theta_initial
    x[em.string_flow] = flow
    if em.with_string_friction:
        x[em.string_friction] = 1.0
    if em.with_bulk_modulus:
        x[em.bulk_modulus] = 1.0

    carriers = [em.theta(i) for i in range(2, em.n + 1)]
    sensitivity = [float(path_friction(NUMPY, em, k, flow, 0.0)) for k in range(em.n - 1)]
    if em.with_density_offset:
        carriers.append(em.density_offset)
        sensitivity.append(w.gravity_mps2 * (g.node_depth_m[-1] - g.node_depth_m[0]))
    a = np.asarray(sensitivity)
    prior = np.asarray(prior_covariance, dtype=float)[np.ix_(carriers, carriers)]
    p1 = sensed[em.pressure(1)]
    departure = y[2] - _steady_profile(em, x, p1)[-1]
    x[carriers] += prior @ a * departure / (a @ prior @ a + bhp_variance_pa2)
    for i, p in enumerate(_steady_profile(em, x, p1), start=1):
        x[em.pressure(i)] = p
    p_n = x[em.pressure(em.n)]
    rho_g = (w.mud.density_kgm3 + em.density_offset_of(x)) * w.gravity_mps2
    if flow > 0.0:
        a_bit = 0.5 * w.mud.density_kgm3 / w.bit_nozzle_coefficient_m2 ** 2
        x[em.string_pressure] = p_n - rho_g * (g.bit_above_bhp_node_m + y[0]) \
            + w.bha_loss_coefficient_pa_s_m3 * flow \
            + a_bit * flow ** 2
    else:
        x[em.string_pressure] = min(rho_g * (g.bit_depth_m - y[0]), p_n)
    return x


def _steady_profile(em: EstimationModel, x, p1_pa: float) -> list[float]:
    """p_1..p_n [Pa] at rest in the annulus' momentum balance with the flows and parameters
    of ``x``: each node the one above plus its mud column and its path's friction."""
    w, depth = em.wm.well, em.wm.geometry.node_depth_m
    rho_g = (w.mud.density_kgm3 + em.density_offset_of(x)) * w.gravity_mps2
    out = [p1_pa]
    for k in range(em.n - 1):
        friction = float(path_friction(NUMPY, em, k, x[em.flow(k + 2)], 0.0, x[em.theta(k + 2)]))
        out.append(out[-1] + rho_g * (depth[k + 1] - depth[k]) + friction)
    return out
