"""The NMPC1 problem built in GEKKO (APMonitor, IMODE 6), run in the supervisor's loop.

The second peer of the comparison of issue 32 (item 3), beside drill_nmpc.peers' do-mpc
one, with the same problem data (drill_nmpc.peer_base: the prediction model, horizon,
weights, bounds, soft constraints and the supervisor's per-sample references). Only
GEKKO's API is called (PyPI ``gekko``, its bundled ``apm`` executable, ``remote=False``):

* the right-hand side is ``PredictionModel.rhs`` itself, evaluated on GEKKO expressions
  through the array namespace :func:`gekko_namespace` (drill_core.backend's functions:
  sqrt, tanh, log, exp from GEKKO; ``fmax`` and ``table`` below); the states are GEKKO
  variables in units of ``PredictionModel.scale``, the inputs in units of their spans; the
  frozen parameters (theta_2..theta_n, the density offset) and the pump state are GEKKO
  parameters set per sample, and so are the output references, levels and input
  references (a value per time point);
* the costs are the supervisor's: output tracking (block position, BHP), the integral
  Q_c = 0.1 W_c on NMPC1's BHP integral (a state, as in the do-mpc peer), input moves
  r~_i (du_i / span_i)^2, input references (bpp flow -> 0, stand-pipe pressure -> its
  first value), the five soft constraints of ``drill_nmpc.soft_constraints`` with the
  penalty T (xi^2 + xi) of their slacks; the input bounds, the slew limits and the
  protection's block acceleration limit are hard;
* one model is built in ``__init__`` and re-solved per sample (``step``): the measured
  prediction state, u_{-1} and the block's last move are the first time point's values,
  the other time points start from GEKKO's previous solution shifted one sample on (the
  warm start; GEKKO's own TIME_SHIFT is off because it would shift the fixed masks
  below too); IPOPT (``SOLVER`` 3, the MA57 build in GEKKO's ``apm``, GEKKO's default
  tolerances): the do-mpc peer's NLP solver, so the two differ in the modelling tool and
  the transcription rather than the solver (APOPT, GEKKO's default active-set solver, is
  meant for mixed-integer and smaller problems);
* the horizon is config/nmpc.yaml's (15 samples of 1 s), one input per sample; GEKKO
  writes its files to a temporary directory of its own, removed by :meth:`GekkoPeer.close`.

What GEKKO could not express as the supervisor's NMPC1 has it, and what was done instead
(the do-mpc peer's simplifications 4, 6, 7 and 8 hold here as well):

1. the friction tables: the string friction table and the annular stress tables are CasADi
   B-splines (``ca.interpolant``), which GEKKO cannot call; each table call is a GEKKO
   cubic spline (``cspline``: its own variable and its argument's) through the CasADi
   table's values at its grid points; between them the two cubics differ (the right-hand
   side agrees with the CasADi one to ~1e-5 relative, test_peers.py);
2. ``fmax`` (on this path only the bit's check valve, fmax(dp, 0)) is the smooth
   (a + b + sqrt((a - b)^2 + eps^2)) / 2 with eps = FMAX_SMOOTHING_PA, an NLP-friendly
   form instead of GEKKO's complementarity (max2) or integer (max3) ones: off by
   eps^2 / (4 dp), 2.5e-4 Pa at 1 bar over the bit, and a rounded corner at dp = 0;
3. discretisation: GEKKO's variables have no lag (u_{k-1} cannot be written), so each
   input is a state that integrates its move, the move a decision (an MV bounded by the
   slew limit) entering over the sample's first substep, and the block's move is a state
   integrating its change (an MV bounded by the acceleration limit): the hard slew and
   acceleration rows become bounds, exact. That needs GEKKO's NODES 2 (implicit Euler:
   with more nodes the integrated input would ramp over the sample), so the samples are
   cut into SUBSTEPS = 4 implicit Euler steps of 0.25 s (60 time points) instead of the
   supervisor's 20 RK4 steps of 0.05 s: the same right-hand side, less accurately
   integrated (one Euler step per sample: the BHP's one-step prediction ~0.3-0.9 bar off
   the loop's RK4 plant on the pull-out; four: ~0.2-0.6 bar); the costs and the slack
   penalties are weighted to the sample points by fixed masks, the soft constraints hold
   on every time point (slacks free between the sample points);
4. the costs sit on the sample points 0..N (the first point's terms are constants) and so
   do the soft constraints' penalties, one slack per side and time point; the
   choke-capacity row pairs the state at t_k with the input of the sample before it (the
   supervisor: with the input of the sample after it);
5. the friction law is the circulating one (``PredictionModel.rhs``'s
   ``friction_pump_on`` = 1): each table call is a spline GEKKO's ``apm`` reads per time
   point, and the pump-off law's tables would double them; ``pump_on`` still switches the
   mud pump and the circulation-only constraint (the supervisor builds one problem per
   pump state; Case 2 circulates throughout);
6. the step reports GEKKO's objective value (``SolveResult.cost``: this NLP's, in its
   scaled units, not the supervisor's) and no predicted outputs.

    python -m drill_nmpc.peers [--samples 150]

prints this peer beside the do-mpc one and the project's supervisor.
"""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
from gekko import GEKKO

from drill_core.input_layout import U_BLOCK
from drill_core.scenario import ActiveSetpoints
from drill_nmpc.peer_base import BHP, NmpcPeer
from drill_nmpc.prediction_model import outputs
from drill_nmpc.soft_constraints import StageValues, soft_constraints
from drill_nmpc.solve_result import SolveResult

FMAX_SMOOTHING_PA = 10.0     # the smooth max's corner width (its one use: a pressure drop)
SOLVER_IPOPT = 3             # GEKKO's m.options.SOLVER numbers
CONTROL_MODE = 6             # IMODE 6: simultaneous nonlinear MPC
SUCCESS = 1                  # m.options.APPSTATUS of a successful solve
SUBSTEPS = 4                 # implicit Euler steps per sample (module docstring, 3)
CIRCULATING = 1.0            # the friction law of the mud pump on (module docstring, 5)
ITERATIONS_NOT_REPORTED = -1 # apm leaves ITERATIONS at 0 under IPOPT


def values(variable) -> np.ndarray:
    """A GEKKO variable's values per time point."""
    return np.array(list(variable.value), dtype=float)


def shifted(trajectory: np.ndarray, points: int) -> np.ndarray:
    """A trajectory advanced by ``points`` time points, its last value held."""
    return np.concatenate([trajectory[points:], np.full(points, trajectory[-1])])


def gekko_namespace(m: GEKKO) -> SimpleNamespace:
    """drill_core.backend's array namespace on a GEKKO model's expressions (what the
    prediction model's right-hand side calls; the module docstring, 1 and 2)."""
    samples: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def fmax(a, b):
        return 0.5 * (a + b + m.sqrt((a - b) ** 2 + FMAX_SMOOTHING_PA ** 2))

    def table(function, v, grid):
        if id(function) not in samples:
            samples[id(function)] = grid, np.asarray(function(grid), dtype=float).ravel()
        argument, value = m.Var(), m.Var()
        m.Equation(argument == v)
        m.cspline(argument, value, *samples[id(function)])
        return value

    return SimpleNamespace(name="gekko", sqrt=m.sqrt, tanh=m.tanh, log=m.log, exp=m.exp,
                           fmax=fmax, table=table)


class GekkoPeer(NmpcPeer):
    """NMPC1 in GEKKO, with the supervisor's ``step`` interface (drill_nmpc.bench's loop).

    ``step(x_hat, setpoints, u_prev, actuators=...)`` returns a :class:`SolveResult` whose
    ``u`` is finite, inside the input bounds and the slew limits of u_{-1};
    ``solve_time_s`` is the wall time of the whole step (writing GEKKO's files, the ``apm``
    run, reading its results), ``solver_time_s`` (list, per step) GEKKO's own
    ``SOLVETIME`` (the ``apm`` run's solve). Call :meth:`close` when done.
    """

    def __init__(self, config, em=None, *, substeps: int = SUBSTEPS):
        super().__init__(config, em)
        self.substeps = substeps
        self.m = GEKKO(remote=False, name="nmpc1")
        self._build()
        self._started = False
        self.solver_time_s: list[float] = []

    # -- construction -------------------------------------------------------------------
    def _build(self) -> None:
        g, mp, em, cfg = self.m, self.model_pred, self.em, self.cfg
        m_sub = self.substeps
        n, h = self.N * m_sub + 1, self.ts / m_sub
        g.time = np.arange(n) * h
        index = np.arange(n)
        at_sample = g.Param(value=(index % m_sub == 0).astype(float))
        step_in = g.Param(value=((index % m_sub == 1 % m_sub) & (index > 0)).astype(float))
        span = self.inputs["span"]
        self.x_scale = mp.scale()
        self.states = [g.Var(value=0.0) for _ in range(mp.nd)]
        self.integral_state = g.Var(value=0.0)
        # the inputs (span units) integrate their moves, the block's its move's change
        self.scaled_inputs = [g.Var(value=0.0, lb=lo / s, ub=hi / s)
                              for lo, hi, s in zip(self.u_min, self.u_max, span)]
        self.moves = [g.Var(value=0.0, lb=-slew / s, ub=slew / s) if i == U_BLOCK
                      else self._decision(slew / s)
                      for i, (slew, s) in enumerate(zip(self.slew, span))]
        change_limit = self.acceleration * self.ts ** 2 / span[U_BLOCK] if self.acceleration \
            else 2.0 * self.slew[U_BLOCK] / span[U_BLOCK]
        block_change = self._decision(change_limit)
        self.decisions = [*(mv for i, mv in enumerate(self.moves) if i != U_BLOCK), block_change]
        self.parameters = [g.Param(value=0.0) for _ in range(mp.npar)]
        self.pump_on = g.Param(value=1.0)
        self.p = {name: g.Param(value=np.zeros(n)) for name in (
            "ref_block_m", "ref_choke_dp_pa", "ref_bhp_pa", "bhp_setpoint_pa", "bhp_low_pa",
            "bhp_high_pa", "dp_low_pa", "dp_high_pa", "velocity_limit_mps")}
        self.u_ref = [g.Param(value=np.zeros(n)) for _ in self.u_names]

        x = [s * k for s, k in zip(self.states, self.x_scale)]
        u = [s * k for s, k in zip(self.scaled_inputs, span)]
        rhs = mp.rhs(x, u, self.parameters, self.pump_on, CIRCULATING, xp=gekko_namespace(g))
        for state, scale, rate in zip(self.states, self.x_scale, rhs):
            g.Equation(state.dt() == rate / scale)
        # a sample's move enters over its first substep (the input held over the sample)
        for scaled, move in zip(self.scaled_inputs, self.moves):
            g.Equation(scaled.dt() == step_in * move / h)
        g.Equation(self.moves[U_BLOCK].dt() == step_in * block_change / h)
        full = mp.full(x, self.parameters)
        y = outputs(em, full)
        p = self.p
        g.Equation(self.integral_state.dt() == (y[BHP] - p["bhp_setpoint_pa"]) / self.y_span[BHP])

        w_y = np.array(cfg.output_weight.as_tuple(), dtype=float)
        refs = (p["ref_block_m"], p["ref_choke_dp_pa"], p["ref_bhp_pa"])
        for i in range(3):
            if w_y[i] > 0.0:
                g.Minimize(at_sample * w_y[i] * ((y[i] - refs[i]) / self.y_span[i]) ** 2)
        g.Minimize(at_sample * cfg.integral_weight_factor * w_y[BHP] * self.integral_state ** 2)
        for i, (r_r, r_move) in enumerate(zip(self.inputs["reference_weight"],
                                              self.inputs["move_weight"])):
            if r_r > 0.0:
                g.Minimize(at_sample * r_r * (self.scaled_inputs[i] - self.u_ref[i] / span[i]) ** 2)
            # the block's move is a state held over the sample, the others' decisions
            # that act only at the sample's first substep (0 elsewhere: the cost's minimum)
            g.Minimize((at_sample if i == U_BLOCK else 1.0) * r_move * self.moves[i] ** 2)
        g.Minimize((1.0 - step_in) * block_change ** 2)     # no effect off the first substep

        stage = StageValues(em, mp, x, u, full, y)
        edges = {"velocity": (-p["velocity_limit_mps"], p["velocity_limit_mps"]),
                 "bhp_band": (p["bhp_low_pa"], p["bhp_high_pa"]),
                 "choke_dp_band": (p["dp_low_pa"], p["dp_high_pa"])}
        self.slacks = {}           # constraint name -> its slack variables (slack units)
        for c in soft_constraints():
            v = c.value(stage)
            if c.band:
                lo, hi = edges[c.name]
                rows = ((lo - v) / c.slack_unit, (v - hi) / c.slack_unit)
            else:
                gate = self.pump_on if c.needs_circulation else 1.0
                rows = (-gate * v / c.slack_unit,)
            weight = getattr(cfg, c.weight)
            self.slacks[c.name] = []
            for row in rows:
                slack = g.Var(value=0.0, lb=0.0)
                g.Equation(row <= slack)
                g.Minimize(at_sample * weight * (slack ** 2 + slack))
                self.slacks[c.name].append(slack)

        o = g.options
        o.IMODE = CONTROL_MODE
        o.SOLVER = SOLVER_IPOPT
        o.NODES = 2
        o.TIME_SHIFT = 0                 # the warm start is shifted in step

    def _decision(self, bound: float):
        """A decision per sample in [-bound, bound] (a GEKKO MV, no cost of its own)."""
        mv = self.m.MV(value=0.0, lb=-bound, ub=bound)
        mv.STATUS = 1
        mv.DCOST = 0.0
        return mv

    # -- one sample ---------------------------------------------------------------------
    def step(self, x_hat, setpoints: ActiveSetpoints, u_prev, disturbance=None,
             actuators: dict | None = None) -> SolveResult:
        t0 = time.perf_counter()
        s = self.sample(x_hat, setpoints, u_prev, disturbance, actuators)
        span, m_sub = self.inputs["span"], self.substeps
        n = self.N * m_sub + 1
        sample_of_point = -(-np.arange(n) // m_sub)     # the sample point at or after each
        for param, value in zip(self.parameters, s.par):
            param.value = np.full(n, value)
        self.pump_on.value = np.full(n, 1.0 if s.pump_on else 0.0)
        y_ref = s.y_ref[sample_of_point]
        per_point = {"ref_block_m": y_ref[:, 0], "ref_choke_dp_pa": y_ref[:, 1],
                     "ref_bhp_pa": y_ref[:, 2], "bhp_setpoint_pa": s.bhp_setpoint_pa,
                     "bhp_low_pa": s.bhp_band_pa[0], "bhp_high_pa": s.bhp_band_pa[1],
                     "dp_low_pa": s.dp_band_pa[0], "dp_high_pa": s.dp_band_pa[1],
                     "velocity_limit_mps": s.velocity_limit_mps}
        for name, value in per_point.items():
            self.p[name].value = np.broadcast_to(value, (n,)).astype(float)
        for param, value in zip(self.u_ref, s.u_ref):
            param.value = np.full(n, value)
        # the first time point: the measured state, u_{-1} and the block's last move
        initial = [*(s.x0 / self.x_scale), s.integral, *(s.u_prev / span),
                   s.speed_mps * self.ts / span[U_BLOCK]]
        variables = [*self.states, self.integral_state, *self.scaled_inputs,
                     self.moves[U_BLOCK]]
        if not self._started:            # cold: every time point at the first one's values
            for var, value in zip(variables, initial):
                var.value = np.full(n, value)
            self._started = True
        else:                            # warm: the previous solution one sample on
            for var, value in zip(variables, initial):
                var.value = np.concatenate([[value], shifted(values(var), m_sub)[1:]])
            for mv in self.decisions:
                mv.value = shifted(values(mv), m_sub)

        m = self.m
        try:
            m.solve(disp=False)
            success = m.options.APPSTATUS == SUCCESS
            status = "success" if success else f"APPSTATUS {m.options.APPSTATUS}"
        except Exception as exc:         # GEKKO raises on an unsuccessful apm run
            success, status = False, f"error: {exc}".strip()[:120]
        self.solver_time_s.append(float(m.options.SOLVETIME))
        planned = np.array([values(v)[m_sub::m_sub] * k
                            for v, k in zip(self.scaled_inputs, span)]).T
        slacks = {c.name: max(float(np.max(values(v)[m_sub:self.N * m_sub:m_sub]))
                              for v in self.slacks[c.name]) * c.slack_unit
                  for c in soft_constraints()}
        return self.result(s, planned[0], success, status, ITERATIONS_NOT_REPORTED, t0,
                           slacks, planned, cost=float(m.options.OBJFCNVAL))

    def close(self) -> None:
        """Remove GEKKO's temporary directory."""
        self.m.cleanup()
