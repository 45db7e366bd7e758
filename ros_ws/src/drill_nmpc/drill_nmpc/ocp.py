"""NMPC supervisor: the optimal control problem of paper eqs. 49-59 in CasADi (DESIGN section 6).

Plain module (no rclpy). The prediction model is the shared estimation model
(``drill_core.estimation_model.drift``, the same equations the UKF runs) with the
friction parameters theta (and, for NMPC2, the bottom influx d) frozen over the horizon
at their estimates, plus the actuator lags (drawworks, back-pressure pump, mud pump)
around it (``PredictionModel``). docs/nmpc.md has the derivation and the measurements
behind each choice.

* **Multiple shooting**, one interval per sample t_s, inputs held over it, M classical
  RK4 steps per interval (forward Euler with the paper's M = 10 is 10 bar off or diverges
  on the lightly damped hoisting/hydraulic modes).
* **Stage-wise layout** (FATROP / HPIPM): stage k holds its state s_k then its controls
  v_k; per stage the gap s_{k+1} - Phi(s_k, v_k) comes first, then that stage's path
  constraints. Stage 0 has no state (x_0 = x_hat is a parameter); the terminal stage has
  no controls (cost only).
* **Control horizon** N_c: the stage state carries the previous input u_{k-1} (Delta u is
  stage-local) and u_r,k-2 (block-reference acceleration); stages k >= N_c apply u_{k-1}.
* **Scaling**: x = x_hat + S_x x~ (S_x = em.state_scale(): bar, 10 L/s, ...), u = u_{-1} +
  S_u u~ with S_u the slew limit per sample (|Delta u~| <= 1), slacks in SLACK_UNITS.
* **Cost (49)/(55)**: w~_i ((y_i - y_ref,i)/y_span,i)^2 over stages 1..N_p (reference
  trajectory of eq. 59 anchored at the estimated output), r~_i (Delta u_i/u_span,i)^2 and
  r~r_i ((u_i - u_ref,i)/u_span,i)^2 over the control horizon, T (xi^2 + xi) per slack
  (the linear term makes the penalty exact).
* **Soft constraints (52)-(53)**: string velocity, BHP band, choke dp band, string
  pressure above the annulus pressure at the moving bit + BHA loss, choke-flow capacity.
  Hard: input bounds (the block reference also within the monotone trip range), slew
  limits and the protection's block-reference acceleration limit.
* **NMPC1**: integrated tracking error of the pressure outputs (eq. 56); the value carried
  between solves integrates the estimated error outside the band, clamped. **NMPC2**: the estimated bottom influx
  d (eqs. 57-58) held constant over the horizon.
* **Solver**: by default one Gauss-Newton SQP step per sample (real-time iteration) with
  the HPIPM QP, warm-started from the shifted previous solution; ipopt and fatrop are
  selectable (config ``solver``).

On an unusable answer the problem is re-solved cold with the relaxed constraint set
(velocity, string pressure, input bounds, slew and acceleration: paper Alg. 3); if that
fails too the last input is held. Commands are always finite and inside the bounds.
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import math
import os
import subprocess
import tempfile
import time
from pathlib import Path
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI, NUMPY
from drill_core.config import Nmpc, RigConfig
from drill_core.estimation_model import EstimationModel, drift, friction_flow_gain_bound
from drill_core.block_control import block_command, integral_rate
from drill_core.integrators import euler_step, rk4_step
from drill_core.scenario import ActiveSetpoints
from drill_nmpc.motion_profile import MotionProfile

OUTPUT_NAMES = ("block_position_m", "choke_dp_pa", "bhp_pa")
INPUT_NAMES = ("block_position_ref_m", "choke_flow_m3s", "bpp_flow_m3s", "spp_pa")
SLACK_NAMES = ("velocity", "bhp_band", "choke_dp_band", "string_pressure", "choke_capacity")
# Unit of each slack variable inside the OCP (its SI value = unit * scaled value).
SLACK_UNITS = {"velocity": 0.01, "bhp_band": 1.0e4, "choke_dp_band": 1.0e5,
               "string_pressure": 1.0e5, "choke_capacity": 1.0e-3}
# Constraint kinds dropped in the relaxed retry (paper Alg. 3 keeps velocity, string
# pressure and the input limits).
RELAXED_DROPS = ("bhp_band", "choke_dp_band", "choke_capacity")
_INTEGRAL_OUTPUTS = (1, 2)        # NMPC1 integrates the pressure outputs (see docs/nmpc.md)
TRIP_RANGE_MARGIN_M = 0.5         # the block reference may pass the string / target by this
THETA_STIFFNESS_LIMIT = 2.0       # |lambda| h of the annular flow modes kept below this (RK4: 2.78)
THETA_SPEED_FLOOR_MPS = 0.1       # quadratic law: effective annular speed used for the cap near zero flow
_INF = float("inf")


@dataclass
class SolveResult:
    """Outcome of one supervisor step (SI units throughout)."""
    u: np.ndarray                          # command to apply from t_k: [u_r m, q_c m^3/s, q_bpp m^3/s, p_in Pa]
    success: bool                          # True when u comes from a converged solve
    fallback: str                          # "none", "relaxed" or "hold"
    status: str                            # solver return status (last attempt)
    iterations: int                        # solver iterations (last attempt)
    solve_time_s: float                    # wall time of the step, retries included
    cost: float                            # optimal cost (NaN when holding)
    slacks: dict = field(default_factory=dict)      # largest slack over the horizon per constraint, SI
    predicted_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))   # 0, t_s, ..., N t_s
    predicted: dict = field(default_factory=dict)   # name -> array over predicted_time_s
    planned_inputs: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # N x 4, u_j
    reference: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))       # (N+1) x 3, y_ref,j
    integral: np.ndarray = field(default_factory=lambda: np.zeros(0))             # NMPC1 e_0 [span s]
    configuration: str = ""
    choke_flow_m3s: float = float("nan")   # predicted choke flow under u at t_k (pressure-loop feedforward)


# ----------------------------------------------------------------------------- model pieces
class StringFrictionTable:
    """The shared model's string friction tabulated as a cubic B-spline of the relative flow.

    ``hy.string_friction`` (Herschel-Bulkley laminar stress by Newton steps, turbulent blend,
    per string section) is ~90 % of the expression graph of the model drift, and it is a
    function of the single scalar q_rel = q_d + A_I v_s (flow relative to the moving pipe).
    Sampling that one definition on a grid (dense around the regularised yield jump at 0)
    and interpolating it makes the prediction model and its derivatives ~10x cheaper; the
    table is checked against the exact function at build time (``max_error_pa``), and
    :meth:`applies` verifies the relative-flow form so a changed model falls back to the
    exact expression instead of silently diverging.
    """

    def __init__(self, wm: hy.WellModel, q_max_m3s: float = 0.2):
        self.wm = wm
        self.area = wm.geometry.string_top_inner_area_m2
        log = np.logspace(-6.0, math.log10(q_max_m3s), 160)
        grid = np.unique(np.concatenate([-log, [0.0], log, np.linspace(-q_max_m3s, q_max_m3s, 1601)]))
        values = np.asarray(hy.string_friction(NUMPY, wm, grid, 0.0 * grid), dtype=float)
        self.scale = 1.0e5
        self.spline = ca.interpolant("string_friction_table", "bspline", [grid], values / self.scale)
        check = np.linspace(-0.04, 0.04, 4001)
        exact = np.asarray(hy.string_friction(NUMPY, wm, check, 0.0 * check), dtype=float)
        table = np.asarray(self.spline(check), dtype=float).ravel() * self.scale
        self.max_error_pa = float(np.max(np.abs(table - exact)))

    def applies(self) -> bool:
        """True when hy.string_friction(q, v) == f(q + A_I v, 0) (the tabulated form)."""
        q = np.array([0.0, 0.005, 0.0167, 0.03, -0.01, 0.0167])
        v = np.array([0.3, -0.5, 0.5, -0.2, 0.1, 0.0])
        a = np.asarray(hy.string_friction(NUMPY, self.wm, q, v), dtype=float)
        b = np.asarray(hy.string_friction(NUMPY, self.wm, q + self.area * v, 0.0 * q), dtype=float)
        return bool(np.allclose(a, b, rtol=1e-9, atol=1.0)) and self.max_error_pa < 1.0e3

    def __call__(self, xp, wm, string_flow_m3s, string_velocity_mps):
        return self.scale * self.spline(string_flow_m3s + self.area * string_velocity_mps)


@contextlib.contextmanager
def _tabulated_string_friction(table: StringFrictionTable | None):
    """Evaluate the shared drift with the tabulated string friction (symbolic build only)."""
    if table is None:
        yield
        return
    exact = hy.string_friction
    hy.string_friction = table
    try:
        yield
    finally:
        hy.string_friction = exact


@dataclass(frozen=True)
class ActuatorLags:
    """First-order lags of the actuators between the NMPC's commands and the process
    (DESIGN section 4); None leaves that input instantaneous in the prediction."""
    drawworks_s: float | None = None      # block position (lags the block controller output)
    bpp_s: float | None = None            # back-pressure pump flow
    pump_s: float | None = None           # stand-pipe pressure

    @classmethod
    def from_config(cls, config: RigConfig) -> "ActuatorLags":
        a = config.actuators
        return cls(a.drawworks.time_constant_s, a.bpp.time_constant_s, a.mud_pump.time_constant_s)


ACTUATOR_KEYS = ("block_m", "bpp_flow_m3s", "spp_pa")    # measured actuator outputs


def input_arrays(cfg: Nmpc) -> dict[str, np.ndarray]:
    """The input vectors' limits and weights (min, max, slew, span, move_weight,
    reference_weight), the choke entry the dp set-point's with choke_control pressure."""
    out = {key: np.array(getattr(cfg, f"input_{key}").as_tuple(), dtype=float)
           for key in ("min", "max", "slew", "span", "move_weight", "reference_weight")}
    if cfg.choke_control == "pressure":
        c = cfg.choke_dp_setpoint
        for key, value in (("min", c.minimum_pa), ("max", c.maximum_pa), ("slew", c.slew_pa),
                           ("span", c.span_pa), ("move_weight", c.move_weight),
                           ("reference_weight", c.reference_weight)):
            out[key][1] = value
    return out


def choke_time_constant(cfg: Nmpc) -> float | None:
    """The choke pressure loop's time constant in the prediction [s]; None: the choke is
    on its flow loop (u[1] is a flow reference)."""
    return cfg.choke_dp_setpoint.time_constant_s if cfg.choke_control == "pressure" else None


def choke_input(cfg: Nmpc, choke_flow_m3s: float, choke_dp_pa: float) -> float:
    """The supervisor's choke input u[1] at an operating point: the choke-dp set-point
    with the choke on its pressure loop, else the flow reference."""
    return choke_dp_pa if cfg.choke_control == "pressure" else choke_flow_m3s


@dataclass(frozen=True)
class ChokeCommand:
    """The choke's part of a supervisor command (SI), as drill_msgs/RigCommand carries it."""
    pressure_control: bool
    flow_m3s: float              # flow reference, or the pressure loop's flow feedforward
    dp_ref_pa: float             # pressure loop: set-point at the command's stamp (else 0)
    dp_ref_rate_pa_s: float      # pressure loop: its ramp to the next planned set-point


def choke_command(cfg: Nmpc, result: "SolveResult", fallback_flow_m3s: float) -> ChokeCommand:
    """What the choke is told for a supervisor result: on the pressure loop u[1] is the
    set-point, ramped toward the next planned one, with the predicted choke flow (the
    operating point's ``fallback_flow_m3s`` before any solve predicted one) as feedforward."""
    u = np.asarray(result.u, dtype=float)
    if cfg.choke_control != "pressure":
        return ChokeCommand(False, float(u[1]), 0.0, 0.0)
    plan = np.asarray(result.planned_inputs, dtype=float).reshape(-1, 4)
    rate = float(plan[1, 1] - u[1]) / cfg.sample_time_s if plan.shape[0] > 1 else 0.0
    flow = result.choke_flow_m3s if math.isfinite(result.choke_flow_m3s) else fallback_flow_m3s
    return ChokeCommand(True, float(flow), float(u[1]), rate)


class PredictionModel:
    """The NMPC's prediction model: the shared drift plus the actuator lags.

    State x = [z1, z2, z3, p_1, q_2, ..., p_n, q_d, p_I (, b, q_bpp, p_in)]: the estimation
    model's evolving states, then the lagged actuator outputs that are modelled (block
    position b, back-pressure pump flow, stand-pipe pressure); par = [theta_2..theta_n (, d)]
    frozen over the horizon; ``pump_on`` (0/1) switches the mud pump (off: p_in -> 0).

    The shared estimation model puts the block at the block controller's output and the
    pumps at their commands instantly; the actuators (and the truth plant) lag them by
    T_dw = 4 s, T_bpp = 30 s and T_spp = 5 s. Predicting with instantaneous actuators made
    the supervisor lean on a back-pressure pump that answers in 30 s and drained the annulus
    (docs/nmpc.md). The shared drift is evaluated unchanged with the lagged pump outputs as
    its inputs and, for the block, at the *virtual* reference that makes its block command
    equal the lagged block b (the controller law is affine in the reference); the controller
    integrator z3 still integrates the real reference. The choke (PI flow loop on a 2 s
    valve, closed-loop time constant ~0.5 s) stays instantaneous.
    """

    def __init__(self, em: EstimationModel, lags: ActuatorLags | None = None,
                 table: StringFrictionTable | None = None,
                 choke_time_constant_s: float | None = None):
        self.em = em
        self.lags = lags or ActuatorLags()
        self.table = table
        self.choke_time_constant_s = choke_time_constant_s
        self.nd_model = em.theta(2)
        index = self.nd_model
        self.block = self.bpp = self.pump = None
        if self.lags.drawworks_s:
            self.block, index = index, index + 1
        if self.lags.bpp_s:
            self.bpp, index = index, index + 1
        if self.lags.pump_s:
            self.pump, index = index, index + 1
        self.nd = index
        self.npar = em.size - self.nd_model
        g = em.wm.geometry
        self._stretch = g.static_stretch_m
        self._slope = (block_command(1.0, 0.0, 0.0, self._stretch, em.block_kp, em.block_ki_per_s)
                       - block_command(0.0, 0.0, 0.0, self._stretch, em.block_kp, em.block_ki_per_s))

    def block_command(self, reference, z1, z3):
        em = self.em
        return block_command(reference, z1, z3, self._stretch, em.block_kp, em.block_ki_per_s)

    def full(self, x, par) -> list:
        """The estimation model's state (list) from a prediction state and par."""
        return [x[i] for i in range(self.nd_model)] + [par[i] for i in range(self.npar)]

    def rhs(self, x, u, par, pump_on=1.0):
        """Time derivative of the prediction state (list of expressions)."""
        em = self.em
        full = self.full(x, par)
        spp_cmd = u[3] * pump_on
        inputs = [u[0], self.choke_flow(x, u), x[self.bpp] if self.bpp is not None else u[2],
                  x[self.pump] if self.pump is not None else spp_cmd]
        if self.block is not None:
            inputs[0] = (x[self.block] - self.block_command(0.0, x[0], x[2])) / self._slope
        with _tabulated_string_friction(self.table):
            out = drift(CASADI, em, full, inputs)[:self.nd_model]
        if self.block is not None:
            out[2] = integral_rate(u[0], x[0])
            out.append((self.block_command(u[0], x[0], x[2]) - x[self.block]) / self.lags.drawworks_s)
        if self.bpp is not None:
            out.append((u[2] - x[self.bpp]) / self.lags.bpp_s)
        if self.pump is not None:
            out.append((spp_cmd - x[self.pump]) / self.lags.pump_s)
        return out

    def choke_flow(self, x, u):
        """The choke flow [m^3/s] under input u: the flow reference itself (flow control), or,
        with the choke on its pressure loop, the flow that takes the top annulus pressure
        to the set-point u[1] as a first-order lag (time constant T_c): what leaves the top
        volume plus the back-pressure pump's flow plus (dp - dp_ref) V_1 / (beta T_c)."""
        if self.choke_time_constant_s is None:
            return u[1]
        em = self.em
        g, w = em.wm.geometry, em.wm.well
        bpp = x[self.bpp] if self.bpp is not None else u[2]
        dp = x[em.pressure(1)] - w.choke_downstream_pressure_pa
        return (x[em.flow(2)] - g.displacement_area_m2[0] * x[1] + bpp
                + (dp - u[1]) * g.annulus_volume_m3[0]
                / (w.mud.bulk_modulus_pa * self.choke_time_constant_s))

    def function(self, step_s: float, substeps: int, integrator: str) -> ca.Function:
        """F(x, u, par, pump_on) -> x after one sample (inputs held), ``substeps`` RK4/Euler steps."""
        x = ca.SX.sym("x", self.nd)
        u = ca.SX.sym("u", 4)
        par = ca.SX.sym("par", self.npar)
        on = ca.SX.sym("pump_on")

        def f(s):
            return ca.vertcat(*self.rhs([s[i] for i in range(self.nd)], u, par, on))

        h = step_s / substeps
        xn = x
        for _ in range(substeps):
            xn = rk4_step(f, xn, h) if integrator == "rk4" else euler_step(f, xn, h)
        # The explicit Jacobian (one SX function) makes every derivative the NLP needs a call
        # of it per stage, instead of forward sweeps through the integrator in each direction.
        out = ca.SX.sym("out", self.nd)
        jac = ca.Function("jac_predict", [x, u, par, on, out],
                          [ca.jacobian(xn, x), ca.jacobian(xn, u), ca.jacobian(xn, par),
                           ca.jacobian(xn, on)],
                          ["x", "u", "par", "pump_on", "out_x_next"],
                          ["jac_x_next_x", "jac_x_next_u", "jac_x_next_par", "jac_x_next_pump_on"])
        return ca.Function("predict", [x, u, par, on], [xn], ["x", "u", "par", "pump_on"],
                           ["x_next"], {"custom_jacobian": jac, "jac_penalty": 0})

    def initial_state(self, x_full, u_prev=None, actuators: dict | None = None,
                      pump_on: bool = True) -> np.ndarray:
        """Prediction state at an estimate and the actuator outputs.

        Measured actuator outputs (``actuators``: ACTUATOR_KEYS) win; otherwise the block
        comes from the quasi-static hoisting balance (string at rest relative to the block:
        b = z1 + s_0 + c_eq z2 / k_eq) and the pumps are taken at their last commands.
        """
        x0 = np.asarray(x_full, dtype=float)[:self.nd_model].copy()
        extra = []
        actuators = actuators or {}

        def measured(key):
            v = actuators.get(key)
            return float(v) if v is not None and math.isfinite(float(v)) else None

        command, reference = measured("block_command_m"), measured("block_reference_m")
        if command is not None and reference is not None and self.em.block_ki_per_s > 0.0:
            # the controller integral behind the drawworks' last command (the UKF, fed the
            # block position, cannot observe it): c = block_command(u_r, z1, z3) solved for z3
            x0[2] = (command - self.block_command(reference, x0[0], 0.0)) / self.em.block_ki_per_s

        if self.block is not None:
            w = self.em.wm.well
            b = measured("block_m")
            extra.append(b if b is not None else
                         x0[0] + self._stretch + w.hoist_damping_n_s_m * x0[1] / w.hoist_stiffness_n_m)
        if self.bpp is not None:
            v = measured("bpp_flow_m3s")
            extra.append(v if v is not None else (float(u_prev[2]) if u_prev is not None else 0.0))
        if self.pump is not None:
            v = measured("spp_pa")
            extra.append(v if v is not None else
                         (float(u_prev[3]) * float(pump_on) if u_prev is not None else 0.0))
        return np.concatenate([x0, extra])

    def actuator_state(self, x) -> dict:
        """The modelled actuator outputs of a prediction state (ACTUATOR_KEYS)."""
        out = {}
        for key, index in zip(ACTUATOR_KEYS, (self.block, self.bpp, self.pump)):
            if index is not None:
                out[key] = float(x[index])
        return out

    def scale(self) -> np.ndarray:
        s = self.em.state_scale()[:self.nd_model]
        extra = [1.0] * (self.block is not None) + [1.0e-2] * (self.bpp is not None) \
            + [1.0e5] * (self.pump is not None)
        return np.concatenate([s, extra])

    def check(self, rng_seed: int = 0) -> float:
        """Largest relative mismatch of the hoisting acceleration against the shared law
        (guards the virtual-reference construction); 0 when the block is not modelled."""
        if self.block is None:
            return 0.0
        rng = np.random.default_rng(rng_seed)
        xs = ca.SX.sym("x", self.nd)
        us = ca.SX.sym("u", 4)
        ps = ca.SX.sym("p", self.npar)
        f = ca.Function("rhs", [xs, us, ps], [ca.vertcat(*self.rhs([xs[i] for i in range(self.nd)],
                                                                    us, ps))])
        worst = 0.0
        for _ in range(3):
            x = rng.normal(size=self.nd)
            acc = float(f(x, np.zeros(4), np.zeros(self.npar))[1])
            ref = float(hy.hoisting_acceleration(self.em.wm, x[0], x[1], x[self.block]))
            worst = max(worst, abs(acc - ref) / max(1.0, abs(ref)))
        return worst


def full_state(em: EstimationModel, x_hat, disturbance=None) -> np.ndarray:
    """Estimate as a state of ``em`` (adds/overrides the bottom influx d when ``em`` has it)."""
    x = np.asarray(x_hat, dtype=float).ravel()
    nd_theta = em.theta(em.n) + 1
    out = np.zeros(em.size)
    out[:nd_theta] = x[:nd_theta]
    if em.with_disturbance:
        if disturbance is not None:
            out[em.disturbance] = float(disturbance)
        elif x.size > nd_theta:
            out[em.disturbance] = x[nd_theta]
    return out


def outputs(em: EstimationModel, x) -> list:
    """Tracked outputs [block position, choke dp, BHP] of a state (numpy or CasADi)."""
    p0 = em.wm.well.choke_downstream_pressure_pa
    return [x[0], x[em.pressure(1)] - p0, x[em.pressure(em.n)]]


def string_pressure_margin(em: EstimationModel, x):
    """p_I - (p_n - rho g z1) - K_b q_d: string pressure above annulus-at-bit + BHA loss [Pa]."""
    w = em.wm.well
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    return (x[em.string_pressure] - (x[em.pressure(em.n)] - rho_g * x[0])
            - w.bha_loss_coefficient_pa_s_m3 * x[em.string_flow])


def choke_capacity(em: EstimationModel, dp):
    """Flow of the fully open choke at differential pressure dp [m^3/s] (eq. 53)."""
    return hy.choke_flow(em.wm, 1.0, dp)


# ----------------------------------------------------------------------------- compilation
# Derivative oracles each plugin evaluates every iteration: (user option, oracle name).
_COMPILABLE = {
    "sqpmethod": (("jac_fg", "nlp_jac_fg"),),
    "ipopt": (("jac_g", "nlp_jac_g"), ("grad_f", "nlp_grad_f")),
}
COMPILER_FLAGS = ("-O1", "-fPIC", "-shared")


def default_cache_dir() -> Path:
    """Where compiled NLP derivatives are kept ($DRILL_NMPC_CACHE or ~/.cache/drill_nmpc)."""
    env = os.environ.get("DRILL_NMPC_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "drill_nmpc"


def compiled_function(fn: ca.Function, cache_dir: str | os.PathLike | None = None) -> ca.Function:
    """``fn`` generated as C, compiled with the system C compiler and loaded as an external.

    The shared library is cached under a hash of the generated source, the flags and the
    CasADi version, so only the first use of a configuration pays the compilation (~10-20 s);
    concurrent builders write to temporary names and rename atomically.
    """
    directory = Path(cache_dir) if cache_dir else default_cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    name = fn.name()
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    gen.add(fn)
    source = gen.dump()
    key = hashlib.sha256("\n".join([source, " ".join(COMPILER_FLAGS), ca.__version__]).encode())
    library = directory / f"{name}_{key.hexdigest()[:20]}.so"
    if not library.exists():
        with tempfile.TemporaryDirectory(dir=directory) as tmp:
            src = Path(tmp) / f"{name}.c"
            src.write_text(source)
            out = Path(tmp) / "lib.so"
            subprocess.run([os.environ.get("CC", "gcc"), *COMPILER_FLAGS, "-o", str(out), str(src),
                            "-lm"], check=True, capture_output=True)
            os.replace(out, library)
    return ca.external(name, str(library))


# ----------------------------------------------------------------------------- the NLP
@dataclass
class _Stage:
    """Index bookkeeping of one stage of the stage-ordered NLP."""
    s: slice                  # state variables in z
    u: slice | None           # input variables in z (stages < N_c)
    slack: dict               # slack name -> index in z
    gap: slice | None         # gap rows of this stage (to stage k+1)
    rows: dict                # path row name -> list of row indices


class NmpcProblem:
    """The NLP of one configuration, built once; ``solve`` runs one instance of it."""

    def __init__(self, cfg: Nmpc, em: EstimationModel, configuration: str | None = None,
                 solver: str | None = None, jit: bool = False, substeps: int | None = None,
                 integrator: str | None = None, solver_options: dict | None = None,
                 tabulate_string_friction: bool = True, hessian: str = "exact",
                 lags: ActuatorLags | None = None, terminal_constraints: bool = False,
                 compile: bool = False, cache_dir: str | None = None,
                 acceleration_limit_mps2: float | None = None):
        self.cfg = cfg
        self.configuration = configuration or cfg.configuration
        if self.configuration == "NMPC2" and not em.with_disturbance:
            em = dataclasses.replace(em, with_disturbance=True)
        if self.configuration != "NMPC2" and em.with_disturbance:
            em = dataclasses.replace(em, with_disturbance=False)
        self.em = em
        self.solver_name = solver or cfg.solver
        if hessian not in ("exact", "gauss-newton"):
            raise ValueError(f"hessian {hessian!r} is not one of exact, gauss-newton")
        if hessian == "gauss-newton" and self.solver_name == "fatrop":
            raise ValueError("FATROP takes no user Hessian: use hessian='exact'")
        self.hessian = hessian
        self.terminal_constraints = terminal_constraints
        self.compile = compile
        self.cache_dir = cache_dir
        self.N = cfg.prediction_steps
        self.Nc = cfg.control_steps
        self.ts = cfg.sample_time_s
        self.substeps = substeps or cfg.substeps
        self.integrator = integrator or cfg.integrator
        table = StringFrictionTable(em.wm) if tabulate_string_friction else None
        if table is not None and not table.applies():
            table = None
        self.model = PredictionModel(em, lags, table, choke_time_constant(cfg))
        if self.model.check() > 1e-9:
            raise RuntimeError("drawworks-lag construction does not reproduce the hoisting law")
        self.nd = self.model.nd
        self.npar = self.model.npar
        self.ne = len(_INTEGRAL_OUTPUTS) if self.configuration == "NMPC1" else 0
        # Block-reference acceleration limit of the process protection (Delta of the
        # reference speed per sample); it needs u_r two samples back in the stage state.
        self.accel = acceleration_limit_mps2
        self.nw = 1 if acceleration_limit_mps2 else 0
        self.ns = self.nd + 4 + self.nw + self.ne   # stage state: x~, u~_{k-1}, u~_r,k-2, e
        self.Sx = self.model.scale()
        self.inputs = input_arrays(cfg)
        self.Su = self.inputs["slew"]
        self.u_span = self.inputs["span"]
        self.y_span = np.array(cfg.output_span.as_tuple(), dtype=float)
        self.F = self.model.function(self.ts, self.substeps, self.integrator)
        self._state_box = self._trust_region()
        self._build(jit, solver_options or {})

    # -- construction -------------------------------------------------------------------
    def _trust_region(self) -> np.ndarray:
        """Bounds on the scaled stage states (deviation from x_0): far outside any physical
        move within the 15 s horizon, they keep the (real-time) SQP's trial points where the
        model is defined and the RK4 step is stable (no effect at the solution)."""
        em, m = self.em, self.model
        phys = np.full(self.nd, np.inf)
        phys[0], phys[1], phys[2] = 40.0, 2.0, 100.0                  # m, m/s, m s
        for i in range(1, em.n + 1):
            phys[em.pressure(i)] = 2.0e7                                # 200 bar
            if i > 1:
                phys[em.flow(i)] = 0.05                                 # 3000 L/min
        phys[em.string_flow] = 0.05
        phys[em.string_pressure] = 2.0e7
        for index, value in ((m.block, 40.0), (m.bpp, 0.05), (m.pump, 3.0e7)):
            if index is not None:
                phys[index] = value
        box = np.full(self.ns, np.inf)
        box[:self.nd] = phys / self.Sx
        return box

    def _stage_slacks(self, k: int) -> tuple[str, ...]:
        names = []
        if 1 <= k < self.N or (k == self.N and self.terminal_constraints):
            names += ["velocity", "bhp_band", "choke_dp_band", "string_pressure"]
        if k < self.N:
            names.append("choke_capacity")
        return tuple(names)

    def _build(self, jit: bool, solver_options: dict) -> None:
        em, cfg, N, Nc, nd = self.em, self.cfg, self.N, self.Nc, self.nd
        w_y = np.array(cfg.output_weight.as_tuple(), dtype=float)
        r_c = self.inputs["move_weight"]
        r_r = self.inputs["reference_weight"]
        q_e = cfg.integral_weight_factor * w_y[list(_INTEGRAL_OUTPUTS)]
        t_w = {"velocity": cfg.slack_weight_velocity, "bhp_band": cfg.slack_weight_bhp,
               "choke_dp_band": cfg.slack_weight_choke_dp,
               "string_pressure": cfg.slack_weight_string_pressure,
               "choke_capacity": cfg.slack_weight_choke_capacity}

        # parameters: x_0, par (theta, d), pump_on, u_{-1}, e_0, y_ref (N x 3, stages 1..N),
        # y_sp, u_ref, BHP bias
        P = ca.MX.sym("p", nd + self.npar + 1 + 4 + self.nw + self.ne + 3 * N + 3 + 4 + 1)
        off = 0
        x0 = P[off:off + nd]; off += nd
        par = P[off:off + self.npar]; off += self.npar
        pump_on = P[off]; off += 1
        u_prev = P[off:off + 4]; off += 4
        w0 = P[off:off + self.nw]; off += self.nw
        e0 = P[off:off + self.ne]; off += self.ne
        y_ref = ca.reshape(P[off:off + 3 * N], 3, N); off += 3 * N
        y_sp = P[off:off + 3]; off += 3
        u_ref = P[off:off + 4]; off += 4
        bhp_bias = P[off]; off += 1
        self.np_ = off
        Sx = ca.DM(self.Sx)
        Su = ca.DM(self.Su)

        z_parts, g_parts = [], []
        lbg, ubg, equality = [], [], []
        nz = 0
        ng = 0
        stages: list[_Stage] = []
        f = 0
        nx_list, nu_list, ng_list = [], [], []

        def new_var(name, n):
            nonlocal nz
            v = ca.MX.sym(name, n)
            z_parts.append(v)
            sl = slice(nz, nz + n)
            nz += n
            return v, sl

        def add_rows(expr, lo, hi, eq=False):
            nonlocal ng
            n = expr.numel()
            g_parts.append(expr)
            lbg.extend([lo] * n if np.isscalar(lo) else list(lo))
            ubg.extend([hi] * n if np.isscalar(hi) else list(hi))
            equality.extend([eq] * n)
            idx = list(range(ng, ng + n))
            ng += n
            return idx

        # stage variables
        s_vars, u_vars, xi_vars = [], [], []
        for k in range(N + 1):
            if k == 0:
                s, s_sl = None, slice(nz, nz)
            else:
                s, s_sl = new_var(f"s{k}", self.ns)
            u, u_sl = (new_var(f"u{k}", 4) if k < Nc else (None, None))
            slack_names = self._stage_slacks(k)
            xi, xi_sl = new_var(f"xi{k}", len(slack_names))
            s_vars.append(s)
            u_vars.append(u)
            xi_vars.append(xi)
            stages.append(_Stage(s_sl, u_sl, {n: xi_sl.start + i for i, n in enumerate(slack_names)},
                                 None, {}))
            nx_list.append(0 if k == 0 else self.ns)
            nu_list.append((4 if k < Nc else 0) + len(slack_names))
        self.nz = nz

        # stage constraints: gap first, then the path rows of that stage
        for k in range(N + 1):
            st = stages[k]
            if k == 0:
                xs = ca.MX.zeros(nd)
                up = ca.MX.zeros(4)
                w = w0
                e = e0
            else:
                sk = s_vars[k]
                xs, up = sk[:nd], sk[nd:nd + 4]
                w, e = sk[nd + 4:nd + 4 + self.nw], sk[nd + 4 + self.nw:]
            x_phys = x0 + Sx * xs
            xi = xi_vars[k]
            names = self._stage_slacks(k)
            slack = {n: xi[i] for i, n in enumerate(names)}
            u_scaled = u_vars[k] if k < Nc else up
            u_phys = u_prev + Su * u_scaled
            xl = self.model.full(x_phys, par)
            y = outputs(em, xl)
            if k >= 1:
                y[2] = y[2] + bhp_bias        # the model's BHP offset, learnt from its errors
            row_start = ng
            if k < N:
                x_next = self.F(x_phys, u_phys, par, pump_on)
                s_next = [(x_next - x0) / Sx, u_scaled]
                if self.nw:
                    s_next.append(up[0])
                if self.ne:
                    err = ca.vertcat(*[(y[i] - y_sp[i]) / self.y_span[i] for i in _INTEGRAL_OUTPUTS])
                    s_next.append(e + self.ts * err)
                gap = s_vars[k + 1] - ca.vertcat(*s_next)
                st.gap = slice(ng, ng + self.ns)
                add_rows(gap, 0.0, 0.0, eq=True)
            # path rows
            if k < Nc:
                st.rows["slew"] = add_rows(u_vars[k] - up, -1.0, 1.0)
                if self.nw:       # change of the block-reference speed per sample
                    limit = self.accel * self.ts ** 2 / self.Su[0]
                    st.rows["acceleration"] = add_rows((u_vars[k][0] - up[0]) - (up[0] - w[0]),
                                                       -limit, limit)
            if "choke_capacity" in slack:
                cap = (choke_capacity(em, y[1]) - self.model.choke_flow(x_phys, u_phys)) \
                    / SLACK_UNITS["choke_capacity"]
                st.rows["choke_capacity"] = add_rows(cap + slack["choke_capacity"], 0.0, _INF)
            if "velocity" in slack:
                v = x_phys[1] / SLACK_UNITS["velocity"]
                st.rows["velocity"] = add_rows(ca.vertcat(v + slack["velocity"], v - slack["velocity"]),
                                               [-_INF, -_INF], [_INF, _INF])
            if "bhp_band" in slack:
                b = y[2] / SLACK_UNITS["bhp_band"]
                st.rows["bhp_band"] = add_rows(ca.vertcat(b + slack["bhp_band"], b - slack["bhp_band"]),
                                               [-_INF, -_INF], [_INF, _INF])
            if "choke_dp_band" in slack:
                d = y[1] / SLACK_UNITS["choke_dp_band"]
                st.rows["choke_dp_band"] = add_rows(
                    ca.vertcat(d + slack["choke_dp_band"], d - slack["choke_dp_band"]),
                    [-_INF, -_INF], [_INF, _INF])
            if "string_pressure" in slack:
                m = string_pressure_margin(em, xl) / SLACK_UNITS["string_pressure"]
                st.rows["string_pressure"] = add_rows(m + slack["string_pressure"], 0.0, _INF)
            ng_list.append(ng - row_start - (self.ns if k < N else 0))

            # cost
            if k >= 1:
                for i in range(3):
                    if w_y[i] > 0.0:
                        f = f + w_y[i] * ((y[i] - y_ref[i, k - 1]) / self.y_span[i]) ** 2
                for j in range(self.ne):
                    if q_e[j] > 0.0:
                        f = f + q_e[j] * e[j] ** 2
            if k < Nc:
                du = Su * (u_vars[k] - up)
                for i in range(4):
                    if r_c[i] > 0.0:
                        f = f + r_c[i] * (du[i] / self.u_span[i]) ** 2
                    if r_r[i] > 0.0:
                        f = f + r_r[i] * ((u_phys[i] - u_ref[i]) / self.u_span[i]) ** 2
            for n, xv in slack.items():
                f = f + t_w[n] * (xv ** 2 + xv)

        self.stages = stages
        self.ng = ng
        self.equality = equality
        self._lbg0 = np.array(lbg, dtype=float)
        self._ubg0 = np.array(ubg, dtype=float)
        z = ca.vertcat(*z_parts)
        g = ca.vertcat(*g_parts)
        self.structure = (nx_list, nu_list, ng_list)
        nlp = {"x": z, "p": P, "f": f, "g": g}
        self.nlp_functions = ca.Function("nlp", [z, P], [f, g])
        opts: dict = {}
        if self.hessian == "gauss-newton":
            # The cost is quadratic in z (outputs are linear in the states), so its Hessian
            # is exact and constant; the curvature of the dynamics is left out.
            lam_f = ca.MX.sym("lam_f")
            lam_g = ca.MX.sym("lam_g", g.numel())
            hess_f = ca.hessian(f, z)[0]
            opts["hess_lag"] = ca.Function("nlp_hess_l", [z, P, lam_f, lam_g],
                                           [ca.triu(lam_f * hess_f) if self.solver_name == "ipopt"
                                            else lam_f * hess_f],
                                           ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
        self.solver = self._make_solver(nlp, jit, {**opts, **solver_options})

    def _make_solver(self, nlp, jit: bool, extra: dict) -> ca.Function:
        name = self.solver_name
        opts: dict = {"error_on_fail": False}
        if jit:     # CasADi's own JIT (fatrop): compiled at every start, in the temp dir
            opts.update({"jit": True, "compiler": "shell",
                         "jit_options": {"flags": ["-O1"], "verbose": False,
                                         "directory": tempfile.gettempdir() + os.sep}})
        max_iter = self.cfg.max_iterations
        if name in _COMPILABLE:
            opts["expand"] = self.cfg.expand
        if name == "ipopt":
            opts["ipopt"] = {"print_level": 0, "sb": "yes", "max_iter": max_iter, "tol": 1e-6,
                             "acceptable_tol": 1e-4, "acceptable_iter": 5,
                             "warm_start_init_point": "yes", "warm_start_bound_push": 1e-6,
                             "warm_start_mult_bound_push": 1e-6, "mu_init": 1e-3,
                             "nlp_scaling_method": "none"}
            opts["print_time"] = False
        elif name == "fatrop":
            nx, nu, ngs = self.structure
            opts.update({"structure_detection": "manual", "N": self.N, "nx": nx, "nu": nu, "ng": ngs,
                         "equality": self.equality,
                         "fatrop": {"print_level": 0, "max_iter": max_iter, "tolerance": 1e-6,
                                    "mu_init": 1e-2},
                         "print_time": False})
        elif name == "sqpmethod":
            nx, nu, ngs = self.structure
            qp = extra.pop("qpsol", "hpipm")
            if qp == "hpipm":       # structure-exploiting interior-point QP (Riccati)
                qp_opts = {"N": self.N, "nx": nx, "nu": nu, "ng": ngs, "error_on_fail": False,
                           "hpipm": {"mode": "speed", "iter_max": 30, "res_g_max": 1e-6,
                                     "res_b_max": 1e-6, "res_d_max": 1e-6, "res_m_max": 1e-6}}
            elif qp == "qrqp":
                qp_opts = {"print_iter": False, "print_header": False, "error_on_fail": False}
            else:
                qp_opts = {"error_on_fail": False}
            opts.update({"qpsol": qp, "qpsol_options": qp_opts,
                         "max_iter": max_iter, "print_header": False, "print_iteration": False,
                         "print_status": False, "print_time": False,
                         "tol_pr": 1e-6, "tol_du": 1e-6})
            if self.hessian == "exact":
                opts["convexify_strategy"] = "eigen-clip"
        else:
            raise ValueError(f"unknown solver {name!r}")
        for key, value in extra.items():
            if isinstance(value, dict) and isinstance(opts.get(key), dict):
                opts[key] = {**opts[key], **value}
            else:
                opts[key] = value
        solver = ca.nlpsol("nmpc", name, nlp, opts)
        if self.compile and name in _COMPILABLE:
            # Compile the derivative oracles the plugin calls every iteration (cached on disk)
            # and hand them back as user functions of a new solver instance.
            for option, oracle in _COMPILABLE[name]:
                if option in opts:
                    continue
                opts[option] = compiled_function(solver.get_function(oracle), self.cache_dir)
            solver = ca.nlpsol("nmpc", name, nlp, opts)
        return solver

    # -- numeric data of one instance ---------------------------------------------------
    def parameters(self, x0, par, u_prev, e0, y_ref, y_sp, u_ref, pump_on: bool = True,
                   reference_speed: float = 0.0, bhp_bias_pa: float = 0.0) -> np.ndarray:
        """Parameter vector: prediction state x_0, par = [theta (, d)], pump_on, u_{-1},
        (u_r,-2 scaled from the last block-reference speed), e_0, y_ref[1..N], y_sp, u_ref,
        the BHP bias added to the predicted BHP of stages 1..N."""
        w0 = [-reference_speed * self.ts / self.Su[0]] * self.nw
        return np.concatenate([x0, par, [1.0 if pump_on else 0.0], u_prev, w0, np.asarray(e0, dtype=float).ravel()[:self.ne],
                               np.asarray(y_ref, dtype=float).ravel(), y_sp, u_ref, [bhp_bias_pa]])

    def bounds(self, u_prev, velocity_limit, bhp_band, dp_band, string_pressure: bool,
               relaxed: bool = False, block_range: tuple | None = None):
        """Variable and row bounds: hard input limits (the block reference also within
        ``block_range``), slew, soft-constraint levels."""
        cfg = self.cfg
        lbz = np.full(self.nz, -_INF)
        ubz = np.full(self.nz, _INF)
        lo = self.inputs["min"].copy()
        hi = self.inputs["max"].copy()
        if block_range is not None:
            lo[0], hi[0] = max(lo[0], block_range[0]), min(hi[0], block_range[1])
        u_lo = (lo - u_prev) / self.Su
        u_hi = (hi - u_prev) / self.Su
        lbg, ubg = self._lbg0.copy(), self._ubg0.copy()
        levels = {"velocity": (-velocity_limit, velocity_limit), "bhp_band": bhp_band,
                  "choke_dp_band": dp_band}
        for st in self.stages:
            if st.s.stop > st.s.start:         # trust region on the predicted states
                box = self._state_box
                lbz[st.s], ubz[st.s] = -box, box
            if st.u is not None:
                lbz[st.u], ubz[st.u] = u_lo, u_hi
            for idx in st.slack.values():
                lbz[idx] = 0.0
            for name, rows in st.rows.items():
                if relaxed and name in RELAXED_DROPS:
                    lbg[rows], ubg[rows] = -_INF, _INF
                elif name in levels:
                    lo, hi = levels[name]
                    lbg[rows[0]] = lo / SLACK_UNITS[name]
                    ubg[rows[1]] = hi / SLACK_UNITS[name]
                elif name == "string_pressure" and not string_pressure:
                    lbg[rows], ubg[rows] = -_INF, _INF
        return lbz, ubz, lbg, ubg

    def pack(self, x0, u_prev, X, U, E, slacks, reference_speed: float = 0.0) -> np.ndarray:
        """Decision vector from physical trajectories X[(N+1) x nd], U[N x 4], E[(N+1) x ne]."""
        z = np.zeros(self.nz)
        for k, st in enumerate(self.stages):
            if k >= 1:
                s = [(X[k] - x0) / self.Sx, (U[k - 1] - u_prev) / self.Su]
                if self.nw:
                    before = U[k - 2, 0] if k >= 2 else u_prev[0] - reference_speed * self.ts
                    s.append([(before - u_prev[0]) / self.Su[0]])
                if self.ne:
                    s.append(E[k])
                z[st.s] = np.concatenate(s)
            if st.u is not None:
                z[st.u] = (U[k] - u_prev) / self.Su
            for name, idx in st.slack.items():
                z[idx] = slacks.get(name, np.zeros(self.N + 1))[k]
        return z

    def unpack(self, z, x0, u_prev, e0):
        """Physical trajectories (X, U, E, slacks in scaled units per stage) from z."""
        N, nd = self.N, self.nd
        X = np.zeros((N + 1, nd))
        U = np.zeros((N, 4))
        E = np.zeros((N + 1, self.ne))
        X[0] = x0
        if self.ne:
            E[0] = e0
        slacks = {n: np.zeros(N + 1) for n in SLACK_NAMES}
        for k, st in enumerate(self.stages):
            if k >= 1:
                s = z[st.s]
                X[k] = x0 + self.Sx * s[:nd]
                if self.ne:
                    E[k] = s[nd + 4 + self.nw:]
            if k < N:
                U[k] = u_prev + self.Su * z[st.u] if st.u is not None else U[k - 1]
            for name, idx in st.slack.items():
                slacks[name][k] = z[idx]
        return X, U, E, slacks

    def simulate(self, x0, par, U, pump_on: bool = True) -> np.ndarray:
        """Prediction-state trajectory from x0 under the inputs U[N x 4] (initial guesses)."""
        X = np.zeros((self.N + 1, self.nd))
        X[0] = x0
        for k in range(self.N):
            X[k + 1] = np.array(self.F(X[k], U[k], par, 1.0 if pump_on else 0.0)).ravel()
        return X

    def shift_multipliers(self, lam_z, lam_g):
        """Multipliers of the previous solution moved one stage earlier (stage k <- k+1)."""
        new_z = np.zeros(self.nz)
        new_g = np.zeros(self.ng)
        for k in range(self.N + 1):
            st = self.stages[k]
            src = self.stages[min(k + 1, self.N)]
            if st.gap is not None and src.gap is not None:
                new_g[st.gap] = lam_g[src.gap]
            for name, rows in st.rows.items():
                if name in src.rows and len(src.rows[name]) == len(rows):
                    new_g[rows] = lam_g[src.rows[name]]
            if st.u is not None and src.u is not None:
                new_z[st.u] = lam_z[src.u]
            for name, idx in st.slack.items():
                if name in src.slack:
                    new_z[idx] = lam_z[src.slack[name]]
        return new_z, new_g

    def assess(self, sol: dict, lbz, ubz, lbg, ubg) -> tuple[bool, bool, str]:
        """(usable, converged, why not) for a solver answer: converged, or an
        iteration-limited iterate meeting the linear hard constraints and (roughly) the
        dynamics."""
        status = str(sol["stats"].get("return_status", ""))
        if "z" not in sol or not np.all(np.isfinite(sol["z"])) or not np.all(np.isfinite(sol["g"])):
            return False, False, f"{status}: non-finite iterate"
        stats = sol["stats"]
        if _succeeded(stats):
            return True, True, ""
        if status not in _ITERATION_LIMIT:
            return False, False, status
        z, g = sol["z"], sol["g"]
        excess = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
        bound = float(np.max(np.maximum(np.maximum(lbz - z, z - ubz), 0.0), initial=0.0))
        slew = max((float(np.max(excess[st.rows[name]])) for st in self.stages
                    for name in ("slew", "acceleration") if name in st.rows), default=0.0)
        gap = max((float(np.max(excess[st.gap])) for st in self.stages if st.gap is not None),
                  default=0.0)
        ok = max(bound, slew) <= LINEAR_TOLERANCE and gap <= GAP_TOLERANCE
        return ok, False, "" if ok else f"{status}: bounds {bound:.2g}, slew {slew:.2g}, gap {gap:.2g}"

    def solve(self, p, z0, lbz, ubz, lbg, ubg, lam_z0=None, lam_g0=None) -> dict:
        args = {"x0": z0, "p": p, "lbx": lbz, "ubx": ubz, "lbg": lbg, "ubg": ubg}
        if lam_z0 is not None:
            args["lam_x0"] = lam_z0
        if lam_g0 is not None:
            args["lam_g0"] = lam_g0
        sol = self.solver(**args)
        try:
            stats = dict(self.solver.stats())
        except RuntimeError:          # sqpmethod: stats of a QP failure can be unreadable
            stats = {"success": False, "return_status": "stats_unavailable", "iter_count": -1}
        out = {"z": np.array(sol["x"]).ravel(), "lam_z": np.array(sol["lam_x"]).ravel(),
               "lam_g": np.array(sol["lam_g"]).ravel(), "f": float(sol["f"]),
               "g": np.array(sol["g"]).ravel(), "stats": stats}
        return out


# ----------------------------------------------------------------------------- supervisor
_SUCCESS_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


_ITERATION_LIMIT = ("Maximum_Iterations_Exceeded", "SOLVER_RET_LIMITED")
# An iteration-limited iterate is still used (real-time iteration) when it meets the
# linear hard constraints (input bounds, slew rows) to LINEAR_TOLERANCE (the QP's accuracy;
# the command is then clipped exactly, Supervisor.limit) and the dynamics (gap rows) to
# GAP_TOLERANCE, both in the OCP's scaled units (S_u: one slew step; S_x: 1 bar, 10 L/s, ...).
LINEAR_TOLERANCE = 5.0e-2
GAP_TOLERANCE = 5.0


def _succeeded(stats: dict) -> bool:
    if stats.get("success"):
        return True
    return str(stats.get("return_status", "")) in _SUCCESS_STATUSES


class Supervisor:
    """NMPC supervisor: one solve per sample with warm start and the fallback policy.

    ``config`` is the rig configuration (its ``nmpc`` section, and the drawworks lag from
    ``actuators``) or just the ``nmpc`` section (no drawworks lag then); ``em`` is the
    shared estimation model. ``step`` takes the estimate x_hat (SI, the estimator's state
    layout; NMPC2 reads the bottom influx d from it unless ``disturbance`` is given), the
    setpoints in force and the previously applied input u_{-1}; it returns a
    :class:`SolveResult` whose ``u`` is always finite, inside the input bounds and within
    the slew limits of u_{-1}.
    """

    def __init__(self, config, em: EstimationModel, *, configuration: str | None = None,
                 solver: str | None = None, hessian: str | None = None, jit: bool | None = None,
                 substeps: int | None = None, integrator: str | None = None,
                 solver_options: dict | None = None, actuator_lags: bool | None = None,
                 cache_dir: str | None = None):
        rig = config if isinstance(config, RigConfig) else None
        cfg: Nmpc = rig.nmpc if rig is not None else config
        self.cfg = cfg
        solver = solver or cfg.solver
        if hessian is None:
            hessian = "exact" if solver == "fatrop" else cfg.hessian
        use_lags = cfg.actuator_lags_in_model if actuator_lags is None else actuator_lags
        lags = ActuatorLags.from_config(rig) if (use_lags and rig) else None
        # the process protection limits the change of the block-reference speed: plan within it
        accel = rig.protection.trip_acceleration_max_mps2 if rig is not None else None
        self.acceleration = accel
        jit = cfg.jit if jit is None else jit
        cached = solver in _COMPILABLE     # compile our own, cached; fatrop: CasADi's JIT
        self.problem = NmpcProblem(cfg, em, configuration=configuration, solver=solver,
                                   jit=jit and not cached, compile=jit and cached,
                                   cache_dir=cache_dir, substeps=substeps, integrator=integrator,
                                   solver_options=solver_options, hessian=hessian,
                                   lags=lags, acceleration_limit_mps2=accel)
        self.em = self.problem.em
        self.model = self.problem.model
        self.configuration = self.problem.configuration
        self.u_min = self.problem.inputs["min"]
        self.u_max = self.problem.inputs["max"]
        self.slew = self.problem.inputs["slew"]
        self.alpha = np.array(cfg.reference_smoothing.as_tuple(), dtype=float)
        self.fallback_count = 0
        self.solve_count = 0
        self.bhp_ref_default: float | None = None   # BHP of the first estimate (NaN setpoint)
        self.spp_nominal: float | None = None       # input reference of the pump pressure
        self.integral = np.zeros(self.problem.ne)
        self._warm: dict | None = None
        self._next_actuators: tuple | None = None   # (predicted actuator outputs, command)
        self._applied: np.ndarray | None = None      # u_{-1} of the previous step (u_{-2})
        self._speed = 0.0                            # block-reference speed of the last period
        self.theta_clamps = 0                        # estimates whose theta had to be capped
        self._trip: tuple[float, float] | None = None  # (block target m, furthest string position on the way m)
        self._profile: MotionProfile | None = None     # block reference's motion profile (block_reference profile)
        self.bhp_bias = 0.0                            # model's BHP offset (bhp_bias_gain > 0) [Pa]
        self.choke_flow_m3s = math.nan                 # the last solve's choke flow (held with its input)
        self._predicted_bhp: float | None = None       # the last solve's BHP prediction for now [Pa]

    # -- helpers ------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget warm start and integral state (e.g. after a hand-back to manual)."""
        self._warm = None
        self._next_actuators = None
        self._applied = None
        self.integral = np.zeros(self.problem.ne)
        self._trip = None
        self._profile = None
        self.bhp_bias = 0.0
        self._predicted_bhp = None

    def safe_input(self, u_prev) -> np.ndarray:
        """u_{-1} made finite and clipped into the input bounds."""
        u = np.asarray(u_prev, dtype=float).ravel()[:4].copy()
        bad = ~np.isfinite(u)
        u[bad] = np.clip(0.0, self.u_min, self.u_max)[bad]
        return np.clip(u, self.u_min, self.u_max)

    def limit(self, u, u_prev, reference_speed: float = 0.0) -> np.ndarray:
        """Clip a command into the slew (and block-reference acceleration) limits around
        u_prev and the bounds; assert finite."""
        u = np.where(np.isfinite(u), u, u_prev)
        lo, hi = u_prev - self.slew, u_prev + self.slew
        if self.acceleration:
            step = self.acceleration * self.problem.ts ** 2
            lo[0] = max(lo[0], u_prev[0] + reference_speed * self.problem.ts - step)
            hi[0] = min(hi[0], u_prev[0] + reference_speed * self.problem.ts + step)
        u = np.clip(u, lo, hi)
        u = np.clip(u, self.u_min, self.u_max)
        assert np.all(np.isfinite(u)), "NMPC command is not finite"
        return u

    def setpoint_vector(self, x_full, setpoints: ActiveSetpoints) -> np.ndarray:
        """y_sp = [block target, choke dp ref, BHP ref] (NaN BHP: the first estimate's BHP)."""
        bhp = setpoints.bhp_ref_pa
        if not math.isfinite(bhp):
            if self.bhp_ref_default is None:
                self.bhp_ref_default = float(outputs(self.em, x_full)[2])
            bhp = self.bhp_ref_default
        return np.array([setpoints.block_position_target_m, setpoints.choke_dp_ref_pa, bhp])

    def levels(self, setpoints: ActiveSetpoints, y_sp):
        """Soft-constraint levels: velocity limit, BHP band, choke dp band (SI)."""
        cfg = self.cfg
        vlim = cfg.velocity_limit_mps
        if math.isfinite(setpoints.trip_speed_limit_mps) and setpoints.trip_speed_limit_mps > 0.0:
            vlim = min(vlim, setpoints.trip_speed_limit_mps)
        band = setpoints.bhp_band_pa if (math.isfinite(setpoints.bhp_band_pa)
                                         and setpoints.bhp_band_pa > 0.0) else cfg.bhp_band_pa
        if not (math.isfinite(setpoints.choke_dp_band_pa) and setpoints.choke_dp_band_pa > 0.0):
            setpoints = dataclasses.replace(setpoints, choke_dp_band_pa=cfg.choke_dp_band_pa)
        dp_limits = dataclasses.replace(setpoints, choke_dp_ref_pa=float(y_sp[1])) \
            .choke_dp_limits(cfg.choke_dp_min_pa)
        return vlim, (y_sp[2] - band, y_sp[2] + band), dp_limits

    def _clamp_friction(self, x, par) -> str:
        """Cap the friction parameters theta_i (in ``par``) where the annular flow mode
        d(q_i)/dt = -(theta_i dF_i/dq_i / M_i) q_i + ... becomes too stiff for the
        prediction's RK4 step h (|lambda| h <= 2, inside RK4's stability region): an
        estimate several times the circulating value would make the prediction diverge.
        dF_i/dq_i is the law's bound (em.friction_flow_gain_bound: 2|v_e|/A_i for the
        quadratic law). Returns a note when it acted."""
        em, g = self.em, self.em.wm.geometry
        h = self.problem.ts / self.problem.substeps
        gain = friction_flow_gain_bound(em, x, THETA_SPEED_FLOOR_MPS)
        notes = []
        for k, i in enumerate(range(2, em.n + 1)):
            limit = THETA_STIFFNESS_LIMIT / h * g.annulus_inertance_kg_m4[k] / gain[k]
            if par[k] > limit:
                notes.append(f"theta_{i} {par[k]:.3g} -> {limit:.3g}")
                par[k] = limit
        if notes:
            self.theta_clamps += 1
            return "friction parameter capped for a stable prediction: " + ", ".join(notes)
        return ""

    def block_range(self, x, u_prev, target: float) -> tuple[float, float]:
        """The trip corridor is monotone: the block reference stays between the furthest
        point the string has reached on its way to the target and the target (each +- a
        small margin) -- the block is not a BHP actuator beyond the trip plan (a wrong
        friction estimate otherwise makes the model see BHP gains in overshooting or
        backing up), and the corridor cannot ratchet along with an overshooting string.
        A new target starts a new corridor at the string's position. Where the
        acceleration limit cannot stop the reference in time, the hardest braking step
        stays allowed (no infeasible bounds)."""
        target, position = float(target), float(x[0])
        if self._trip is None or self._trip[0] != target:
            self._trip = (target, position)
        direction = np.sign(target - self._trip[1])
        progress = self._trip[1]
        if direction * (position - progress) > 0.0 and direction * (target - position) > 0.0:
            progress = position                      # further along, not past the target
        elif direction * (position - target) >= 0.0:
            progress = target
        self._trip = (target, progress)
        lo = min(progress, target) - TRIP_RANGE_MARGIN_M
        hi = max(progress, target) + TRIP_RANGE_MARGIN_M
        ts = self.problem.ts
        if self.acceleration:
            coast = float(u_prev[0]) + self._speed * ts
            step = self.acceleration * ts ** 2
            lo, hi = min(lo, coast + step), max(hi, coast - step)
        else:
            lo, hi = min(lo, float(u_prev[0])), max(hi, float(u_prev[0]))
        return lo, hi

    def block_profile(self, position_m: float, target_m: float, speed_mps: float) -> np.ndarray:
        """Block-position reference over the horizon (block_reference profile): the trip's
        motion profile (drill_nmpc.motion_profile) toward the target at the speed limit and
        the protection's acceleration, stepped once per sample from where the string was
        when the supervisor started."""
        if self._profile is None:
            self._profile = MotionProfile(position_m)
        accel = self.acceleration or math.inf
        self._profile.step(target_m, speed_mps, accel, self.problem.ts)
        return np.array([s.position_m for s in self._profile.ahead(
            target_m, speed_mps, accel, self.problem.ts, self.problem.N)])

    def _initial_guess(self, x0, par, u_prev, pump_on=True):
        """Cold start: inputs held at u_{-1}, states simulated, slacks and multipliers zero."""
        pb = self.problem
        U = np.tile(u_prev, (pb.N, 1))
        X = pb.simulate(x0, par, U, pump_on)
        if not np.all(np.isfinite(X)):
            X = np.tile(x0, (pb.N + 1, 1))
        E = np.tile(self.integral, (pb.N + 1, 1)) if pb.ne else None
        return pb.pack(x0, u_prev, X, U, E, {}, self._speed), None, None

    def _shifted_guess(self, x0, par, u_prev):
        """Previous solution shifted one sample (primal and multipliers), re-expressed
        around the new x_0 and u_{-1}."""
        pb, w = self.problem, self._warm
        X = np.vstack([w["X"][1:], w["X"][-1:]])
        X[0] = x0
        U = np.vstack([w["U"][1:], w["U"][-1:]])
        E = None
        if pb.ne:
            E = np.vstack([w["E"][1:], w["E"][-1:]])
            E[0] = self.integral
        slacks = {n: np.concatenate([v[1:], v[-1:]]) for n, v in w["slacks"].items()}
        z = pb.pack(x0, u_prev, X, U, E, slacks, self._speed)
        lam_z, lam_g = pb.shift_multipliers(w["lam_z"], w["lam_g"])
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(lam_z)) and np.all(np.isfinite(lam_g))):
            return self._initial_guess(x0, par, u_prev)
        return z, lam_z, lam_g

    # -- one sample ---------------------------------------------------------------------
    def step(self, x_hat, setpoints: ActiveSetpoints, u_prev, disturbance=None,
             actuators: dict | None = None) -> SolveResult:
        """Solve the OCP at estimate ``x_hat`` and return the command to apply from now.

        ``actuators`` holds measured actuator outputs (keys ACTUATOR_KEYS: block position,
        back-pressure pump flow, stand-pipe pressure, e.g. from /actuators/<name>/frame), the
        initial states of the modelled actuator lags; a missing one is carried over from the
        previous prediction when the last command was applied, else estimated
        (PredictionModel.initial_state).
        """
        t0 = time.perf_counter()
        pb, em = self.problem, self.em
        u_prev = self.safe_input(u_prev)
        # block-reference speed of the last period, from the two inputs applied last
        self._speed = 0.0 if self._applied is None else \
            float(u_prev[0] - self._applied[0]) / pb.ts
        self._applied = u_prev.copy()
        x = full_state(em, x_hat, disturbance)
        self.solve_count += 1
        if not np.all(np.isfinite(x)):
            return self._hold(u_prev, "invalid_estimate", t0)
        if self.spp_nominal is None:
            self.spp_nominal = float(u_prev[3])
        pump_on = bool(setpoints.mud_pump_on)
        known = {}
        if self._next_actuators is not None and np.allclose(u_prev, self._next_actuators[1]):
            known.update(self._next_actuators[0])
        known.update({k: v for k, v in (actuators or {}).items() if v is not None})
        self._next_actuators = None
        x0 = self.model.initial_state(x, u_prev, known, pump_on)
        par = x[self.model.nd_model:].copy()
        clamped = self._clamp_friction(x, par)
        y_now = np.array([float(v) for v in outputs(em, x)])
        y_sp = self.setpoint_vector(x, setpoints)
        # reference trajectory (59), anchored at the estimated output
        y_ref = np.array([self.alpha ** j * y_now + (1.0 - self.alpha ** j) * y_sp
                          for j in range(pb.N + 1)])
        vlim, bhp_band, dp_band = self.levels(setpoints, y_sp)
        if self.cfg.block_reference == "profile":
            y_ref[:, 0] = self.block_profile(float(x[0]), float(y_sp[0]), vlim)
        if pb.ne:
            # NMPC1: integrate the estimated error *outside the band* (the part the model
            # failed to prevent): riding the band edge on purpose does not wind it up, a
            # persistent model bias does; clamped.
            bands = {1: dp_band, 2: bhp_band}
            err = np.array([(y_now[i] - min(max(y_now[i], bands[i][0]), bands[i][1]))
                            / pb.y_span[i] for i in _INTEGRAL_OUTPUTS])
            self.integral = np.clip(self.integral + pb.ts * err, -self.cfg.integral_limit_s,
                                    self.cfg.integral_limit_s)
        u_ref = np.array([y_sp[0], u_prev[1], 0.0, self.spp_nominal])
        if self._predicted_bhp is not None:
            # offset-free: integrate the error of the last one-step BHP prediction
            error = y_now[2] - self._predicted_bhp
            limit = self.cfg.bhp_bias_limit_pa
            self.bhp_bias = float(np.clip(self.bhp_bias + self.cfg.bhp_bias_gain * error,
                                          -limit, limit))
        self._predicted_bhp = None
        p = pb.parameters(x0, par, u_prev, self.integral, y_ref[1:], y_sp, u_ref, pump_on,
                          self._speed, self.bhp_bias)
        circulating = pump_on

        last = None
        reasons: list[str] = []
        for relaxed in (False, True):
            if relaxed or self._warm is None:
                z0, lam_z0, lam_g0 = self._initial_guess(x0, par, u_prev, pump_on)
            else:
                z0, lam_z0, lam_g0 = self._shifted_guess(x0, par, u_prev)
            lbz, ubz, lbg, ubg = pb.bounds(u_prev, vlim, bhp_band, dp_band, circulating, relaxed,
                                           self.block_range(x, u_prev, y_sp[0]))
            try:
                sol = pb.solve(p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0)
            except RuntimeError as err:       # evaluation error inside the solver
                sol = {"stats": {"success": False, "return_status": f"error: {err}"[:120],
                                 "iter_count": -1}}
            last = sol
            usable, converged, why = pb.assess(sol, lbz, ubz, lbg, ubg)
            if not usable:
                reasons.append(why)
                continue
            X, U, E, slacks = pb.unpack(sol["z"], x0, u_prev, self.integral)
            if not (np.all(np.isfinite(U)) and np.all(np.isfinite(X))):
                continue
            if relaxed:
                self._warm = None
                self.fallback_count += 1
            else:
                self._warm = {"X": X, "U": U, "E": E, "slacks": slacks,
                              "lam_z": sol["lam_z"], "lam_g": sol["lam_g"]}
            u = self.limit(U[0], u_prev, self._speed)
            U[0] = u
            lagged = self.model.nd > self.model.nd_model
            if lagged or self.cfg.bhp_bias_gain > 0.0:      # the plant one sample ahead under u
                x1 = np.asarray(pb.F(x0, u, par, 1.0 if pump_on else 0.0), dtype=float).ravel()
                if lagged:
                    self._next_actuators = (self.model.actuator_state(x1), u.copy())
                if self.cfg.bhp_bias_gain > 0.0:
                    self._predicted_bhp = float(outputs(em, self.model.full(x1, par))[2]) \
                        + self.bhp_bias
            result = self._result(u, "relaxed" if relaxed else "none", sol, t0, par, X, U, slacks,
                                  y_ref, converged)
            self.choke_flow_m3s = result.choke_flow_m3s = float(self.model.choke_flow(x0, u))
            if clamped:
                result.status = f"{result.status}; {clamped}"
            if relaxed:
                result.status = f"{result.status}; first attempt: {reasons[0]}"
            return result
        self._warm = None
        return self._hold(u_prev, "; ".join(reasons) or "failed", t0,
                          iterations=int(last["stats"].get("iter_count", -1)))

    def hold(self, u_prev, status: str) -> SolveResult:
        """Hold the last input (e.g. the estimate was unusable); counted as a fallback."""
        self._warm = None
        self._applied = None
        return self._hold(self.safe_input(u_prev), status, time.perf_counter())

    def _hold(self, u_prev, status: str, t0: float, iterations: int = -1) -> SolveResult:
        self.fallback_count += 1
        u = u_prev.copy()
        if self.acceleration and self._speed:      # brake the block reference, within the limit
            v = math.copysign(max(abs(self._speed) - self.acceleration * self.problem.ts, 0.0),
                              self._speed)
            u[0] = u_prev[0] + v * self.problem.ts
        u = self.limit(u, u_prev, self._speed)
        return SolveResult(u=u, success=False, fallback="hold", status=status, iterations=iterations,
                           solve_time_s=time.perf_counter() - t0, cost=float("nan"),
                           slacks={n: float("nan") for n in SLACK_NAMES},
                           planned_inputs=np.tile(u, (self.problem.N, 1)),
                           integral=self.integral.copy(), configuration=self.configuration,
                           choke_flow_m3s=self.choke_flow_m3s)

    def _result(self, u, fallback, sol, t0, par, X, U, slacks, y_ref, converged) -> SolveResult:
        pb, em, model = self.problem, self.em, self.model
        rows = [model.full(row, par) for row in X]
        Y = np.array([[float(v) for v in outputs(em, r)] for r in rows])
        predicted = {"block_position_m": Y[:, 0], "choke_dp_pa": Y[:, 1], "bhp_pa": Y[:, 2],
                     "string_velocity_mps": X[:, 1].copy(),
                     "string_pressure_margin_pa": np.array([float(string_pressure_margin(em, r))
                                                            for r in rows])}
        for key, index in zip(ACTUATOR_KEYS, (model.block, model.bpp, model.pump)):
            if index is not None:
                predicted[key] = X[:, index].copy()
        slack_si = {n: float(np.max(v)) * SLACK_UNITS[n] for n, v in slacks.items()}
        stats = sol["stats"]
        status = str(stats.get("return_status", ""))
        return SolveResult(u=u, success=True, fallback=fallback,
                           status=status if converged else f"{status} (feasible iterate used)",
                           iterations=int(stats.get("iter_count", -1)),
                           solve_time_s=time.perf_counter() - t0, cost=float(sol["f"]),
                           slacks=slack_si, predicted_time_s=pb.ts * np.arange(pb.N + 1),
                           predicted=predicted, planned_inputs=U.copy(), reference=y_ref,
                           integral=self.integral.copy(), configuration=self.configuration)
