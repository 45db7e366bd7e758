"""The NMPC's optimal control problem (paper eqs. 49-59) transcribed for CasADi: multiple
shooting in a stage-wise layout, scaled variables, the cost, the soft constraints of
``drill_nmpc.soft_constraints`` and the hard input, slew and acceleration limits; built
once per configuration, then solved per sample (one real-time-iteration step by default)
with warm starts and an assessment of each answer. Plain module (no rclpy); the
derivation and the measurements behind each choice: docs/nmpc.md sections 1-4.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from drill_core.compiled import compiled
from drill_core.config import Nmpc
from drill_core.estimation_model import EstimationModel
from drill_core.input_layout import U_BLOCK, U_SIZE
from drill_nmpc.inputs import choke_time_constant, input_arrays
from drill_nmpc.parameter_layout import ParameterLayout
from drill_nmpc.prediction_model import (ActuatorLags, PredictionModel, StringFrictionTable,
                                         outputs)
from drill_nmpc.soft_constraints import BY_NAME, SLACK_NAMES, StageValues, soft_constraints
from drill_nmpc.solver_options import Structure, hpipm_options, solver_options

INTEGRAL_OUTPUTS = (1, 2)        # NMPC1 integrates the pressure outputs (see docs/nmpc.md)
_INF = float("inf")
_SUCCESS_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
RTI_STATUS = "RTI_step"          # one real-time-iteration step (solver rti)
_ITERATION_LIMIT = ("Maximum_Iterations_Exceeded", "SOLVER_RET_LIMITED", RTI_STATUS)
# An iteration-limited iterate is still used (real-time iteration) when it meets the
# linear hard constraints (input bounds, slew rows) to LINEAR_TOLERANCE (the QP's accuracy;
# the command is then clipped exactly, Supervisor.limit) and the dynamics (gap rows) to
# GAP_TOLERANCE, both in the OCP's scaled units (S_u: one slew step; S_x: 1 bar, 10 L/s, ...).
LINEAR_TOLERANCE = 5.0e-2
GAP_TOLERANCE = 5.0
STEP_FRACTIONS = (1.0, 0.5, 0.25, 0.125)   # RTI step lengths tried until the gaps are within it
# The parts of a real-time-iteration step whose wall time NmpcProblem.part_seconds adds up
# (the bench's profile, drill_nmpc.bench.solve_profile), with what each is.
RTI_PARTS = {
    "linearisation": "the cost gradient, the constraints and their Jacobian at the warm start "
                     "(the compiled prediction step and its Jacobian per stage, in CasADi's graph)",
    "qp": "the QP (HPIPM)",
    "evaluation": "the cost and constraints at the new iterate (the step's assessment)",
}


def _succeeded(stats: dict) -> bool:
    if stats.get("success"):
        return True
    return str(stats.get("return_status", "")) in _SUCCESS_STATUSES


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
                 cache_dir: str | None = None, acceleration_limit_mps2: float | None = None,
                 friction_pump_on: float | None = None, floor_trip: bool = False):
        self.cfg = cfg
        self.soft_constraints = soft_constraints(floor_trip)
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
        if hessian != "gauss-newton" and self.solver_name == "rti":
            raise ValueError("the real-time iteration is a Gauss-Newton step: use "
                             "hessian='gauss-newton'")
        if jit and hessian != "gauss-newton":
            raise ValueError("jit compiles the prediction step with its Jacobian only: the "
                             "exact Hessian needs jit false")
        self.hessian = hessian
        self.terminal_constraints = terminal_constraints
        self.jit = jit
        self.part_seconds = dict.fromkeys(RTI_PARTS, 0.0)   # wall time per RTI part, summed [s]
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
        self.ne = len(INTEGRAL_OUTPUTS) if self.configuration == "NMPC1" else 0
        # Block-reference acceleration limit of the process protection (Delta of the
        # reference speed per sample); it needs u_r two samples back in the stage state.
        self.accel = acceleration_limit_mps2
        self.nw = 1 if acceleration_limit_mps2 else 0
        self.ns = self.nd + U_SIZE + self.nw + self.ne   # stage state: x~, u~_{k-1}, u~_r,k-2, e
        self.Sx = self.model.scale()
        self.inputs = input_arrays(cfg)
        self.Su = self.inputs["slew"]
        self.u_span = self.inputs["span"]
        self.y_span = np.array(cfg.output_span.as_tuple(), dtype=float)
        # the friction law of one pump state (PredictionModel.function), None: the parameter's
        self.friction_pump_on = friction_pump_on
        self.F = self.model.function(self.ts, self.substeps, self.integrator, friction_pump_on)
        if jit:     # the step and its Jacobian in C; the NLP around them stays an MX graph
            self.F = compiled([self.F, self.F.jacobian()], "nmpc_predict", cache_dir)["predict"]
        self._state_box = self._trust_region()
        self.parameter_layout = ParameterLayout((
            ("x0", self.nd), ("par", self.npar), ("pump_on", 1), ("u_prev", U_SIZE),
            ("w0", self.nw), ("e0", self.ne), ("y_ref", 3 * self.N), ("y_sp", 3), ("u_ref", U_SIZE),
            ("bhp_bias", 1)))
        self._build(solver_options or {})

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
        """The soft constraints of stage k (path ones first: the slack order)."""
        path = 1 <= k < self.N or (k == self.N and self.terminal_constraints)
        return tuple(c.name for c in self.soft_constraints if not c.on_input_stages and path) \
            + tuple(c.name for c in self.soft_constraints if c.on_input_stages and k < self.N)

    def _build(self, extra_options: dict) -> None:
        em, cfg, N, Nc, nd = self.em, self.cfg, self.N, self.Nc, self.nd
        w_y = np.array(cfg.output_weight.as_tuple(), dtype=float)
        r_c = self.inputs["move_weight"]
        r_r = self.inputs["reference_weight"]
        q_e = cfg.integral_weight_factor * w_y[list(INTEGRAL_OUTPUTS)]
        t_w = {c.name: getattr(cfg, c.weight) for c in self.soft_constraints}
        P = ca.MX.sym("p", self.parameter_layout.size)
        p = self.parameter_layout.split(P)
        x0, par, pump_on, u_prev = p["x0"], p["par"], p["pump_on"], p["u_prev"]
        w0, e0, y_sp, u_ref, bhp_bias = p["w0"], p["e0"], p["y_sp"], p["u_ref"], p["bhp_bias"]
        y_ref = ca.reshape(p["y_ref"], 3, N)
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
            u, u_sl = (new_var(f"u{k}", U_SIZE) if k < Nc else (None, None))
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
                up = ca.MX.zeros(U_SIZE)
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
                    err = ca.vertcat(*[(y[i] - y_sp[i]) / self.y_span[i] for i in INTEGRAL_OUTPUTS])
                    s_next.append(e + self.ts * err)
                gap = s_vars[k + 1] - ca.vertcat(*s_next)
                st.gap = slice(ng, ng + self.ns)
                add_rows(gap, 0.0, 0.0, eq=True)
            # path rows
            if k < Nc:
                st.rows["slew"] = add_rows(u_vars[k] - up, -1.0, 1.0)
                if self.nw:       # change of the block-reference speed per sample
                    limit = self.accel * self.ts ** 2 / self.Su[U_BLOCK]
                    st.rows["acceleration"] = add_rows((u_vars[k][0] - up[0]) - (up[0] - w[0]),
                                                       -limit, limit)
            values = StageValues(em, self.model, x_phys, u_phys, xl, y)
            for c in sorted((BY_NAME[n] for n in names), key=lambda c: not c.on_input_stages):
                v = c.value(values) / c.slack_unit      # rows of input stages first
                xi_c = slack[c.name]
                st.rows[c.name] = add_rows(ca.vertcat(v + xi_c, v - xi_c), [-_INF, -_INF],
                                           [_INF, _INF]) if c.band else add_rows(v + xi_c, 0.0, _INF)
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
                for i in range(U_SIZE):
                    if r_c[i] > 0.0:
                        f = f + r_c[i] * (du[i] / self.u_span[i]) ** 2
                    if r_r[i] > 0.0:
                        f = f + r_r[i] * ((u_phys[i] - u_ref[i]) / self.u_span[i]) ** 2
            for n, xv in slack.items():
                f = f + t_w[n] * (xv ** 2 + xv)

        self.stages = stages
        self.ng = ng
        self._lbg0 = np.array(lbg, dtype=float)
        self._ubg0 = np.array(ubg, dtype=float)
        z = ca.vertcat(*z_parts)
        g = ca.vertcat(*g_parts)
        self.structure = Structure(N, nx_list, nu_list, ng_list, equality)
        self.nlp_functions = ca.Function("nlp", [z, P], [f, g])
        # Gauss-Newton: the cost is quadratic in z (outputs are linear in the states), so its
        # Hessian is exact and constant; the curvature of the dynamics is left out.
        hess_f = ca.hessian(f, z)[0] if self.hessian == "gauss-newton" else None
        if self.solver_name == "rti":
            self._build_rti(z, P, f, g, hess_f, extra_options)
            return
        nlp = {"x": z, "p": P, "f": f, "g": g}
        opts: dict = {}
        if hess_f is not None:
            lam_f = ca.MX.sym("lam_f")
            lam_g = ca.MX.sym("lam_g", g.numel())
            opts["hess_lag"] = ca.Function("nlp_hess_l", [z, P, lam_f, lam_g],
                                           [ca.triu(lam_f * hess_f) if self.solver_name == "ipopt"
                                            else lam_f * hess_f],
                                           ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
        options = solver_options(self.solver_name, cfg.max_iterations, self.structure,
                                 self.hessian, cfg.expand and not self.jit,  # a compiled step stays MX
                                 {**opts, **extra_options})
        self.solver = ca.nlpsol("nmpc", self.solver_name, nlp, options)

    def _build_rti(self, z, P, f, g, hess_f, extra_options: dict) -> None:
        """The real-time iteration: the constraints' Jacobian and the cost gradient at the
        warm start (one function), the cost Hessian (constant: checked at two random
        points) and the QP solver with the stage structure."""
        self._linearisation = ca.Function("rti_linearisation", [z, P],
                                          [ca.gradient(f, z), g, ca.jacobian(g, z)])
        hessian = ca.Function("rti_hessian", [z, P], [hess_f])
        rng = np.random.default_rng(0)
        h1, h2 = (hessian(rng.normal(size=self.nz), rng.normal(size=self.parameter_layout.size))
                  for _ in range(2))
        if float(ca.mmax(ca.fabs(h1 - h2))) != 0.0:
            raise RuntimeError("the cost Hessian is not constant: the real-time iteration needs it")
        self._hessian = h1
        self.solver = ca.conic("nmpc_qp", "hpipm", {"h": h1.sparsity(),
                                                     "a": self._linearisation.sparsity_out(2)},
                               {**hpipm_options(self.structure), **extra_options})

    # -- numeric data of one instance ---------------------------------------------------
    def parameters(self, x0, par, u_prev, e0, y_ref, y_sp, u_ref, pump_on: bool = True,
                   reference_speed: float = 0.0, bhp_bias_pa: float = 0.0) -> np.ndarray:
        """Parameter vector: prediction state x_0, par (the estimate from theta on), pump_on,
        u_{-1}, (u_r,-2 scaled from the last block-reference speed), e_0, y_ref[1..N], y_sp, u_ref,
        the BHP bias added to the predicted BHP of stages 1..N."""
        return self.parameter_layout.pack(
            x0=x0, par=par, pump_on=1.0 if pump_on else 0.0, u_prev=u_prev,
            w0=[-reference_speed * self.ts / self.Su[U_BLOCK]] * self.nw,
            e0=np.asarray(e0, dtype=float).ravel()[:self.ne], y_ref=y_ref, y_sp=y_sp,
            u_ref=u_ref, bhp_bias=bhp_bias_pa)

    def bounds(self, u_prev, velocity_limit, bhp_band, dp_band, circulating: bool,
               relaxed: bool = False, block_range: tuple | None = None, fixed=None,
               stand_end: tuple = (-_INF, _INF)):
        """Variable and row bounds: hard input limits (the block reference also within
        ``block_range``), slew, the soft constraints' band edges (SI) and the constraints
        dropped (relaxed retry; no circulation). ``fixed`` (N_c x 4, SI, NaN: free) pins
        stage inputs to a plan made elsewhere (the rig floor's pump ramp, the block held
        in the slips): their slew and acceleration rows are dropped. ``stand_end``: the
        string position's band on a multi-stand trip [m]."""
        lbz = np.full(self.nz, -_INF)
        ubz = np.full(self.nz, _INF)
        lo = self.inputs["min"].copy()
        hi = self.inputs["max"].copy()
        if block_range is not None:
            lo[0], hi[0] = max(lo[0], block_range[0]), min(hi[0], block_range[1])
        u_lo = (lo - u_prev) / self.Su
        u_hi = (hi - u_prev) / self.Su
        lbg, ubg = self._lbg0.copy(), self._ubg0.copy()
        edges = {"velocity": (-velocity_limit, velocity_limit), "bhp_band": bhp_band,
                 "choke_dp_band": dp_band, "stand_end": stand_end}
        for st in self.stages:
            if st.s.stop > st.s.start:         # trust region on the predicted states
                box = self._state_box
                lbz[st.s], ubz[st.s] = -box, box
            if st.u is not None:
                lbz[st.u], ubz[st.u] = u_lo, u_hi
            for idx in st.slack.values():
                lbz[idx] = 0.0
            for name, rows in st.rows.items():
                c = BY_NAME.get(name)
                if c is None:
                    continue
                if (relaxed and c.relaxed_on_fallback) or (c.needs_circulation and not circulating):
                    lbg[rows], ubg[rows] = -_INF, _INF
                elif c.band:
                    lo, hi = edges[name]
                    lbg[rows[0]] = lo / c.slack_unit
                    ubg[rows[1]] = hi / c.slack_unit
        if fixed is not None:
            self._pin(np.asarray(fixed, dtype=float), u_prev, lbz, ubz, lbg, ubg)
        return lbz, ubz, lbg, ubg

    def _pin(self, fixed, u_prev, lbz, ubz, lbg, ubg) -> None:
        """Stage inputs pinned to ``fixed`` (NaN: free); the moves into and out of a pinned
        input are not limited (the plan's own)."""
        pinned_before = np.zeros(U_SIZE, dtype=bool)
        for k, st in enumerate(self.stages):
            if st.u is None:
                break
            pinned = np.isfinite(fixed[k])
            idx = np.arange(st.u.start, st.u.stop)[pinned]
            lbz[idx] = ubz[idx] = (fixed[k][pinned] - u_prev[pinned]) / self.Su[pinned]
            free_moves = pinned | pinned_before
            rows = np.asarray(st.rows["slew"])[free_moves]
            lbg[rows], ubg[rows] = -_INF, _INF
            if "acceleration" in st.rows and (free_moves[U_BLOCK] or (
                    k >= 2 and np.isfinite(fixed[k - 2][U_BLOCK]))):
                lbg[st.rows["acceleration"]], ubg[st.rows["acceleration"]] = -_INF, _INF
            pinned_before = pinned

    def pack(self, x0, u_prev, X, U, E, slacks, reference_speed: float = 0.0) -> np.ndarray:
        """Decision vector from physical trajectories X[(N+1) x nd], U[N x 4], E[(N+1) x ne]."""
        z = np.zeros(self.nz)
        for k, st in enumerate(self.stages):
            if k >= 1:
                s = [(X[k] - x0) / self.Sx, (U[k - 1] - u_prev) / self.Su]
                if self.nw:
                    before = U[k - 2, U_BLOCK] if k >= 2 else u_prev[U_BLOCK] - reference_speed * self.ts
                    s.append([(before - u_prev[U_BLOCK]) / self.Su[U_BLOCK]])
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
        U = np.zeros((N, U_SIZE))
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

    def integral_rollout(self, X, par, e0, y_sp, bhp_bias_pa: float = 0.0) -> np.ndarray:
        """NMPC1's integral E[(N+1) x ne] along X as the NLP integrates it (stage 0 without
        the BHP bias); empty columns for the other configurations."""
        E = np.zeros((self.N + 1, self.ne))
        if not self.ne:
            return E
        E[0] = np.asarray(e0, dtype=float).ravel()[:self.ne]
        for k in range(self.N):
            y = np.array([float(v) for v in outputs(self.em, self.model.full(X[k], par))])
            if k >= 1:
                y[2] += bhp_bias_pa
            E[k + 1] = E[k] + self.ts * np.array([(y[i] - y_sp[i]) / self.y_span[i]
                                                  for i in INTEGRAL_OUTPUTS])
        return E

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
        gap = self.dynamics_gap(g, lbg, ubg)
        ok = max(bound, slew) <= LINEAR_TOLERANCE and gap <= GAP_TOLERANCE
        return ok, False, "" if ok else f"{status}: bounds {bound:.2g}, slew {slew:.2g}, gap {gap:.2g}"

    def solve(self, p, z0, lbz, ubz, lbg, ubg, lam_z0=None, lam_g0=None) -> dict:
        if self.solver_name == "rti":
            return self._rti_step(p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0)
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

    def _rti_step(self, p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0) -> dict:
        """One Gauss-Newton SQP step, full length (acados' real-time iteration): the QP of
        the linearisation at z0 gives the step and the new multipliers."""
        t0 = time.perf_counter()
        grad_f, g0, jac_g = self._linearisation(z0, p)
        t1 = time.perf_counter()
        args = {"h": self._hessian, "g": grad_f, "a": jac_g, "lba": lbg - g0, "uba": ubg - g0,
                "lbx": lbz - z0, "ubx": ubz - z0}
        if lam_z0 is not None:
            args["lam_x0"] = lam_z0
        if lam_g0 is not None:
            args["lam_a0"] = lam_g0
        qp = self.solver(**args)
        qp_stats = self.solver.stats()
        t2 = time.perf_counter()
        dz = np.array(qp["x"]).ravel()
        lam_z, lam_g = np.array(qp["lam_x"]).ravel(), np.array(qp["lam_a"]).ravel()
        # An inexact QP answer (HPIPM's iteration or step-length limit) is still a step: the
        # assessment checks the linear constraints and the dynamics of the iterate, as it
        # does for an iteration-limited SQP. A full step whose dynamics gaps exceed the
        # tolerance (a linearisation far from the model: the string at rest in gelled mud,
        # the pump stopped) is shortened, halving it up to three times.
        finite = bool(np.all(np.isfinite(dz)))
        for fraction in STEP_FRACTIONS:
            z = z0 + fraction * dz
            f, g = self.nlp_functions(z, p)
            g = np.array(g).ravel()
            if not finite or self.dynamics_gap(g, lbg, ubg) <= GAP_TOLERANCE:
                break
        t3 = time.perf_counter()
        for part, seconds in zip(RTI_PARTS, (t1 - t0, t2 - t1, t3 - t2)):
            self.part_seconds[part] += seconds
        if fraction < 1.0:          # the multipliers move with the primal step
            lam_z = fraction * lam_z + (1.0 - fraction) * (0.0 if lam_z0 is None else lam_z0)
            lam_g = fraction * lam_g + (1.0 - fraction) * (0.0 if lam_g0 is None else lam_g0)
        status = RTI_STATUS if finite else f"QP {qp_stats.get('return_status', 'failed')}"
        return {"z": z, "lam_z": lam_z, "lam_g": lam_g, "f": float(f), "g": g,
                "stats": {"success": False, "return_status": status, "iter_count": 1,
                          "step_fraction": fraction}}

    def dynamics_gap(self, g, lbg, ubg) -> float:
        """The largest violation of the gap rows (dynamics) in scaled units."""
        excess = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
        return max((float(np.max(excess[st.gap])) for st in self.stages if st.gap is not None),
                   default=0.0)
