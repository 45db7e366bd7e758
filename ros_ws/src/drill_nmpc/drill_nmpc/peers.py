"""The NMPC1 problem built in do-mpc, run in the same in-process loop as the supervisor.

A peer for the comparison of issue 32 (item 3): the project's NMPC (CasADi, one real-time
iteration per sample) against do-mpc (PyPI ``do-mpc``) on the same problem. Only
do-mpc's API is called; the problem comes from the project's own definitions:

* the do-mpc ``Model`` (continuous, SX) has the states and inputs of the supervisor's
  prediction model (``PredictionModel``: the shared estimation model's evolving states plus
  the drawworks / back-pressure-pump / mud-pump lags of config/actuators.yaml, the string
  friction B-spline table, the choke on its flow loop) and its right-hand side is
  ``PredictionModel.rhs`` itself; the frozen parameters (theta_2..theta_n, the density
  offset) and the pump state are do-mpc parameters (``_p``, one scenario, set per sample);
  the tracked outputs are ``prediction_model.outputs``; one more state, NMPC1's BHP
  integral;
* the do-mpc ``MPC`` has config/nmpc.yaml's horizon (15 samples of 1 s), the output
  weights on the block position and BHP tracking (choke dp weight 0), the input move
  weights (``set_rterm`` on inputs scaled by their spans, so the r-term is
  r~_i (du_i / span_i)^2), the input reference weights (bpp flow -> 0, stand-pipe pressure
  -> its first value), the NMPC1 integral weight Q_c = 0.1 W_c, the input bounds, the five
  soft constraints of ``drill_nmpc.soft_constraints`` (velocity, BHP band, choke-dp band,
  string pressure, choke capacity; ``set_nl_cons`` in the slack units of that table, with
  its weights), and do-mpc's defaults for the rest: orthogonal collocation (Radau, degree
  2, one finite element per sample), IPOPT (MUMPS) to convergence, warm-started from the
  previous solution;
* the references per sample are the supervisor's: the pressures' (59) with the
  reference smoothing alpha, anchored at the current output; the block's the trip's motion
  profile (``drill_nmpc.motion_profile``) at the trip-speed limit and the protection's
  acceleration; the choke-dp target following the steady dp at rest
  (``ActiveSetpoints.following_rest`` with ``drill_core.surge_swab``); NMPC1's carried
  integral of the BHP error outside its band, leaking back inside it, clamped.

What do-mpc could not express, and was done through its documented low-level NLP API
(``prepare_nlp`` -> ``nlp_cons`` / ``nlp_obj`` -> ``create_nlp``):

* the hard slew limits |u_k - u_{k-1}| <= slew (k = 0..N-1, u_{-1} the applied input) and
  the protection's block-reference acceleration limit (rows on the second difference of the
  block reference, u_{-2} from the last reference speed): do-mpc bounds only variables;
* the quadratic part of the slack penalty T (xi^2 + xi): ``set_nl_cons`` penalises T xi.

Every simplification against the supervisor's NMPC1 (drill_nmpc.transcription and
drill_nmpc.supervisor), so what the comparison does *not* compare:

1. discretisation: do-mpc's orthogonal collocation (Radau, degree 2, one element per 1 s
   sample) instead of multiple shooting with 20 RK4 steps per sample: the same right-hand
   side, a different (less accurate: one degree-2 polynomial over the sample against 20
   RK4 steps of 0.05 s) integration of it; the stage map and its explicit Jacobian
   (``PredictionModel.function``, compiled with ``jit``) are not used;
2. solver: IPOPT run to convergence per sample (do-mpc's default options, output
   silenced) instead of one Gauss-Newton SQP step (the real-time iteration, HPIPM);
   exact Hessian of the Lagrangian instead of the cost's; do-mpc's warm start is the
   previous solution as it is (not shifted one stage), with its multipliers;
3. scaling: do-mpc's is multiplicative only (states by ``PredictionModel.scale``, inputs by
   their spans) where the project scales deviations from x_0 and u_{-1} (by the state
   scale and the slew limits);
4. NMPC1's integral state is continuous over the horizon (de/dt = (BHP - BHP_sp)/span)
   instead of the transcription's forward-Euler sum from the stage-start outputs, and only
   the BHP's is modelled: the choke-dp integral has weight 0 (Q_c = 0.1 W_c, W_c = 0);
5. the costs sit on stages 0..N (do-mpc's l-term at 0..N-1 plus its m-term at N; stage 0's
   output and integral terms are constants, so the minimiser is that of stages 1..N) and the soft state
   constraints on stages 0..N-1 (stage 0's slacks are fixed by x_0, not by the decisions,
   so the minimiser is that of 1..N-1); two-sided bands have one slack per side (one is zero
   wherever the other is not: the same penalty);
6. left out: the model's BHP bias learnt from its one-step errors (``bhp_bias_gain``: the
   peer predicts without it), the cap of the friction parameters for a stable RK4 step
   (there is no RK4 step), the monotone trip corridor of the block reference
   (``Supervisor.block_range``: the input bounds alone), the trust region on the states,
   the relaxed retry and the rollout of the fallback policy (an unsuccessful solve holds
   the last input, counted as a hold), the braking of a held block reference, and the
   actuator outputs carried over from the previous prediction (the loop measures them);
7. the choke input is the flow reference (config/nmpc.yaml's ``choke_control: flow``);
   the pressure-loop variant (``choke_control: pressure``) is not built here;
8. the per-sample references, levels and NMPC1's carried integrals are the supervisor's own
   (``Supervisor.setpoint_vector``, ``levels``, ``block_profile``, ``carried_integral``,
   from a Supervisor the peer keeps for them: drill_nmpc.peer_base, shared with the GEKKO
   peer); its last period's block speed and the reference trajectory (59) are two lines
   written again;
9. the step reports no objective value (``SolveResult.cost`` NaN: do-mpc keeps none) and
   no predicted output trajectories, only the planned inputs and the slacks.

    python -m drill_nmpc.peers [--samples 150] [--out-at 5] [--friction-factor 1]

prints median / p99 solve time and BHP RMSE of this peer, of the GEKKO one
(drill_nmpc.peer_gekko) and of the project's supervisor on the same bench loop (``drill_nmpc.bench.closed_loop``, one function for both: the shared
model as the plant, exact state feedback; Case 2 from its steady state -- 1000 L/min, 20 bar
choke dp, BHP held at its start within +-2 bar, the dp band up to the BHP band's bottom --
with the bench's schedule: the 28 m pull-out from ``--out-at``, the run back in from 0.6 of
the run). Solve times are wall times on whatever machine runs it.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings

import casadi as ca
import numpy as np

from drill_core.config import RigConfig, load_rig
from drill_core.input_layout import U_BLOCK, U_SIZE
from drill_core.rig_root import config_dir as default_config_dir
from drill_core.scenario import ActiveSetpoints
from drill_nmpc.bench import closed_loop, distribution
from drill_nmpc.peer_base import BHP, NmpcPeer
from drill_nmpc.peer_gekko import GekkoPeer
from drill_nmpc.prediction_model import nmpc_estimation_model, outputs
from drill_nmpc.soft_constraints import StageValues, soft_constraints
from drill_nmpc.solve_result import SolveResult
from drill_nmpc.supervisor import Supervisor

with warnings.catch_warnings():      # do-mpc warns at import about its optional extras (ONNX, torch)
    warnings.simplefilter("ignore")
    import do_mpc

CASE2_DP_BAND_UPPER_PA = 6.63e7      # config/scenarios/case2.yaml: dp up to the BHP band's bottom
# Case 2 (config/scenarios/case2.yaml) on the bench loop, beyond bench's defaults (its steady
# state, +-2 bar BHP band, 20 bar dp reference, 0.5 m/s): the dp band's upper edge.
CASE2 = {"dp_band_upper_pa": CASE2_DP_BAND_UPPER_PA}


class DoMpcPeer(NmpcPeer):
    """NMPC1 in do-mpc, with the supervisor's ``step`` interface (drill_nmpc.bench's loop).

    ``step(x_hat, setpoints, u_prev, actuators=...)`` returns a :class:`SolveResult` whose
    ``u`` is finite, inside the input bounds and the slew limits of u_{-1}; ``solve_time_s``
    is the wall time of the whole step (do-mpc's ``make_step`` and the per-sample data), and
    ``make_step_s`` (list, per step) that of ``make_step`` alone (IPOPT and do-mpc's
    bookkeeping).
    """

    def __init__(self, config: RigConfig, em=None, *, nlpsol_opts: dict | None = None):
        super().__init__(config, em)
        self.model = self._build_model()
        self.mpc = self._build_mpc(nlpsol_opts or {})
        self._started = False
        self.make_step_s: list[float] = []

    # -- construction -------------------------------------------------------------------
    def _build_model(self):
        """The do-mpc model: the prediction model's states, inputs and right-hand side."""
        m, em, cfg = self.model_pred, self.em, self.cfg
        model = do_mpc.model.Model("continuous", "SX")
        self.x_names = tuple(m.layout.names) + ("bhp_integral",)
        self.par_names = tuple(em.names[m.nd_model:])
        x = [model.set_variable("_x", name) for name in m.layout.names]
        e = model.set_variable("_x", "bhp_integral")
        u = [model.set_variable("_u", name) for name in self.u_names]
        par = [model.set_variable("_p", name) for name in self.par_names]
        pump_on = model.set_variable("_p", "pump_on")
        tv = {name: model.set_variable("_tvp", name) for name in (
            "ref_block_m", "ref_choke_dp_pa", "ref_bhp_pa", "bhp_setpoint_pa",
            *(f"u_ref_{n}" for n in self.u_names),
            "bhp_low_pa", "bhp_high_pa", "dp_low_pa", "dp_high_pa", "velocity_limit_mps",
            "previous_block_step_m")}
        rhs = m.rhs(x, u, par, pump_on)
        for name, expr in zip(m.layout.names, rhs):
            model.set_rhs(name, expr)
        full = m.full(x, par)
        y = outputs(em, full)
        model.set_rhs("bhp_integral", (y[BHP] - tv["bhp_setpoint_pa"]) / self.y_span[BHP])
        model.setup()
        # what the cost and the soft constraints read: expressions of the set-up model's
        # symbols (setup replaces the ones set_variable returned)
        x = [model.x[name] for name in m.layout.names]
        e = model.x["bhp_integral"]
        u = [model.u[name] for name in self.u_names]
        par = [model.p[name] for name in self.par_names]
        pump_on = model.p["pump_on"]
        tv = {name: model.tvp[name] for name in tv}
        full = m.full(x, par)
        y = outputs(em, full)
        w_y = np.array(cfg.output_weight.as_tuple(), dtype=float)
        refs = (tv["ref_block_m"], tv["ref_choke_dp_pa"], tv["ref_bhp_pa"])
        q_e = cfg.integral_weight_factor * w_y[BHP]
        self._output_cost = sum(w_y[i] * ((y[i] - refs[i]) / self.y_span[i]) ** 2
                                for i in range(3) if w_y[i] > 0.0) + q_e * e ** 2
        r_r, span = self.inputs["reference_weight"], self.inputs["span"]
        self._input_cost = sum(r_r[i] * ((u[i] - tv[f"u_ref_{self.u_names[i]}"]) / span[i]) ** 2
                               for i in range(U_SIZE) if r_r[i] > 0.0)
        values = StageValues(em, m, x, u, full, y)
        edges = {"velocity": (-tv["velocity_limit_mps"], tv["velocity_limit_mps"]),
                 "bhp_band": (tv["bhp_low_pa"], tv["bhp_high_pa"]),
                 "choke_dp_band": (tv["dp_low_pa"], tv["dp_high_pa"])}
        self._soft = []       # (name, expression <= 0 in slack units, weight)
        for c in soft_constraints():
            v = c.value(values)
            weight = getattr(cfg, c.weight)
            if c.band:
                lo, hi = edges[c.name]
                self._soft.append((f"{c.name}_low", (lo - v) / c.slack_unit, weight))
                self._soft.append((f"{c.name}_high", (v - hi) / c.slack_unit, weight))
            else:
                # a margin kept >= 0; dropped while the mud pump is off where the table says so
                gate = pump_on if c.needs_circulation else 1.0
                self._soft.append((c.name, -gate * v / c.slack_unit, weight))
        return model

    def _build_mpc(self, nlpsol_opts: dict):
        mpc = do_mpc.controller.MPC(self.model)
        s = mpc.settings
        s.n_horizon = self.N
        s.t_step = self.ts
        s.store_full_solution = False
        s.store_lagr_multiplier = False
        s.store_solver_stats = ["success", "iter_count"]     # numbers only (do-mpc stacks them)
        s.supress_ipopt_output()
        s.nlpsol_opts.update(nlpsol_opts)
        mpc.set_objective(lterm=self._output_cost + self._input_cost, mterm=self._output_cost)
        mpc.set_rterm(**{n: float(r) for n, r in zip(self.u_names, self.inputs["move_weight"])})
        for i, name in enumerate(self.u_names):
            mpc.bounds["lower", "_u", name] = self.u_min[i]
            mpc.bounds["upper", "_u", name] = self.u_max[i]
            mpc.scaling["_u", name] = self.inputs["span"][i]
        for name, scale in zip(self.model_pred.layout.names, self.model_pred.scale()):
            mpc.scaling["_x", name] = scale
        self._soft_weights = {}
        for name, expr, weight in self._soft:
            mpc.set_nl_cons(name, expr, ub=0.0, soft_constraint=True, penalty_term_cons=weight)
            self._soft_weights[name] = weight
        self._tvp = mpc.get_tvp_template()
        mpc.set_tvp_fun(lambda t_now: self._tvp)
        self._p = mpc.get_p_template(1)
        mpc.set_p_fun(lambda t_now: self._p)

        with warnings.catch_warnings():   # do-mpc calls numpy on casadi values (casadi 3.8 notice)
            warnings.filterwarnings("ignore", message=r"\s*casadi: a numpy function was called",
                                    category=FutureWarning)
            mpc.prepare_nlp()
        ux = mpc.opt_x_unscaled
        prev = mpc.opt_p["_u_prev"]
        slew = ca.DM(self.slew)
        steps = []
        for k in range(self.N):
            u_k = ux["_u", k, 0]
            step = u_k - (prev if k == 0 else ux["_u", k - 1, 0])
            steps.append(step[U_BLOCK])
            mpc.nlp_cons.append(step / slew)               # slew rows in slew units
            mpc.nlp_cons_lb.append(-np.ones((U_SIZE, 1)))
            mpc.nlp_cons_ub.append(np.ones((U_SIZE, 1)))
        if self.acceleration:
            limit = self.acceleration * self.ts ** 2 / self.slew[U_BLOCK]
            before = mpc.opt_p["_tvp", 0, "previous_block_step_m"]
            for k in range(self.N):
                change = steps[k] - (before if k == 0 else steps[k - 1])
                mpc.nlp_cons.append(change / self.slew[U_BLOCK])
                mpc.nlp_cons_lb.append(np.full((1, 1), -limit))
                mpc.nlp_cons_ub.append(np.full((1, 1), limit))
        # the quadratic part of the exact penalty T (xi^2 + xi) (set_nl_cons adds T xi)
        quadratic = 0
        for k in range(self.N):
            for name, weight in self._soft_weights.items():
                quadratic += weight * mpc.opt_x["_eps", k, 0, name] ** 2
        mpc.nlp_obj += quadratic
        mpc.create_nlp()
        return mpc

    # -- one sample ---------------------------------------------------------------------
    def step(self, x_hat, setpoints: ActiveSetpoints, u_prev, disturbance=None,
             actuators: dict | None = None) -> SolveResult:
        t0 = time.perf_counter()
        s = self.sample(x_hat, setpoints, u_prev, disturbance, actuators)
        tvp = self._tvp
        for k in range(self.N + 1):
            values = {"ref_block_m": s.y_ref[k, 0], "ref_choke_dp_pa": s.y_ref[k, 1],
                      "ref_bhp_pa": s.y_ref[k, 2], "bhp_setpoint_pa": s.bhp_setpoint_pa,
                      "bhp_low_pa": s.bhp_band_pa[0], "bhp_high_pa": s.bhp_band_pa[1],
                      "dp_low_pa": s.dp_band_pa[0], "dp_high_pa": s.dp_band_pa[1],
                      "velocity_limit_mps": s.velocity_limit_mps,
                      "previous_block_step_m": s.speed_mps * self.ts}
            values.update({f"u_ref_{n}": s.u_ref[i] for i, n in enumerate(self.u_names)})
            for name, value in values.items():
                tvp["_tvp", k, name] = value
        for name, value in zip(self.par_names, s.par):
            self._p["_p", 0, name] = value
        self._p["_p", 0, "pump_on"] = 1.0 if s.pump_on else 0.0

        state = np.concatenate([s.x0, [s.integral]]).reshape(-1, 1)
        u_prev = s.u_prev
        mpc = self.mpc
        mpc.u0 = u_prev.reshape(-1, 1)         # u_{-1} of the r-term and the slew rows
        if not self._started:                   # cold: every stage at x_0 and u_{-1}
            mpc.x0 = state
            mpc.set_initial_guess()
            self._started = True
        t_solve = time.perf_counter()
        try:
            u_opt = np.asarray(mpc.make_step(state), dtype=float).ravel()
            stats = mpc.solver_stats
        except RuntimeError as exc:             # an evaluation error inside IPOPT
            u_opt, stats = u_prev.copy(), {"success": False, "return_status": f"error: {exc}"[:120]}
        self.make_step_s.append(time.perf_counter() - t_solve)
        planned = np.array([np.asarray(mpc.opt_x_num_unscaled["_u", k, 0]).ravel()
                            for k in range(self.N)])
        slacks = {}
        for c in soft_constraints():
            names = [f"{c.name}_low", f"{c.name}_high"] if c.band else [c.name]
            slacks[c.name] = max(float(mpc.opt_x_num["_eps", k, 0, n]) for n in names
                                 for k in range(1, self.N)) * c.slack_unit
        return self.result(s, u_opt, bool(stats.get("success", False)),
                           str(stats.get("return_status", "")), int(stats.get("iter_count", -1)),
                           t0, slacks, planned)


def run_loop(config: RigConfig, controller, samples: int, *, out_at: float = 5.0,
             in_at: float | None = None, friction_factor: float = 1.0) -> dict:
    """Case 2 on drill_nmpc.bench's loop with ``controller`` (the supervisor or a peer): the
    stand pulled from ``out_at`` and run back in from ``in_at`` (None: bench's 0.6 of the
    run); per-sample solve times [s], the BHP RMSE [Pa] and the log."""
    log, _ = closed_loop(config, "NMPC1", samples, out_at=out_at, in_at=in_at,
                         supervisor=controller, friction_factor=friction_factor, **CASE2)
    a = log.arrays()
    err = a["bhp_pa"] - a["bhp_ref_pa"]
    return {"solve_time_s": a["solve_time_s"], "bhp_rmse_pa": float(np.sqrt(np.mean(err ** 2))),
            "bhp_max_error_pa": float(np.max(np.abs(err))),
            "fallbacks": int(np.sum(a["fallback"] != "none")), "log": log}


def compare(samples: int = 150, config_dir=None, out_at: float = 5.0,
            friction_factor: float = 1.0) -> dict:
    """do-mpc's and GEKKO's NMPC1 and the project's supervisor on the same loop, one run
    each; beyond the common keys, do-mpc's ``make_step`` median and GEKKO's own solve time
    (``SOLVETIME``, the ``apm`` run's solver) median [s]."""
    config = load_rig(config_dir or default_config_dir())
    em = nmpc_estimation_model(config, "NMPC1")
    out: dict = {"samples": samples, "out_at_s": out_at, "friction_factor": friction_factor}
    for name, build in (("do_mpc", lambda: DoMpcPeer(config, em)),
                        ("gekko", lambda: GekkoPeer(config, em)),
                        ("project", lambda: Supervisor(config, em, configuration="NMPC1"))):
        t0 = time.perf_counter()
        controller = build()
        build_s = time.perf_counter() - t0
        try:
            run = run_loop(config, controller, samples, out_at=out_at,
                           friction_factor=friction_factor)
        finally:
            if isinstance(controller, GekkoPeer):
                controller.close()
        dist = distribution(run["solve_time_s"])
        out[f"{name}_median_s"] = dist["median_s"]
        out[f"{name}_p99_s"] = dist["p99_s"]
        out[f"{name}_max_s"] = dist["max_s"]
        out[f"{name}_bhp_rmse_pa"] = run["bhp_rmse_pa"]
        out[f"{name}_bhp_max_error_pa"] = run["bhp_max_error_pa"]
        out[f"{name}_fallbacks"] = run["fallbacks"]
        out[f"{name}_build_s"] = build_s
        if isinstance(controller, DoMpcPeer):
            out["do_mpc_make_step_median_s"] = float(np.median(controller.make_step_s))
        if isinstance(controller, GekkoPeer):
            out["gekko_solver_median_s"] = float(np.median(controller.solver_time_s))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=150)
    parser.add_argument("--out-at", type=float, default=5.0, help="pull-out start [s]")
    parser.add_argument("--friction-factor", type=float, default=1.0,
                        help="plant friction theta scaled (1: the plant is the prediction model)")
    parser.add_argument("--config-dir", default=None)
    args = parser.parse_args(argv)
    print(json.dumps(compare(args.samples, args.config_dir, args.out_at, args.friction_factor),
                     indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
