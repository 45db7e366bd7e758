"""What the NMPC1 peers (drill_nmpc.peers: do-mpc; drill_nmpc.peer_gekko: GEKKO) share.

The problem's data from the project's configuration (the prediction model, the horizon,
the input bounds, spans and slew limits), the supervisor's per-sample references (from a
``Supervisor`` kept for them), the clipping of the command into the slew, acceleration and
input limits, and the ``SolveResult`` of a step. Each peer builds and solves its own
problem from these; the simplifications are listed in the peers' docstrings.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from drill_core.config import RigConfig
from drill_core.input_layout import U_BLOCK, U_CHOKE, U_PUMP_PRESSURE
from drill_core.scenario import ActiveSetpoints
from drill_nmpc.inputs import choke_time_constant, input_arrays
from drill_nmpc.prediction_model import (ActuatorLags, PredictionModel, StringFrictionTable,
                                         full_state, nmpc_estimation_model, outputs)
from drill_nmpc.soft_constraints import SLACK_NAMES
from drill_nmpc.solve_result import Fallback, SolveResult
from drill_nmpc.supervisor import Supervisor
from drill_nmpc.transcription import INTEGRAL_OUTPUTS

BHP = 2                              # index of the BHP in the outputs [block, choke dp, BHP]


def input_names(config: RigConfig) -> tuple[str, ...]:
    """The supervisor's input names, in the input vector's order (config/nmpc.yaml)."""
    return tuple(f.name for f in dataclasses.fields(config.nmpc.input_min))


@dataclass(frozen=True)
class Sample:
    """One sample's data of the NMPC1 problem, as the supervisor sets it up."""
    u_prev: np.ndarray             # u_{-1}, the applied input (finite, inside the bounds)
    speed_mps: float               # the block reference's speed over the last period
    x0: np.ndarray                 # the prediction state at the estimate
    par: np.ndarray                # the frozen parameters (theta_2..theta_n, density offset)
    pump_on: bool
    y_ref: np.ndarray              # (N + 1, 3) output references [m, Pa, Pa]
    bhp_setpoint_pa: float
    velocity_limit_mps: float
    bhp_band_pa: tuple[float, float]
    dp_band_pa: tuple[float, float]
    u_ref: np.ndarray              # input references of the input reference weights
    integral: float                # NMPC1's carried BHP integral [span s]


class NmpcPeer:
    """The supervisor's NMPC1 data for a peer with its ``step`` interface (drill_nmpc.bench's
    loop); a subclass builds the problem and solves it in ``step``."""

    configuration = "NMPC1"

    def __init__(self, config: RigConfig, em=None):
        cfg = config.nmpc
        if cfg.choke_control != "flow":
            raise ValueError("the peers are built for choke_control flow")
        self.config, self.cfg = config, cfg
        self.em = em = em or nmpc_estimation_model(config, self.configuration)
        if em.with_disturbance:
            raise ValueError("NMPC1 predicts without the influx state")
        lags = ActuatorLags.from_config(config) if cfg.actuator_lags_in_model else None
        table = StringFrictionTable(em.wm)
        self.model_pred = PredictionModel(em, lags, table if table.applies() else None,
                                          choke_time_constant(cfg))
        self.N, self.ts = cfg.prediction_steps, cfg.sample_time_s
        if cfg.control_steps != self.N:
            raise ValueError("a peer optimises an input per stage: control_steps must equal "
                             "prediction_steps")
        self.inputs = input_arrays(cfg)
        self.u_min, self.u_max = self.inputs["min"], self.inputs["max"]
        self.slew = self.inputs["slew"]
        self.acceleration = config.protection.trip_acceleration_max_mps2
        self.alpha = np.array(cfg.reference_smoothing.as_tuple(), dtype=float)
        self.y_span = np.array(cfg.output_span.as_tuple(), dtype=float)
        self.u_names = input_names(config)
        self.references = Supervisor(config, em)   # its per-sample references and levels
        # carried between samples, as the supervisor carries them
        self.integral = 0.0                          # the BHP's, the one with a weight
        self._integrals = np.zeros(len(INTEGRAL_OUTPUTS))
        self.spp_nominal: float | None = None
        self._applied: np.ndarray | None = None
        self.solve_count = 0
        self.fallback_count = 0

    def safe_input(self, u_prev) -> np.ndarray:
        u = np.asarray(u_prev, dtype=float).ravel()[:len(self.u_min)].copy()
        bad = ~np.isfinite(u)
        u[bad] = np.clip(0.0, self.u_min, self.u_max)[bad]
        return np.clip(u, self.u_min, self.u_max)

    def limit(self, u, u_prev, reference_speed: float) -> np.ndarray:
        """The command clipped into the slew, acceleration and input limits around u_prev
        (the solvers meet them to their tolerance)."""
        u = np.where(np.isfinite(u), u, u_prev)
        lo, hi = u_prev - self.slew, u_prev + self.slew
        if self.acceleration:
            step = self.acceleration * self.ts ** 2
            lo[U_BLOCK] = max(lo[U_BLOCK], u_prev[U_BLOCK] + reference_speed * self.ts - step)
            hi[U_BLOCK] = min(hi[U_BLOCK], u_prev[U_BLOCK] + reference_speed * self.ts + step)
        return np.clip(np.clip(u, lo, hi), self.u_min, self.u_max)

    def sample(self, x_hat, setpoints: ActiveSetpoints, u_prev, disturbance=None,
               actuators: dict | None = None) -> Sample:
        """The sample's problem data: the supervisor's own per-sample rules for the
        set-points and references, and its carried integral (counts the solve)."""
        em, m, cfg = self.em, self.model_pred, self.cfg
        u_prev = self.safe_input(u_prev)
        speed = 0.0 if self._applied is None else \
            float(u_prev[U_BLOCK] - self._applied[U_BLOCK]) / self.ts
        self._applied = u_prev.copy()
        self.solve_count += 1
        x = full_state(em, x_hat, disturbance)
        if self.spp_nominal is None:
            self.spp_nominal = float(u_prev[U_PUMP_PRESSURE])
        pump_on = bool(setpoints.mud_pump_on)
        x0 = m.initial_state(x, u_prev, actuators or {}, pump_on)
        par = x[m.nd_model:]
        y_now = np.array([float(v) for v in outputs(em, x)])
        sup = self.references
        y_sp = sup.setpoint_vector(x, setpoints, par)
        vlim, bhp_band, dp_band = sup.levels(setpoints, y_sp)
        y_ref = np.array([self.alpha ** j * y_now + (1.0 - self.alpha ** j) * y_sp
                          for j in range(self.N + 1)])
        if cfg.block_reference == "profile":
            y_ref[:, 0] = sup.block_profile(float(x[em.position]), float(y_sp[0]), vlim)
        self._integrals = sup.carried_integral(self._integrals, y_now, dp_band, bhp_band)
        self.integral = float(self._integrals[INTEGRAL_OUTPUTS.index(BHP)])
        u_ref = np.array([y_sp[0], u_prev[U_CHOKE], 0.0, self.spp_nominal])
        return Sample(u_prev, speed, x0, par, pump_on, y_ref, float(y_sp[BHP]), vlim,
                      bhp_band, dp_band, u_ref, self.integral)

    def result(self, s: Sample, u_opt, success: bool, status: str, iterations: int,
               started_s: float, slacks: dict, planned: np.ndarray,
               cost: float = math.nan) -> SolveResult:
        """The step's result: the solver's first input clipped into the limits, or, where
        the solve failed, the last input held (counted as a fallback); ``cost`` the peer's
        own objective value (NaN: none)."""
        success = success and bool(np.all(np.isfinite(u_opt)))
        if success:
            u, fallback = self.limit(u_opt, s.u_prev, s.speed_mps), Fallback.NONE
        else:
            self.fallback_count += 1
            u, fallback = self.limit(s.u_prev, s.u_prev, s.speed_mps), Fallback.HOLD
        return SolveResult(u=u, success=success, fallback=fallback, status=status,
                           iterations=iterations,
                           solve_time_s=time.perf_counter() - started_s,
                           cost=cost if success else math.nan,
                           slacks=slacks if success else {n: math.nan for n in SLACK_NAMES},
                           planned_inputs=planned if success else np.tile(u, (self.N, 1)),
                           reference=s.y_ref, integral=np.array([s.integral]),
                           configuration=self.configuration)
