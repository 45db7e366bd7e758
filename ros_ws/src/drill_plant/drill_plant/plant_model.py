"""Truth plant: stochastic wellbore hydraulics + hoisting (docs/design.md §3).

State x = [x_s, v_s, p_1, q_2, p_2, ..., q_n, p_n, q_d, p_I] (2n + 3 entries, SI),
input u = [u_b block position m, u_c choke opening 1, q_bpp m^3/s, p_in Pa].
The drift is built from the shared equations in drill_core.hydraulics with the
Herschel-Bulkley annular friction; it is compiled once with CasADi into a
function that advances a whole sensor frame, with Wiener increments drawn from a
seeded numpy generator so runs reproduce exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI
from drill_core.config import RigConfig
from drill_core.integrators import srk_step
from drill_core.operating_point import OperatingPoint, operating_point

INPUT_NAMES = ("block_position_m", "choke_opening", "bpp_flow_m3s", "pump_pressure_pa")


@dataclass(frozen=True)
class PlantLayout:
    """Indices of the plant state vector for n annulus segments."""
    n: int

    @property
    def size(self) -> int:
        return 2 * self.n + 3

    position = 0
    velocity = 1

    def pressure(self, i: int) -> int:
        """Index of p_i, i = 1..n."""
        return 2 * i

    def flow(self, i: int) -> int:
        """Index of q_i, i = 2..n."""
        return 2 * i - 1

    @property
    def string_flow(self) -> int:
        return 2 * self.n + 1

    @property
    def string_pressure(self) -> int:
        return 2 * self.n + 2


def drift(xp, wm: hy.WellModel, x, u):
    """Deterministic right-hand side f(x, u) of the truth plant, as a list of entries."""
    lay = PlantLayout(wm.n)
    n = wm.n
    p = [x[lay.pressure(i)] for i in range(1, n + 1)]
    q = [x[lay.flow(i)] for i in range(2, n + 1)]
    x_s, v_s = x[lay.position], x[lay.velocity]
    q_c = hy.choke_flow(wm, u[1], p[0] - wm.well.choke_downstream_pressure_pa)
    friction = hy.annulus_friction(xp, wm, q, v_s)
    rates = hy.hydraulic_rates(xp, wm, p, q, x[lay.string_flow], x[lay.string_pressure], x_s, v_s,
                               q_c, u[2], u[3], friction)
    out = [v_s, hy.hoisting_acceleration(wm, x_s, v_s, u[0])]
    for i in range(n):
        if i > 0:
            out.append(rates.flow[i - 1])
        out.append(rates.pressure[i])
    return out + [rates.string_flow, rates.string_pressure]


def diffusion(wm: hy.WellModel, config: RigConfig) -> np.ndarray:
    """Additive diffusion: g_p on pressures, g_q on flows, none on the hoisting states."""
    lay = PlantLayout(wm.n)
    g = np.zeros(lay.size)
    g[[lay.pressure(i) for i in range(1, wm.n + 1)] + [lay.string_pressure]] = \
        config.plant.pressure_diffusion_pa_sqrt_s
    g[[lay.flow(i) for i in range(2, wm.n + 1)] + [lay.string_flow]] = \
        config.plant.flow_diffusion_m3s_sqrt_s
    return g


@dataclass(frozen=True)
class SteadyState:
    """A consistent steady operating point: state and the inputs that hold it."""
    state: np.ndarray
    inputs: np.ndarray       # [u_b, u_c, q_bpp, p_in]
    choke_flow_m3s: float


def steady_state(wm: hy.WellModel, circulation_m3s: float, choke_dp_pa: float,
                 bpp_flow_m3s: float) -> SteadyState:
    """The truth plant's state at rest at the well's steady operating point
    (drill_core.operating_point: the U-tube balance of a circulation rate)."""
    return plant_steady_state(wm.n, operating_point(wm, circulation_m3s, choke_dp_pa,
                                                    bpp_flow_m3s))


def plant_steady_state(n: int, op: OperatingPoint) -> SteadyState:
    """An operating point in the plant's state layout (string at rest at 0 m)."""
    lay = PlantLayout(n)
    x = np.zeros(lay.size)
    for i in range(1, n + 1):
        x[lay.pressure(i)] = op.annulus_pressure_pa[i - 1]
    for i in range(2, n + 1):
        x[lay.flow(i)] = op.annulus_flow_m3s[i - 2]
    x[lay.string_pressure] = op.string_pressure_pa
    x[lay.string_flow] = op.string_flow_m3s
    return SteadyState(x, op.inputs, op.choke_flow_m3s)


def _symbolic_drift(wm: hy.WellModel, x, u):
    return ca.vertcat(*drift(CASADI, wm, [x[i] for i in range(x.numel())], u))


def build_frame_function(wm: hy.WellModel, config: RigConfig) -> ca.Function:
    """CasADi function advancing one sensor frame.

    plant_frame(x0, U[4 x N], DW[nx x N*substeps]) -> X[nx x N], X[:, k] the state after
    plant step k; U[:, k] is held over step k; DW are Wiener increments per substep.
    """
    lay = PlantLayout(wm.n)
    substeps = config.plant.substeps
    h = config.plant.step_s / substeps
    x = ca.SX.sym("x", lay.size)
    u = ca.SX.sym("u", 4)
    dw = ca.SX.sym("dw", lay.size, substeps)
    g = ca.DM(diffusion(wm, config))
    xn = x
    for k in range(substeps):
        xn = srk_step(lambda s: _symbolic_drift(wm, s, u), lambda s: g, xn, h, dw[:, k])
    step = ca.Function("plant_step", [x, u, dw], [xn])
    return step.mapaccum("plant_frame", config.plant.steps_per_frame)


def build_outputs_function(wm: hy.WellModel) -> ca.Function:
    """Algebraic quantities for the truth message: [q_c, q_bit, annulus friction 2..n, string friction]."""
    lay = PlantLayout(wm.n)
    x = ca.SX.sym("x", lay.size)
    u = ca.SX.sym("u", 4)
    xs = [x[i] for i in range(lay.size)]
    p = [xs[lay.pressure(i)] for i in range(1, wm.n + 1)]
    q = [xs[lay.flow(i)] for i in range(2, wm.n + 1)]
    v_s = xs[lay.velocity]
    rho_g = wm.well.mud.density_kgm3 * wm.well.gravity_mps2
    q_c = hy.choke_flow(wm, u[1], p[0] - wm.well.choke_downstream_pressure_pa)
    q_bit = hy.bit_flow(CASADI, wm, xs[lay.string_pressure] - (p[-1] - rho_g * xs[lay.position]))
    out = [q_c, q_bit, *hy.annulus_friction(CASADI, wm, q, v_s),
           hy.string_friction(CASADI, wm, xs[lay.string_flow], v_s)]
    return ca.Function("plant_outputs", [x, u], [ca.vertcat(*out)])
