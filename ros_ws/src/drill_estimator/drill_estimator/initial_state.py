"""The UKF's first state: a steady state of the estimation model consistent with one
measurement."""
from __future__ import annotations

import numpy as np

from drill_core.estimation_model import EstimationModel


def initial_state(em: EstimationModel, theta_initial: float, y, circulating: bool) -> np.ndarray:
    """A steady state of ``em`` from y = [z1 m, choke dp Pa, BHP Pa, q_d m^3/s] (SI).

    String at rest at the measured position; annulus pressures from the measured choke dp
    plus hydrostatics, the measured BHP minus that hydrostatic column spread over the paths
    as friction (so p_n matches the measurement); all flows equal the measured string flow
    (0 with the pump off); p_I = BHP + bit loss (circulating) or the string's hydrostatic
    column (pump off); every theta at ``theta_initial``.
    """
    g, w = em.wm.geometry, em.wm.well
    y = np.asarray(y, dtype=float)
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    x = np.zeros(em.size)
    x[em.position] = y[0]
    flow = float(y[3]) if circulating and len(y) > 3 and np.isfinite(y[3]) else 0.0
    flow = max(flow, 0.0)
    p1 = w.choke_downstream_pressure_pa + y[1]
    static = [p1 + rho_g * (g.node_depth_m[i] - g.node_depth_m[0]) for i in range(em.n)]
    extra = y[2] - static[-1]                  # friction (and model error) to distribute
    lengths = np.diff(np.asarray(g.node_depth_m))
    share = np.concatenate([[0.0], np.cumsum(lengths) / np.sum(lengths)])
    for i in range(1, em.n + 1):
        x[em.pressure(i)] = static[i - 1] + extra * share[i - 1]
        if i > 1:
            x[em.flow(i)] = flow
            x[em.theta(i)] = theta_initial
    x[em.string_flow] = flow
    if em.with_string_friction:
        x[em.string_friction] = 1.0            # the mud report's string friction
    if flow > 0.0:
        a = 0.5 * w.mud.density_kgm3 / w.bit_nozzle_coefficient_m2 ** 2
        x[em.string_pressure] = y[2] + w.bha_loss_coefficient_pa_s_m3 * flow + a * flow ** 2
    else:
        x[em.string_pressure] = min(rho_g * (g.bit_depth_m - y[0]), y[2])
    return x
