"""Estimation model shared by the UKF and the NMPC (paper eqs. 45-48; DESIGN section 5).

The truth-plant equations (drill_core.hydraulics) with the annular friction replaced
by F_i = theta_i |v_e,i| v_e,i, v_e,i = q_i / A_f,i - K_c v_s (eq. 46 with the
physical clinging sign), random-walk parameters theta_i, the block-position
controller in place of the drawworks lag, and optionally an unmeasured influx into
the bottom volume (input disturbance on BHP, NMPC2).

State  x = [z1 m, z2 m/s, z3 m s, p_1, q_2, p_2, ..., q_n, p_n, q_d, p_I, theta_2..theta_n (, d)]
Input  u = [u_r block reference m, q_c choke flow m^3/s, q_bpp m^3/s, p_in pump pressure Pa]
Output y = [z1, p_1 - p_0, p_n, q_d] (q_d only while circulating).
Everything here takes an array namespace ``xp`` so the one definition evaluates on
numpy rows (all sigma points at once) and on CasADi symbols.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI
from drill_core.block_control import block_command, integral_rate
from drill_core.config import RigConfig
from drill_core.integrators import euler_step, rk4_step

MEASUREMENT_NAMES = ("block_position_m", "choke_dp_pa", "bhp_pa", "string_flow_m3s")
INPUT_NAMES = ("block_position_ref_m", "choke_flow_m3s", "bpp_flow_m3s", "pump_pressure_pa")


@dataclass(frozen=True)
class EstimationModel:
    """Estimation model of a well: equations' parameters and state layout."""
    wm: hy.WellModel
    block_kp: float
    block_ki_per_s: float
    with_disturbance: bool

    @property
    def n(self) -> int:
        return self.wm.n

    # ---- layout
    @property
    def size(self) -> int:
        return 3 + (2 * self.n - 1) + 2 + (self.n - 1) + int(self.with_disturbance)

    def pressure(self, i: int) -> int:
        """Index of p_i, i = 1..n."""
        return 1 + 2 * i

    def flow(self, i: int) -> int:
        """Index of q_i, i = 2..n."""
        return 2 * i

    @property
    def string_flow(self) -> int:
        return 2 * self.n + 2

    @property
    def string_pressure(self) -> int:
        return 2 * self.n + 3

    def theta(self, i: int) -> int:
        """Index of theta_i, i = 2..n."""
        return 2 * self.n + 2 + i

    @property
    def disturbance(self) -> int:
        if not self.with_disturbance:
            raise AttributeError("model has no disturbance state")
        return self.size - 1

    def state_names(self) -> list[str]:
        names = ["string_position_m", "string_velocity_mps", "block_integral_m_s"]
        for i in range(1, self.n + 1):
            if i > 1:
                names.append(f"annulus_flow_{i}_m3s")
            names.append(f"annulus_pressure_{i}_pa")
        names += ["string_flow_m3s", "string_bottom_pressure_pa"]
        names += [f"friction_parameter_{i}_pa_s2_m2" for i in range(2, self.n + 1)]
        if self.with_disturbance:
            names.append("bottom_influx_m3s")
        return names

    def state_scale(self) -> np.ndarray:
        """Typical magnitude of each state, for conditioning (bar, 1000 L/min, ...)."""
        s = np.ones(self.size)
        s[1] = 0.1
        for i in range(1, self.n + 1):
            s[self.pressure(i)] = 1e5
            if i > 1:
                s[self.flow(i)] = 1e-2
        s[self.string_flow] = 1e-2
        s[self.string_pressure] = 1e5
        for i in range(2, self.n + 1):
            s[self.theta(i)] = 1e6
        if self.with_disturbance:
            s[self.disturbance] = 1e-3
        return s


def build_estimation_model(config: RigConfig, with_disturbance: bool = False) -> EstimationModel:
    wm = hy.build_well_model(config.well, config.plant.yield_regularisation_velocity_mps,
                             config.plant.choke_regularisation_pa)
    return EstimationModel(wm, config.actuators.block_kp, config.actuators.block_ki_per_s,
                           with_disturbance)


def annulus_friction(xp, em: EstimationModel, x):
    """Quadratic friction F_i = theta_i |v_e| v_e of paths 2..n (eq. 46) [Pa]."""
    g = em.wm.geometry
    v_s = x[1]
    out = []
    for k, i in enumerate(range(2, em.n + 1)):
        v_e = x[em.flow(i)] / g.main_flow_area_m2[k] - g.main_clinging[k] * v_s
        out.append(x[em.theta(i)] * xp.fabs(v_e) * v_e)
    return out


def drift(xp, em: EstimationModel, x, u):
    """Deterministic right-hand side of the estimation model, as a list of entries."""
    wm, n = em.wm, em.n
    z1, z2, z3 = x[0], x[1], x[2]
    u_b = block_command(u[0], z1, z3, wm.geometry.static_stretch_m, em.block_kp, em.block_ki_per_s)
    p = [x[em.pressure(i)] for i in range(1, n + 1)]
    q = [x[em.flow(i)] for i in range(2, n + 1)]
    rates = hy.hydraulic_rates(xp, wm, p, q, x[em.string_flow], x[em.string_pressure], z1, z2,
                               u[1], u[2], u[3], annulus_friction(xp, em, x))
    bottom_influx = 0.0
    if em.with_disturbance:
        bottom_influx = wm.well.mud.bulk_modulus_pa / wm.geometry.annulus_volume_m3[-1] \
            * x[em.disturbance]
    out = [z2, hy.hoisting_acceleration(wm, z1, z2, u_b), integral_rate(u[0], z1)]
    for i in range(n):
        if i > 0:
            out.append(rates.flow[i - 1])
        out.append(rates.pressure[i] + (bottom_influx if i == n - 1 else 0.0))
    out += [rates.string_flow, rates.string_pressure]
    out += [0.0 * z1] * (n - 1)                       # random-walk theta: no drift
    if em.with_disturbance:
        out.append(0.0 * z1)                          # random-walk disturbance
    return out


def measurement(em: EstimationModel, x, circulating: bool):
    """Noise-free measurement y = h(x) (eq. 48), without q_d when circulation is off."""
    p0 = em.wm.well.choke_downstream_pressure_pa
    y = [x[0], x[em.pressure(1)] - p0, x[em.pressure(em.n)]]
    if circulating:
        y.append(x[em.string_flow])
    return y


def build_discrete_model(em: EstimationModel, step_s: float, substeps: int = 1,
                         integrator: str = "rk4") -> ca.Function:
    """CasADi function F(x, u) -> x after ``step_s`` (``substeps`` steps, inputs held)."""
    x = ca.SX.sym("x", em.size)
    u = ca.SX.sym("u", 4)
    uu = [u[i] for i in range(4)]

    def f(s):
        return ca.vertcat(*drift(CASADI, em, [s[i] for i in range(em.size)], uu))

    one_step = rk4_step if integrator == "rk4" else lambda fn, s, h: euler_step(fn, s, h)
    h = step_s / substeps
    xn = x
    for _ in range(substeps):
        xn = one_step(f, xn, h)
    return ca.Function("estimation_step", [x, u], [xn])


def friction_estimate(em: EstimationModel, x) -> np.ndarray:
    """Estimated annular friction [Pa] of paths 2..n at state ``x`` (numpy)."""
    return np.array([float(v) for v in annulus_friction(np, em, np.asarray(x, dtype=float))])
