"""Truth plant: stochastic wellbore hydraulics + hoisting, with the formation across the
open hole and the active pit (docs/design.md §3, docs/model.md).

State (PlantLayout, indexed by name): x = [x_s, v_s, p_1, q_2, p_2, ..., q_n, p_n, q_d, p_I,
pit gain, influx volume, loss volume] (2n + 6 entries, SI); the first 2n + 3 are the
hydraulic and hoisting states, the last three integrate the surface and formation flows.
Input u = [u_b block position m, u_c choke opening 1, q_bpp m^3/s, p_in Pa]; parameters
theta = PARAMETER_NAMES (what a scenario event may change during a run).
The drift is built from the shared equations in drill_core.hydraulics with the
Herschel-Bulkley annular friction; it is compiled once with CasADi into a
function that advances a whole sensor frame, with Wiener increments drawn from a
seeded numpy generator so runs reproduce exactly.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI
from drill_core.config import RigConfig, Well
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE, U_SIZE
from drill_core.integrators import srk_step
from drill_core.operating_point import OperatingPoint, operating_point
from drill_core.state_layout import POSITION, VELOCITY, WellboreLayout, hydraulic_state_names

# Plant parameters a scenario event may change (pore/fracture steps, a plugging choke) and
# the rig floor's hoisting mode (the elevator latched 1/0, the slips set 1/0).
PARAMETER_NAMES = ("pore_pressure_pa", "fracture_pressure_pa", "choke_capacity_factor",
                   "elevator_latched", "slips_set")
# The scenario events (drill_core.events) that set a parameter, and which one.
EVENT_PARAMETERS = {"pore_pressure": "pore_pressure_pa", "fracture_pressure": "fracture_pressure_pa",
                    "choke_plugging": "choke_capacity_factor"}


# The hoisting parameters of a string on the elevator with the slips out.
ON_THE_ELEVATOR = (1.0, 0.0)

# The paper's well is closed down-hole: no pore pressure, a fracture pressure no BHP here
# reaches, a clean choke, the string on the elevator (the physics tests of the paper's plant).
CLOSED_BOTTOM = (0.0, 1.0e9, 1.0, *ON_THE_ELEVATOR)


def nominal_parameters(well: Well) -> np.ndarray:
    """The parameters as configured: the formation window of well.yaml, a clean choke, the
    string on the elevator, the slips out."""
    return np.array([well.formation.pore_pressure_pa, well.formation.fracture_pressure_pa, 1.0,
                     *ON_THE_ELEVATOR])


PIT_GAIN = "pit_gain_m3"
INFLUX_VOLUME = "influx_volume_m3"
LOSS_VOLUME = "loss_volume_m3"


@dataclass(frozen=True)
class PlantLayout(WellboreLayout):
    """The truth plant's states by name for n annulus segments: the string motion, the
    hydraulics, then the volumes the surface and formation flows accumulate."""
    n: int

    @functools.cached_property
    def names(self) -> tuple[str, ...]:
        return (POSITION, VELOCITY, *hydraulic_state_names(self.n),
                PIT_GAIN, INFLUX_VOLUME, LOSS_VOLUME)

    @property
    def hydraulic_size(self) -> int:
        """The stochastic states (hoisting and hydraulics): the first 2n + 3, the ones
        noise drives."""
        return self.pit_gain

    @property
    def pit_gain(self) -> int:
        return self.index(PIT_GAIN)

    @property
    def influx_volume(self) -> int:
        return self.index(INFLUX_VOLUME)

    @property
    def loss_volume(self) -> int:
        return self.index(LOSS_VOLUME)


def drift(xp, wm: hy.WellModel, x, u, theta=None):
    """Deterministic right-hand side f(x, u, theta) of the truth plant, as a list of
    entries (theta: PARAMETER_NAMES, nominal_parameters by default)."""
    lay = PlantLayout(wm.n)
    n = wm.n
    pore, fracture, choke_capacity, latched, slips_set = \
        nominal_parameters(wm.well) if theta is None else theta
    p = [x[lay.pressure(i)] for i in range(1, n + 1)]
    q = [x[lay.flow(i)] for i in range(2, n + 1)]
    x_s, v_s = x[lay.position], x[lay.velocity]
    q_c = hy.choke_flow(wm, u[U_CHOKE] * choke_capacity, p[0] - wm.well.choke_downstream_pressure_pa)
    friction = hy.annulus_friction(xp, wm, q, v_s)
    rates = hy.hydraulic_rates(xp, wm, p, q, x[lay.string_flow], x[lay.string_pressure], x_s, v_s,
                               q_c, u[U_BPP_FLOW], u[U_PUMP_PRESSURE], friction)
    influx, loss = hy.formation_flows(xp, wm.well.formation, p[-1], pore, fracture)
    out = [v_s, hy.hoisting_acceleration(wm, x_s, v_s, u[U_BLOCK], latched, slips_set, xp)]
    for i in range(n):
        if i > 0:
            out.append(rates.flow[i - 1])
        out.append(rates.pressure[i] + (hy.bottom_inflow_rate(wm, influx - loss)
                                        if i == n - 1 else 0.0))
    # the active pit takes the returns and feeds the mud pump and the back-pressure pump
    pit_gain_rate = q_c - x[lay.string_flow] - u[U_BPP_FLOW]
    return out + [rates.string_flow, rates.string_pressure, pit_gain_rate, influx, loss]


def diffusion(wm: hy.WellModel, config: RigConfig) -> np.ndarray:
    """Additive diffusion: g_p on pressures, g_q on flows, none on the hoisting states and
    the accumulated volumes."""
    lay = PlantLayout(wm.n)
    g = np.zeros(lay.size)
    g[[lay.pressure(i) for i in range(1, wm.n + 1)] + [lay.string_pressure]] = \
        config.plant.pressure_diffusion_pa_sqrt_s
    g[[lay.flow(i) for i in range(2, wm.n + 1)] + [lay.string_flow]] = \
        config.plant.flow_diffusion_m3s_sqrt_s
    return g


def wiener_increments(rng: np.random.Generator, layout: PlantLayout, count: int,
                      substep_s: float) -> np.ndarray:
    """Wiener increments [size x count] for ``count`` substeps: drawn for the hydraulic
    states (in that order, so the noise does not depend on the accumulated volumes), zero
    for the accumulated volumes."""
    dw = np.zeros((layout.size, count))
    dw[:layout.hydraulic_size] = rng.normal(0.0, np.sqrt(substep_s),
                                            size=(layout.hydraulic_size, count))
    return dw


def held_parameters(theta: np.ndarray, steps: int) -> np.ndarray:
    """The plant parameters [len(PARAMETER_NAMES) x steps] held over a frame."""
    return np.repeat(np.asarray(theta, dtype=float)[:, None], steps, axis=1)


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


def _symbolic_drift(wm: hy.WellModel, x, u, theta):
    return ca.vertcat(*drift(CASADI, wm, [x[i] for i in range(x.numel())], u,
                             [theta[i] for i in range(theta.numel())]))


def build_frame_function(wm: hy.WellModel, config: RigConfig) -> ca.Function:
    """CasADi function advancing one sensor frame.

    plant_frame(x0, U[4 x N], DW[nx x N*substeps], THETA[5 x N]) -> X[nx x N], X[:, k] the
    state after plant step k; U[:, k] and THETA[:, k] are held over step k; DW are Wiener
    increments per substep (zero rows for the accumulated volumes).
    """
    lay = PlantLayout(wm.n)
    substeps = config.plant.substeps
    h = config.plant.step_s / substeps
    x = ca.SX.sym("x", lay.size)
    u = ca.SX.sym("u", U_SIZE)
    theta = ca.SX.sym("theta", len(PARAMETER_NAMES))
    dw = ca.SX.sym("dw", lay.size, substeps)
    g = ca.DM(diffusion(wm, config))
    xn = x
    for k in range(substeps):
        xn = srk_step(lambda s: _symbolic_drift(wm, s, u, theta), lambda s: g, xn, h, dw[:, k])
    step = ca.Function("plant_step", [x, u, dw, theta], [xn])
    return step.mapaccum("plant_frame", config.plant.steps_per_frame)


def build_outputs_function(wm: hy.WellModel) -> ca.Function:
    """Algebraic quantities for the truth message: [q_c, q_bit, annulus friction 2..n,
    string friction, influx, loss]."""
    lay = PlantLayout(wm.n)
    x = ca.SX.sym("x", lay.size)
    u = ca.SX.sym("u", U_SIZE)
    theta = ca.SX.sym("theta", len(PARAMETER_NAMES))
    xs = [x[i] for i in range(lay.size)]
    p = [xs[lay.pressure(i)] for i in range(1, wm.n + 1)]
    q = [xs[lay.flow(i)] for i in range(2, wm.n + 1)]
    v_s = xs[lay.velocity]
    rho_g = wm.well.mud.density_kgm3 * wm.well.gravity_mps2
    q_c = hy.choke_flow(wm, u[U_CHOKE] * theta[2], p[0] - wm.well.choke_downstream_pressure_pa)
    q_bit = hy.bit_flow(CASADI, wm, hy.bit_pressure_drop(wm.geometry, xs[lay.string_pressure], p[-1],
                                                         rho_g, xs[lay.position]))
    out = [q_c, q_bit, *hy.annulus_friction(CASADI, wm, q, v_s),
           hy.string_friction(CASADI, wm, xs[lay.string_flow], v_s),
           *hy.formation_flows(CASADI, wm.well.formation, p[-1], theta[0], theta[1])]
    return ca.Function("plant_outputs", [x, u, theta], [ca.vertcat(*out)])
