"""The NMPC supervisor: one solve per sample, with warm start and the fallback policy.

Plain module (no rclpy). Each sample it turns the estimate into the OCP's initial state
(the actuator lags from their measured outputs, the block controller's integral from the
drawworks' last command), caps the friction parameters for a stable prediction, builds
the references (the trip's motion profile for the block) and the soft constraints' band
edges, learns the model's BHP bias from its one-step errors, solves from the shifted
previous solution and, on an unusable answer, once more from that solution's inputs rolled
out through the prediction model (no dynamics gaps), then cold with the relaxed constraint
set (paper Alg. 3), or holds the last input. Commands are always finite and inside the
bounds. docs/nmpc.md sections 0 and 5.
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import NamedTuple

import numpy as np

from drill_core.config import Nmpc, RigConfig
from drill_core.estimation_model import EstimationModel, friction_flow_gain_bound
from drill_core.input_layout import U_BLOCK, U_CHOKE, U_PUMP_PRESSURE
from drill_core.scenario import ActiveSetpoints
from drill_core.surge_swab import SurgeSwabModel
from drill_nmpc.motion_profile import MotionProfile
from drill_nmpc.prediction_model import (ACTUATOR_KEYS, ActuatorLags, PumpSwitchedFriction,
                                         full_state, outputs, string_pressure_margin)
from drill_nmpc.soft_constraints import SLACK_NAMES, SLACK_UNITS
from drill_nmpc.solve_result import Fallback, SolveResult
from drill_nmpc.transcription import INTEGRAL_OUTPUTS, NmpcProblem

TRIP_RANGE_MARGIN_M = 0.5         # the block reference may pass the string / target by this
THETA_STIFFNESS_LIMIT = 2.0       # |lambda| h of the annular flow modes kept below this (RK4: 2.78)
THETA_SPEED_FLOOR_MPS = 0.1       # quadratic law: effective annular speed used for the cap near zero flow


class TripCorridor(NamedTuple):
    """The block reference's corridor to one target (Supervisor.block_range)."""
    target_m: float
    progress_m: float      # the furthest the string has reached on its way [m]
    direction: float       # +1 up, -1 down, 0 held where the corridor began


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
                 cache_dir: str | None = None, floor_trip: bool = False):
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
        jit = (cfg.jit if jit is None else jit) and hessian == "gauss-newton"

        def problem(friction_pump_on):
            return NmpcProblem(cfg, em, configuration=configuration, solver=solver, jit=jit,
                               cache_dir=cache_dir, substeps=substeps, integrator=integrator,
                               solver_options=solver_options, hessian=hessian, lags=lags,
                               acceleration_limit_mps2=accel, friction_pump_on=friction_pump_on,
                               floor_trip=floor_trip)

        # one problem per pump state where the friction law follows it (the same OCP as
        # one with the law selected by its pump_on parameter, at one law's cost); the one
        # of the pump state in force is self.problem
        if isinstance(em.nominal_friction, PumpSwitchedFriction):
            self._problems = {True: problem(1.0), False: problem(0.0)}
        else:
            self._problems = dict.fromkeys((True, False), problem(None))
        self.problem = self._problems[True]
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
        self.rollouts = 0                            # solves from the rolled-out warm start
        self._trip: TripCorridor | None = None         # the block's trip corridor (block_range)
        self._profile: MotionProfile | None = None     # block reference's motion profile (block_reference profile)
        self.bhp_bias = 0.0                            # model's BHP offset (bhp_bias_gain > 0) [Pa]
        self.choke_flow_m3s = math.nan                 # the last solve's choke flow (held with its input)
        self._predicted_bhp: float | None = None       # the last solve's BHP prediction for now [Pa]
        self.surge = SurgeSwabModel(self.em)
        self._rest_inputs: tuple | None = None         # rest_choke_dp's arguments at the last estimate
        self._held_choke_dp = math.nan                 # the choke dp held since the holds began [Pa]

    # -- helpers ------------------------------------------------------------------------
    def problem_for(self, pump_on: bool) -> NmpcProblem:
        """The OCP solved while the mud pump is planned ``pump_on``."""
        return self._problems[bool(pump_on)]

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
        self._held_choke_dp = math.nan

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
            lo[U_BLOCK] = max(lo[U_BLOCK], u_prev[U_BLOCK] + reference_speed * self.problem.ts - step)
            hi[U_BLOCK] = min(hi[U_BLOCK], u_prev[U_BLOCK] + reference_speed * self.problem.ts + step)
        u = np.clip(u, lo, hi)
        u = np.clip(u, self.u_min, self.u_max)
        assert np.all(np.isfinite(u)), "NMPC command is not finite"
        return u

    def setpoint_vector(self, x_full, setpoints: ActiveSetpoints, par) -> np.ndarray:
        """y_sp = [block target, choke dp target, BHP ref] (NaN BHP: the first estimate's
        BHP). The choke dp target is the setpoints' reference following the steady dp that
        holds the BHP reference at rest with the prediction's parameters ``par`` (friction
        clamped, density offset: ActiveSetpoints.following_rest)."""
        bhp = setpoints.bhp_ref_pa
        if not math.isfinite(bhp):
            if self.bhp_ref_default is None:
                self.bhp_ref_default = float(outputs(self.em, x_full)[2])
            bhp = self.bhp_ref_default
        rest = self.rest_choke_dp(x_full, par, bhp, bool(setpoints.mud_pump_on),
                                  (-math.inf, math.inf))
        dp = setpoints.following_rest(rest, self.cfg.choke_dp_min_pa).choke_dp_ref_pa
        return np.array([setpoints.block_position_target_m, dp, bhp])

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

    def _clamp_friction(self, x, par, pump_on: bool) -> str:
        """Cap the friction parameters theta_i (in ``par``) where the annular flow mode
        d(q_i)/dt = -(theta_i dF_i/dq_i / M_i) q_i + ... becomes too stiff for the
        prediction's RK4 step h (|lambda| h <= 2, inside RK4's stability region): an
        estimate several times the circulating value would make the prediction diverge.
        dF_i/dq_i is the bound of the law the prediction takes with the pump ``pump_on``
        (em.friction_flow_gain_bound: 2|v_e|/A_i for the quadratic law). Returns a note
        when it acted."""
        em, g = self.em, self.em.wm.geometry
        h = self.problem.ts / self.problem.substeps
        gain = friction_flow_gain_bound(self.model.model_at(1.0 if pump_on else 0.0), x,
                                        THETA_SPEED_FLOOR_MPS)
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
        target, position = float(target), float(x[self.em.position])
        if self._trip is None or self._trip.target_m != target:
            self._trip = TripCorridor(target, position, float(np.sign(target - position)))
        progress = self._trip.progress_m
        direction = np.sign(target - progress)
        if direction * (position - progress) > 0.0 and direction * (target - position) > 0.0:
            progress = position                      # further along, not past the target
        elif direction * (position - target) >= 0.0:
            progress = target
        self._trip = self._trip._replace(progress_m=progress)
        lo = min(progress, target) - TRIP_RANGE_MARGIN_M
        hi = max(progress, target) + TRIP_RANGE_MARGIN_M
        ts = self.problem.ts
        if self.acceleration:
            coast = float(u_prev[U_BLOCK]) + self._speed * ts
            step = self.acceleration * ts ** 2
            lo, hi = min(lo, coast + step), max(hi, coast - step)
        else:
            lo, hi = min(lo, float(u_prev[U_BLOCK])), max(hi, float(u_prev[U_BLOCK]))
        return lo, hi

    def stand_end_band(self) -> tuple[float, float]:
        """The string's band on a multi-stand trip (its OCP's ``stand_end`` rows) [m]: at most
        ``stand_end_allowance_m`` past the target in the corridor's direction of travel
        (block_range sets the corridor); unbounded while no move is under way."""
        if self._trip is None or self._trip.direction == 0.0:
            return -math.inf, math.inf
        end = self._trip.target_m + self._trip.direction * self.cfg.stand_end_allowance_m
        return (-math.inf, end) if self._trip.direction > 0.0 else (end, math.inf)

    def carried_integral(self, integral, y_now, dp_band, bhp_band) -> np.ndarray:
        """NMPC1's integral states one sample on: the estimated error *outside the band*
        (the part the model failed to prevent) integrated, so riding the band edge on
        purpose does not wind it up and a persistent model bias does; clamped. Back inside
        its band an output's integral leaks away: what a transient (a start off the
        reference) wound up must not hold the output at the band's other edge until it has
        been paid back."""
        pb = self.problem
        bands = {1: dp_band, 2: bhp_band}
        err = np.array([(y_now[i] - min(max(y_now[i], bands[i][0]), bands[i][1]))
                        / pb.y_span[i] for i in INTEGRAL_OUTPUTS])
        leak = math.exp(-pb.ts / self.cfg.integral_leak_time_s) \
            if self.cfg.integral_leak_time_s > 0.0 else 1.0
        kept = np.where(err == 0.0, leak, 1.0)
        return np.clip(kept * integral + pb.ts * err,
                       -self.cfg.integral_limit_s, self.cfg.integral_limit_s)

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

    @staticmethod
    def _with_plan(U, fixed):
        """Input trajectory ``U`` (N x 4) with the pinned inputs of ``fixed`` (N_c x 4, NaN:
        free; None: none) in it, the stages past N_c at its last row."""
        if fixed is None:
            return U
        U = U.copy()
        rows = len(fixed)
        U[:rows] = np.where(np.isfinite(fixed), fixed, U[:rows])
        U[rows:] = U[rows - 1]
        return U

    def _initial_guess(self, x0, par, u_prev, pump_on, fixed=None):
        """Cold start: inputs held at u_{-1} (the pinned ones on their plan), states
        simulated, slacks and multipliers zero."""
        pb = self.problem
        U = self._with_plan(np.tile(u_prev, (pb.N, 1)), fixed)
        X = pb.simulate(x0, par, U, pump_on)
        if not np.all(np.isfinite(X)):
            X = np.tile(x0, (pb.N + 1, 1))
        E = np.tile(self.integral, (pb.N + 1, 1)) if pb.ne else None
        return pb.pack(x0, u_prev, X, U, E, {}, self._speed), None, None

    def _rollout_guess(self, x0, par, u_prev, pump_on, y_sp, fixed=None):
        """The previous solution's inputs, shifted one sample (the pinned ones on their
        plan), rolled out from x_0 through the prediction model: states and NMPC1's integral
        without dynamics gaps (the pump state of now); slacks and multipliers zero."""
        pb, w = self.problem, self._warm
        U = self._with_plan(np.vstack([w["U"][1:], w["U"][-1:]]), fixed)
        X = pb.simulate(x0, par, U, pump_on)
        if not np.all(np.isfinite(X)):
            return self._initial_guess(x0, par, u_prev, pump_on, fixed)
        E = pb.integral_rollout(X, par, self.integral, y_sp, self.bhp_bias) if pb.ne else None
        return pb.pack(x0, u_prev, X, U, E, {}, self._speed), None, None

    def _shifted_guess(self, x0, par, u_prev, pump_on, fixed=None):
        """Previous solution shifted one sample (primal and multipliers), re-expressed
        around the new x_0 and u_{-1}, the pinned inputs on their plan."""
        pb, w = self.problem, self._warm
        X = np.vstack([w["X"][1:], w["X"][-1:]])
        X[0] = x0
        U = self._with_plan(np.vstack([w["U"][1:], w["U"][-1:]]), fixed)
        E = None
        if pb.ne:
            E = np.vstack([w["E"][1:], w["E"][-1:]])
            E[0] = self.integral
        slacks = {n: np.concatenate([v[1:], v[-1:]]) for n, v in w["slacks"].items()}
        z = pb.pack(x0, u_prev, X, U, E, slacks, self._speed)
        lam_z, lam_g = pb.shift_multipliers(w["lam_z"], w["lam_g"])
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(lam_z)) and np.all(np.isfinite(lam_g))):
            return self._initial_guess(x0, par, u_prev, pump_on, fixed)
        return z, lam_z, lam_g

    # -- one sample ---------------------------------------------------------------------
    def step(self, x_hat, setpoints: ActiveSetpoints, u_prev, disturbance=None,
             actuators: dict | None = None, fixed_inputs=None,
             bpp_reference_m3s: float = 0.0) -> SolveResult:
        """Solve the OCP at estimate ``x_hat`` and return the command to apply from now.

        ``actuators`` holds measured actuator outputs (keys ACTUATOR_KEYS: block position,
        back-pressure pump flow, stand-pipe pressure, e.g. from /actuators/<name>/frame), the
        initial states of the modelled actuator lags; a missing one is carried over from the
        previous prediction when the last command was applied, else estimated
        (PredictionModel.initial_state). ``fixed_inputs`` (N_c x 4, SI, NaN: free) pins
        inputs the rig floor plans (NmpcProblem.bounds): the command takes its first row's
        pinned values as they are; ``bpp_reference_m3s`` the back-pressure pump's input
        reference (its reference weight pulls it there).
        """
        t0 = time.perf_counter()
        pb, em = self.problem, self.em
        u_prev = self.safe_input(u_prev)
        # block-reference speed of the last period, from the two inputs applied last
        self._speed = 0.0 if self._applied is None else \
            float(u_prev[U_BLOCK] - self._applied[U_BLOCK]) / pb.ts
        self._applied = u_prev.copy()
        x = full_state(em, x_hat, disturbance)
        self.solve_count += 1
        if not np.all(np.isfinite(x)):
            return self._hold(u_prev, "not solved", t0, reasons=("invalid_estimate",))
        if self.spp_nominal is None:
            self.spp_nominal = float(u_prev[U_PUMP_PRESSURE])
        pump_on = bool(setpoints.mud_pump_on)
        pb = self.problem = self.problem_for(pump_on)
        known = {}
        if self._next_actuators is not None and np.allclose(u_prev, self._next_actuators[1]):
            known.update(self._next_actuators[0])
        known.update({k: v for k, v in (actuators or {}).items() if v is not None})
        self._next_actuators = None
        x0 = self.model.initial_state(x, u_prev, known, pump_on)
        par = x[self.model.nd_model:].copy()
        clamped = self._clamp_friction(x, par, pump_on)
        y_now = np.array([float(v) for v in outputs(em, x)])
        y_sp = self.setpoint_vector(x, setpoints, par)
        # reference trajectory (59), anchored at the estimated output
        y_ref = np.array([self.alpha ** j * y_now + (1.0 - self.alpha ** j) * y_sp
                          for j in range(pb.N + 1)])
        vlim, bhp_band, dp_band = self.levels(setpoints, y_sp)
        self._rest_inputs = (x.copy(), par.copy(), float(y_sp[2]), pump_on, dp_band)
        if self.cfg.block_reference == "profile":
            y_ref[:, 0] = self.block_profile(float(x[self.em.position]), float(y_sp[0]), vlim)
        if pb.ne:
            self.integral = self.carried_integral(self.integral, y_now, dp_band, bhp_band)
        u_ref = np.array([y_sp[0], u_prev[U_CHOKE], bpp_reference_m3s, self.spp_nominal])
        if self._predicted_bhp is not None:
            # offset-free: integrate the error of the last one-step BHP prediction
            error = y_now[2] - self._predicted_bhp
            clip = self.cfg.bhp_bias_error_clip_pa
            if clip > 0.0:
                error = min(max(error, -clip), clip)
            limit = self.cfg.bhp_bias_limit_pa
            self.bhp_bias = float(np.clip(self.bhp_bias + self.cfg.bhp_bias_gain * error,
                                          -limit, limit))
        self._predicted_bhp = None
        p = pb.parameters(x0, par, u_prev, self.integral, y_ref[1:], y_sp, u_ref, pump_on,
                          self._speed, self.bhp_bias)
        circulating = pump_on

        corridor = self.block_range(x, u_prev, y_sp[0])
        stand_end = self.stand_end_band()
        last = None
        reasons: list[str] = []
        # warm starts in turn: the shifted previous solution, its inputs rolled out again
        # (the iterate of the first was unusable: the plan's states no longer fit, e.g. the
        # mud pump stopped), then held inputs with the relaxed constraint set (a fallback)
        attempts = ("shifted", "rollout", "relaxed") if self._warm is not None \
            else ("cold", "relaxed")
        for start in attempts:
            relaxed = start == "relaxed"
            if start == "shifted":
                z0, lam_z0, lam_g0 = self._shifted_guess(x0, par, u_prev, pump_on, fixed_inputs)
            elif start == "rollout":
                z0, lam_z0, lam_g0 = self._rollout_guess(x0, par, u_prev, pump_on, y_sp,
                                                         fixed_inputs)
            else:
                z0, lam_z0, lam_g0 = self._initial_guess(x0, par, u_prev, pump_on,
                                                         fixed_inputs)
            lbz, ubz, lbg, ubg = pb.bounds(u_prev, vlim, bhp_band, dp_band, circulating, relaxed,
                                           corridor, fixed_inputs, stand_end)
            try:
                sol = pb.solve(p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0)
            except RuntimeError as err:       # evaluation error inside the solver
                sol = {"stats": {"success": False, "return_status": f"error: {err}"[:120],
                                 "iter_count": -1}}
            last = sol
            usable, converged, why = pb.assess(sol, lbz, ubz, lbg, ubg)
            if not usable:
                reasons.append(f"{start} attempt: {why}")
                continue
            X, U, E, slacks = pb.unpack(sol["z"], x0, u_prev, self.integral)
            if not (np.all(np.isfinite(U)) and np.all(np.isfinite(X))):
                continue
            if relaxed:
                self._warm = None
                self.fallback_count += 1
            else:
                self.rollouts += start == "rollout"
                self._warm = {"X": X, "U": U, "E": E, "slacks": slacks,
                              "lam_z": sol["lam_z"], "lam_g": sol["lam_g"]}
            u = self.limit(U[0], u_prev, self._speed)
            if fixed_inputs is not None:
                pinned = np.isfinite(fixed_inputs[0])
                u[pinned] = np.asarray(fixed_inputs[0], dtype=float)[pinned]
            U[0] = u
            lagged = self.model.nd > self.model.nd_model
            if lagged or self.cfg.bhp_bias_gain > 0.0:      # the plant one sample ahead under u
                x1 = np.asarray(pb.F(x0, u, par, 1.0 if pump_on else 0.0), dtype=float).ravel()
                if lagged:
                    self._next_actuators = (self.model.actuator_state(x1), u.copy())
                if self.cfg.bhp_bias_gain > 0.0:
                    self._predicted_bhp = float(outputs(em, self.model.full(x1, par))[2]) \
                        + self.bhp_bias
            if start == "rollout":
                reasons.append("warm start rolled out")
            fraction = sol["stats"].get("step_fraction", 1.0)
            if fraction < 1.0:
                reasons.append(f"step shortened to {fraction:g}")
            result = self._result(u, Fallback.RELAXED if relaxed else Fallback.NONE, sol, t0, par,
                                  X, U, slacks, y_ref, converged,
                                  ((clamped,) if clamped else ()) + tuple(reasons))
            self.choke_flow_m3s = result.choke_flow_m3s = float(self.model.choke_flow(
                x0, u, em.bulk_modulus_of(self.model.full(x0, par))))
            self._held_choke_dp = math.nan
            return result
        self._warm = None
        return self._hold(u_prev, str(last["stats"].get("return_status", "failed")), t0,
                          iterations=int(last["stats"].get("iter_count", -1)),
                          reasons=((clamped,) if clamped else ()) + tuple(reasons))

    def hold(self, u_prev, reason: str) -> SolveResult:
        """Hold the last input (e.g. the estimate was unusable: ``reason``); counted as a
        fallback."""
        self._warm = None
        self._applied = None
        return self._hold(self.safe_input(u_prev), "not solved", time.perf_counter(),
                          reasons=(reason,))

    def rest_choke_dp(self, x, par, bhp_ref_pa: float, pump_on: bool, dp_band) -> float:
        """The steady choke dp [Pa] that holds ``bhp_ref_pa`` with the string at rest at
        the estimated circulation (none with the pump off) and friction parameters
        ``par``, inside ``dp_band``: what the choke holds while the supervisor falls back."""
        flow = float(x[self.em.string_flow]) if pump_on else 0.0
        dp = float(self.surge.choke_dp_for_bhp(bhp_ref_pa, par[:self.em.n - 1], flow, 0.0,
                                               self.em.wm.well.choke_downstream_pressure_pa,
                                               float(self.em.density_offset_of(x))))
        return min(max(dp, dp_band[0]), dp_band[1]) if math.isfinite(dp) else math.nan

    def _hold(self, u_prev, status: str, t0: float, iterations: int = -1,
              reasons: tuple[str, ...] = ()) -> SolveResult:
        """The last input held (the block reference braked within the acceleration limit)
        and the choke dp to hold meanwhile, fixed when this run of holds began: the steady
        dp that holds the BHP reference with the string at rest (``rest_choke_dp``). A
        held choke flow would let the pressure run away against the back-pressure pump
        without circulation; the dp of the moment would keep a surge's friction that goes
        as the string stops."""
        self.fallback_count += 1
        if not math.isfinite(self._held_choke_dp) and self._rest_inputs is not None:
            self._held_choke_dp = self.rest_choke_dp(*self._rest_inputs)
        u = u_prev.copy()
        if self.acceleration and self._speed:      # brake the block reference, within the limit
            v = math.copysign(max(abs(self._speed) - self.acceleration * self.problem.ts, 0.0),
                              self._speed)
            u[U_BLOCK] = u_prev[U_BLOCK] + v * self.problem.ts
        u = self.limit(u, u_prev, self._speed)
        return SolveResult(u=u, success=False, fallback=Fallback.HOLD, status=status,
                           reasons=reasons, iterations=iterations,
                           solve_time_s=time.perf_counter() - t0, cost=float("nan"),
                           slacks={n: float("nan") for n in SLACK_NAMES},
                           planned_inputs=np.tile(u, (self.problem.N, 1)),
                           integral=self.integral.copy(), configuration=self.configuration,
                           choke_flow_m3s=self.choke_flow_m3s, hold_choke_dp_pa=self._held_choke_dp)

    def _result(self, u, fallback: Fallback, sol, t0, par, X, U, slacks, y_ref, converged,
                reasons: tuple[str, ...]) -> SolveResult:
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
                           integral=self.integral.copy(), configuration=self.configuration,
                           reasons=reasons)
