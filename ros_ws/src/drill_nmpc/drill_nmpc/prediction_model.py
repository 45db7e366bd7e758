"""The NMPC's prediction model: the shared estimation model plus the actuator lags.

The drift is ``drill_core.estimation_model.drift`` (the equations the UKF runs) with the
friction parameters theta (and, for NMPC2, the bottom influx d) frozen over the horizon;
around it the lags of the drawworks, back-pressure pump and mud pump, and the choke's
pressure loop as a first-order lag. ``PredictionModel.function`` is the one-sample map the
transcription shoots with (RK4, inputs held) and its explicit Jacobian. Plain module (no
rclpy); docs/nmpc.md section 1 has the derivation.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI, NUMPY, table
from drill_core.block_control import (block_command, integral_for_command, integral_rate,
                                       reference_for_command)
from drill_core.config import RigConfig
from drill_core.estimation_model import (EstimationModel, NominalFriction, build_estimation_model,
                                         drift, measurement)
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE, U_SIZE
from drill_core.integrators import WithSensitivity, euler_step, rk4_step
from drill_core.state_layout import StateLayout
from drill_core.table_tape import drift_with_jacobian

OUTPUT_NAMES = ("block_position_m", "choke_dp_pa", "bhp_pa")


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
        self.grid = grid                  # the table's sample points [m^3/s]
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
        relative_flow_m3s = string_flow_m3s + self.area * string_velocity_mps
        return self.scale * table(xp, self.spline, relative_flow_m3s, self.grid)


@dataclass(frozen=True)
class ActuatorLags:
    """First-order lags of the actuators between the NMPC's commands and the process
    (docs/design.md §4); None leaves that input instantaneous in the prediction."""
    drawworks_s: float | None = None      # block position (lags the block controller output)
    bpp_s: float | None = None            # back-pressure pump flow
    pump_s: float | None = None           # stand-pipe pressure

    @classmethod
    def from_config(cls, config: RigConfig) -> "ActuatorLags":
        a = config.actuators
        return cls(a.drawworks.time_constant_s, a.bpp.time_constant_s, a.mud_pump.time_constant_s)


# the measured actuator outputs, each by the actuator whose frame's last output it is
FRAME_OUTPUTS = {"drawworks": "block_m", "bpp": "bpp_flow_m3s", "mud_pump": "spp_pa"}
ACTUATOR_KEYS = tuple(FRAME_OUTPUTS.values())    # block_m, bpp_flow_m3s, spp_pa


def frame_measurements(name: str, last_output: float, command: float | None = None,
                       reference: float | None = None) -> dict:
    """What actuator ``name``'s frame tells the NMPC (``Supervisor.step``'s ``actuators``):
    its output at the frame's end, and the drawworks' the block controller's command and
    reference behind it (None: not known)."""
    values = {FRAME_OUTPUTS[name]: float(last_output)}
    if name == "drawworks":
        values.update(block_command_m=command, block_reference_m=reference)
    return values


def measured_actuators(frames: Mapping) -> dict:
    """``frame_measurements`` of every actuator frame in ``frames`` (by actuator name;
    each with ``output``, ``command`` and ``reference``) that the NMPC reads."""
    out = {}
    for name, frame in frames.items():
        if name in FRAME_OUTPUTS:
            out.update(frame_measurements(name, frame.output[-1], frame.command,
                                          frame.reference))
    return out


# The lagged actuator outputs' state names, in the prediction state's order after the
# estimation model's evolving states, and the lag each needs.
LAGGED_OUTPUTS = (("drawworks_output_m", "drawworks_s"), ("bpp_flow_output_m3s", "bpp_s"),
                  ("spp_output_pa", "pump_s"))


@dataclass(frozen=True)
class PumpSwitchedFriction:
    """The prediction's nominal annular friction F_nom,i: the yield jump smoothed over
    ``circulating``'s velocity while the mud pump is planned on and over ``pump_off``'s
    (wider) one while it is off, where every annular flow is near zero and the real-time
    iteration's linearisation of the sharper jump failed (docs/nmpc.md). ``pump_on`` is 1
    or 0, or the prediction's CasADi symbol; evaluated with a number it is one law alone."""
    circulating: NominalFriction
    pump_off: NominalFriction
    pump_on: object = 1.0

    def at(self, pump_on) -> "PumpSwitchedFriction":
        """The same laws selected by ``pump_on``."""
        return dataclasses.replace(self, pump_on=pump_on)

    def _selected(self) -> NominalFriction | None:
        """The one law a numeric ``pump_on`` selects (None: a symbol, both in play)."""
        on = self.pump_on
        if isinstance(on, (int, float)):
            return self.circulating if on else self.pump_off
        return None

    def loss(self, xp, k: int, flow_m3s, string_velocity_mps):
        """F_nom of path k + 2 [Pa] (numpy rows or CasADi symbols)."""
        law = self._selected()
        if law is not None:
            return law.loss(xp, k, flow_m3s, string_velocity_mps)
        on = self.pump_on
        return on * self.circulating.loss(xp, k, flow_m3s, string_velocity_mps) \
            + (1.0 - on) * self.pump_off.loss(xp, k, flow_m3s, string_velocity_mps)

    def peak_gain_near(self, k: int, flow_m3s: float, half_width_m3s: float) -> float:
        """dF_nom/dq's bound (NominalFriction.peak_gain_near) of the law selected, the
        larger of the two where ``pump_on`` is a symbol."""
        law = self._selected()
        laws = (law,) if law is not None else (self.circulating, self.pump_off)
        return max(law.peak_gain_near(k, flow_m3s, half_width_m3s) for law in laws)


class PredictionLayout(StateLayout):
    """The prediction state's names: the estimation model's states before theta_2, then
    the actuator outputs whose lag is modelled."""

    def __init__(self, em: EstimationModel, lags: ActuatorLags):
        self.model_size = em.theta(2)
        self._names = (*em.names[:self.model_size],
                       *(name for name, lag in LAGGED_OUTPUTS if getattr(lags, lag)))

    @property
    def names(self) -> tuple[str, ...]:
        return self._names

    def lagged(self, name: str) -> int | None:
        """Index of a lagged actuator output, None where its lag is not modelled."""
        return self.index(name) if name in self._names else None


class PredictionModel:
    """The NMPC's prediction model: the shared drift plus the actuator lags.

    State x = [z1, z2, z3, p_1, q_2, ..., p_n, q_d, p_I (, b, q_bpp, p_in)]: the estimation
    model's evolving states, then the lagged actuator outputs that are modelled (block
    position b, back-pressure pump flow, stand-pipe pressure); par = the estimation model's
    states from theta_2 on (theta_2..theta_n, then the density offset, the string friction
    factor and d where the model has them) frozen over the horizon; ``pump_on`` (0/1) switches the mud pump (off: p_in -> 0)
    and, under :class:`PumpSwitchedFriction`, the annular friction law.

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
        self.layout = PredictionLayout(em, self.lags)
        self.nd_model = self.layout.model_size
        (self.block, self.bpp, self.pump) = (self.layout.lagged(name)
                                             for name, _ in LAGGED_OUTPUTS)
        self.nd = self.layout.size
        self.npar = em.size - self.nd_model
        g = em.wm.geometry
        self._stretch = g.static_stretch_m

    def block_command(self, reference, z1, z3):
        em = self.em
        return block_command(reference, z1, z3, self._stretch, em.block_kp, em.block_ki_per_s)

    def full(self, x, par) -> list:
        """The estimation model's state (list) from a prediction state and par."""
        return [x[i] for i in range(self.nd_model)] + [par[i] for i in range(self.npar)]

    def model_at(self, pump_on) -> EstimationModel:
        """The estimation model with the friction law of ``pump_on`` (a number or symbol)."""
        em = self.em
        if isinstance(em.nominal_friction, PumpSwitchedFriction):
            em = dataclasses.replace(em, nominal_friction=em.nominal_friction.at(pump_on))
        return em

    def rhs(self, x, u, par, pump_on=1.0, friction_pump_on=None, xp=CASADI):
        """Time derivative of the prediction state (list of expressions in the array
        namespace ``xp``, drill_core.backend); the friction law is ``friction_pump_on``'s
        (0/1) where given, else ``pump_on``'s."""
        em = self.model_at(pump_on if friction_pump_on is None else friction_pump_on)
        full = self.full(x, par)
        spp_cmd = u[U_PUMP_PRESSURE] * pump_on
        inputs = [u[U_BLOCK], self.choke_flow(x, u, em.bulk_modulus_of(full)),
                  x[self.bpp] if self.bpp is not None else u[U_BPP_FLOW],
                  x[self.pump] if self.pump is not None else spp_cmd]
        if self.block is not None:
            inputs[U_BLOCK] = reference_for_command(x[self.block], x[em.position], x[em.block_integral],
                                                    self._stretch, em.block_kp, em.block_ki_per_s)
        out = drift(xp, em, full, inputs, self.table)[:self.nd_model]
        if self.block is not None:
            out[em.block_integral] = integral_rate(u[U_BLOCK], x[em.position])
            command = self.block_command(u[U_BLOCK], x[em.position], x[em.block_integral])
            out.append((command - x[self.block]) / self.lags.drawworks_s)
        if self.bpp is not None:
            out.append((u[U_BPP_FLOW] - x[self.bpp]) / self.lags.bpp_s)
        if self.pump is not None:
            out.append((spp_cmd - x[self.pump]) / self.lags.pump_s)
        return out

    def choke_flow(self, x, u, bulk_modulus_factor=1.0):
        """The choke flow [m^3/s] under input u: the flow reference itself (flow control), or,
        with the choke on its pressure loop, the flow that takes the top annulus pressure
        to the set-point u[U_CHOKE] as a first-order lag (time constant T_c): what leaves the top
        volume plus the back-pressure pump's flow plus (dp - dp_ref) V_1 / (beta T_c), beta
        the report's bulk modulus times ``bulk_modulus_factor`` (the estimate's)."""
        if self.choke_time_constant_s is None:
            return u[U_CHOKE]
        em = self.em
        g, w = em.wm.geometry, em.wm.well
        bpp = x[self.bpp] if self.bpp is not None else u[U_BPP_FLOW]
        dp = measurement(em, x, False)[1]
        return (x[em.flow(2)] - g.displacement_area_m2[0] * x[em.velocity] + bpp
                + (dp - u[U_CHOKE]) * g.annulus_volume_m3[0]
                / (w.mud.bulk_modulus_pa * bulk_modulus_factor * self.choke_time_constant_s))

    def function(self, step_s: float, substeps: int, integrator: str,
                 friction_pump_on: float | None = None) -> ca.Function:
        """F(x, u, par, pump_on) -> x after one sample (inputs held), ``substeps`` RK4/Euler
        steps: calls of one step function (its code once, however many steps). With
        ``friction_pump_on`` (0/1) the friction law is that pump state's alone whatever
        ``pump_on`` says (under :class:`PumpSwitchedFriction` the symbolic law evaluates
        both laws' splines, twice the cost, to select one); ``pump_on`` still switches the
        pump. F's
        derivative is its explicit Jacobian, the chain rule over the steps of the step's
        own (one SX function), so every derivative the NLP needs is one call of it per
        stage instead of forward sweeps through the integrator; the step's Jacobian is the
        RK4 stages' forward sensitivities with each friction table's value and slope one
        call each (drill_core.table_tape), not one call per seed direction. F is
        differentiable in x and u only: the frozen parameters and the pump state are the
        NLP's parameters, never its decisions (``is_diff_in``), so no sensitivity is
        carried for them."""
        x = ca.SX.sym("x", self.nd)
        u = ca.SX.sym("u", U_SIZE)
        par = ca.SX.sym("par", self.npar)
        on = ca.SX.sym("pump_on")

        def f(s):
            return ca.vertcat(*self.rhs([s[i] for i in range(self.nd)], u, par, on,
                                        friction_pump_on))

        h = step_s / substeps
        integrate = rk4_step if integrator == "rk4" else euler_step
        step = ca.Function("predict_step", [x, u, par, on], [integrate(f, x, h)])
        drift_jacobian = drift_with_jacobian(f, x, [u], [par, on])
        nd = self.nd

        def sensitive_drift(s: WithSensitivity) -> WithSensitivity:
            value, jacobian = drift_jacobian(s.value, u, par, on)
            direct = ca.horzcat(ca.SX(nd, nd), jacobian[:, nd:])     # u
            return WithSensitivity(value, ca.mtimes(jacobian[:, :nd], s.sensitivity) + direct)

        stepped = integrate(sensitive_drift,
                            WithSensitivity(x, ca.horzcat(ca.SX.eye(nd), ca.SX(nd, U_SIZE))), h)
        step_jacobian = ca.Function("predict_step_jacobian", [x, u, par, on],
                                    [stepped.value, stepped.sensitivity[:, :nd],
                                     stepped.sensitivity[:, nd:]])
        args = [ca.MX.sym("x", self.nd), ca.MX.sym("u", U_SIZE), ca.MX.sym("par", self.npar),
                ca.MX.sym("pump_on")]
        state = args[0]
        for _ in range(substeps):
            state = step(state, *args[1:])
        xk, chain_x, chain_u = args[0], None, None        # d x_k / d x, d x_k / d u
        for _ in range(substeps):
            xk, local_x, local_u = step_jacobian(xk, *args[1:])
            chain_x, chain_u = ((local_x, local_u) if chain_x is None else
                                (ca.mtimes(local_x, chain_x), ca.mtimes(local_x, chain_u) + local_u))
        names = ["x", "u", "par", "pump_on"]
        held = [ca.MX(nd, self.npar), ca.MX(nd, 1)]      # par, pump_on: not differentiated
        jac = ca.Function("jac_predict", [*args, ca.MX.sym("out", self.nd)],
                          [chain_x, chain_u, *held],
                          [*names, "out_x_next"], [f"jac_x_next_{n}" for n in names])
        return ca.Function("predict", args, [state], names, ["x_next"],
                           {"custom_jacobian": jac, "jac_penalty": 0,
                            "is_diff_in": [True, True, False, False]})

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
            x0[2] = integral_for_command(command, reference, x0[0], self._stretch,
                                         self.em.block_kp, self.em.block_ki_per_s)

        if self.block is not None:
            w, g = self.em.wm.well, self.em.wm.geometry
            b = measured("block_m")
            extra.append(b if b is not None else
                         x0[0] + self._stretch + w.hoist_damping_n_s_m * x0[1] / g.axial_stiffness_n_m)
        if self.bpp is not None:
            v = measured("bpp_flow_m3s")
            extra.append(v if v is not None else (float(u_prev[U_BPP_FLOW]) if u_prev is not None else 0.0))
        if self.pump is not None:
            v = measured("spp_pa")
            extra.append(v if v is not None else
                         (float(u_prev[U_PUMP_PRESSURE]) * float(pump_on) if u_prev is not None else 0.0))
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
        us = ca.SX.sym("u", U_SIZE)
        ps = ca.SX.sym("p", self.npar)
        f = ca.Function("rhs", [xs, us, ps], [ca.vertcat(*self.rhs([xs[i] for i in range(self.nd)],
                                                                    us, ps))])
        worst = 0.0
        for _ in range(3):
            x = rng.normal(size=self.nd)
            acc = float(f(x, np.zeros(U_SIZE), np.zeros(self.npar))[1])
            ref = float(hy.hoisting_acceleration(self.em.wm, x[self.em.position], x[self.em.velocity],
                                                  x[self.block]))
            worst = max(worst, abs(acc - ref) / max(1.0, abs(ref)))
        return worst


def nmpc_estimation_model(config: RigConfig, configuration: str | None = None,
                          pulled_m: float = 0.0) -> EstimationModel:
    """The estimation model the NMPC predicts with: the shared one with the influx state
    under NMPC2 (``configuration``, None: config/nmpc.yaml's) and, under scaled_rheology,
    the yield jump smoothed over ``prediction_friction_smoothing_mps`` while the mud pump
    is planned on and ``pump_off_friction_smoothing_mps`` while it is off
    (:class:`PumpSwitchedFriction`); ``pulled_m``: the string that much shorter."""
    cfg = config.nmpc
    configuration = configuration or cfg.configuration
    em = build_estimation_model(config, configuration == "NMPC2",
                                cfg.prediction_friction_smoothing_mps, pulled_m)
    if em.nominal_friction is None:
        return em
    pump_off = NominalFriction(em.wm, cfg.pump_off_friction_smoothing_mps)
    return dataclasses.replace(em, nominal_friction=PumpSwitchedFriction(em.nominal_friction,
                                                                         pump_off))


def full_state(em: EstimationModel, x_hat, disturbance=None) -> np.ndarray:
    """Estimate as a state of ``em`` (adds/overrides the bottom influx d when ``em`` has it).
    The estimate holds the same states as ``em`` before d (one configuration builds both
    models); d, last, is taken from ``disturbance``, else from the estimate if it has it."""
    x = np.asarray(x_hat, dtype=float).ravel()
    common = em.size - int(em.with_disturbance)
    out = np.zeros(em.size)
    out[:common] = x[:common]
    if em.with_disturbance:
        if disturbance is not None:
            out[em.disturbance] = float(disturbance)
        elif x.size > common:
            out[em.disturbance] = x[common]
    return out


def outputs(em: EstimationModel, x) -> list:
    """Tracked outputs [block position, choke dp, BHP] of a state: h(x) without q_d."""
    return measurement(em, x, circulating=False)


def string_pressure_margin(em: EstimationModel, x):
    """p_I - (p_n - rho g z1) - K_b q_d: string pressure above annulus-at-bit + BHA loss [Pa]."""
    w = em.wm.well
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    return (hy.bit_pressure_drop(em.wm.geometry, x[em.string_pressure], x[em.pressure(em.n)],
                                 rho_g, x[em.position])
            - w.bha_loss_coefficient_pa_s_m3 * x[em.string_flow])


def choke_capacity(em: EstimationModel, dp):
    """Flow of the fully open choke at differential pressure dp [m^3/s] (eq. 53)."""
    return hy.choke_flow(em.wm, 1.0, dp)
