"""In-process closed loop of the NMPC supervisor and its solve-time benchmark (no ROS).

The "plant" here is the shared estimation model itself (RK4 with 20 steps per sample; the
string friction from the same B-spline table as the supervisor unless ``exact``) plus the
actuator lags (drawworks, back-pressure pump, mud pump), optionally with a friction
mismatch (theta scaled) and a bottom influx, and the supervisor sees its exact state: a
test bed for the optimiser, not a substitute for the ROS graph with the truth plant, the
actuators and the UKF.

    python -m drill_nmpc.bench [--samples 150] [--solver sqpmethod] [--jit]

prints the solve-time distribution per configuration (median, p95, p99, max) and the
ratio to the 16.4 s per solve of the paper's MATLAB implementation.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from drill_core import hydraulics as hy
from drill_core.config import RigConfig, load_rig
from drill_core.estimation_model import EstimationModel, fitted_friction_parameters
from drill_core.input_layout import U_CHOKE
from drill_core.operating_point import BENCH_POINT, initial_operating_point
from drill_core.rig_root import config_dir as default_config_dir
from drill_core.scenario import ActiveSetpoints, Initial
from drill_nmpc.inputs import choke_input, choke_time_constant
from drill_nmpc.prediction_model import (ActuatorLags, PredictionModel, StringFrictionTable,
                                         full_state, nmpc_estimation_model, outputs)
from drill_nmpc.supervisor import Supervisor
from drill_nmpc.transcription import RTI_PARTS

PAPER_SOLVE_TIME_S = 16.4          # Tengesdal & Holden 2020, sec. 6.3.4 (MATLAB fmincon, NMPC0)
TRIP_DISTANCE_M = 28.0


def steady_estimate(em: EstimationModel, initial: Initial) -> tuple[np.ndarray, np.ndarray]:
    """Estimation-model state and inputs u_{-1} at a scenario's steady operating point.

    Design knowledge, not truth: the closed-form steady circulation of the well
    (drill_core.operating_point) in the estimation layout, with
    theta_i fitted to the Herschel-Bulkley friction at that flow (the model's law).
    """
    wm = em.wm
    op = initial_operating_point(wm, initial)
    x = np.zeros(em.size)
    for i in range(1, wm.n + 1):
        x[em.pressure(i)] = op.annulus_pressure_pa[i - 1]
    for i in range(2, wm.n + 1):
        x[em.flow(i)] = op.annulus_flow_m3s[i - 2]
    x[em.string_flow] = op.string_flow_m3s
    x[em.string_pressure] = op.string_pressure_pa
    flows = np.full(wm.n - 1, initial.circulation_m3s)
    friction = hy.annulus_friction(np, wm, flows, 0.0)
    x[em.theta(2):em.theta(wm.n) + 1] = fitted_friction_parameters(em, flows, friction)
    if em.with_string_friction:
        x[em.string_friction] = 1.0          # the mud report's string friction
    if em.with_bulk_modulus:
        x[em.bulk_modulus] = 1.0             # the mud report's bulk modulus
    u = np.array([0.0, op.choke_flow_m3s, initial.bpp_flow_m3s, op.spp_pa])
    return x, u


def supervisor_input(config: RigConfig, u: np.ndarray, initial: Initial) -> np.ndarray:
    """The supervisor's input vector at a steady state's inputs (inputs.choke_input)."""
    u = np.array(u, dtype=float)
    u[U_CHOKE] = choke_input(config.nmpc, u[U_CHOKE], initial.choke_dp_pa)
    return u


class ModelPlant:
    """The estimation model (+ drawworks lag) as a deterministic plant, one sample per call;
    with choke_control pressure its choke is the prediction's ideal pressure loop."""

    def __init__(self, config: RigConfig, em: EstimationModel, x0: np.ndarray, u0: np.ndarray,
                 friction_factor: float = 1.0, substeps: int = 20, exact: bool = False):
        em_d = dataclasses.replace(em, with_disturbance=True)
        self.em = em_d
        # exact=False evaluates the string friction from the B-spline table (< 0.01 bar off,
        # builds in a fraction of the time); the rest of the model is the shared drift.
        self.model = PredictionModel(em_d, ActuatorLags.from_config(config),
                                     None if exact else StringFrictionTable(em_d.wm),
                                     choke_time_constant(config.nmpc))
        self.step_fn = self.model.function(config.nmpc.sample_time_s, substeps, "rk4")
        full = full_state(em_d, x0, 0.0)
        self.par = full[self.model.nd_model:].copy()
        self.par[:em.n - 1] *= friction_factor
        self.x = self.model.initial_state(full, u0)

    @property
    def influx_m3s(self) -> float:
        return float(self.par[-1])

    @influx_m3s.setter
    def influx_m3s(self, value: float) -> None:
        self.par[-1] = value

    def actuators(self) -> dict:
        """Actuator outputs (block, bpp flow, stand-pipe pressure), as their frames report them."""
        return self.model.actuator_state(self.x)

    def state(self, em: EstimationModel) -> np.ndarray:
        """The plant state in the layout of ``em`` (what a perfect estimator would report)."""
        full = np.array(self.model.full(self.x, self.par), dtype=float)
        return em.vector(dict(zip(self.em.names, full)))

    def advance(self, u, pump_on: bool = True) -> None:
        self.x = np.asarray(self.step_fn(self.x, u, self.par, 1.0 if pump_on else 0.0),
                            dtype=float).ravel()


@dataclass
class LoopLog:
    """Closed-loop record, one row per sample (SI)."""
    time_s: list = field(default_factory=list)
    block_position_m: list = field(default_factory=list)
    velocity_mps: list = field(default_factory=list)
    bhp_pa: list = field(default_factory=list)
    bhp_ref_pa: list = field(default_factory=list)
    choke_dp_pa: list = field(default_factory=list)
    inputs: list = field(default_factory=list)
    solve_time_s: list = field(default_factory=list)
    iterations: list = field(default_factory=list)
    fallback: list = field(default_factory=list)
    status: list = field(default_factory=list)

    def arrays(self) -> dict:
        return {k: np.asarray(v) for k, v in dataclasses.asdict(self).items()}


def trip_setpoints(t: float, out_at: float, in_at: float, bhp_ref: float = math.nan,
                   dp_band_upper_pa: float = 0.0) -> ActiveSetpoints:
    """Case 1-3 style schedule: pull a stand out at ``out_at``, run it back in at ``in_at``
    (choke dp band +-5 bar, or up to ``dp_band_upper_pa`` above its reference)."""
    target = TRIP_DISTANCE_M if out_at <= t < in_at else 0.0
    return ActiveSetpoints(bhp_ref_pa=bhp_ref, bhp_band_pa=2.0e5, choke_dp_ref_pa=2.0e6,
                           choke_dp_band_pa=5.0e5, block_position_target_m=target,
                           trip_speed_limit_mps=0.5, controller_enabled=True, mud_pump_on=True,
                           choke_dp_band_upper_pa=dp_band_upper_pa)


def closed_loop(config: RigConfig, configuration: str, samples: int, *, out_at: float = 5.0,
                in_at: float | None = None, supervisor: Supervisor | None = None,
                friction_factor: float = 1.0, influx_m3s: float = 0.0,
                solver: str | None = None, jit: bool | None = None,
                initial: Initial | None = None, measured_actuators: bool = True,
                dp_band_upper_pa: float = 0.0) -> tuple[LoopLog, Supervisor]:
    """Run ``samples`` supervisor steps on the model plant (perfect state feedback)."""
    initial = initial or BENCH_POINT
    em = nmpc_estimation_model(config, configuration)
    x0, u = steady_estimate(em, initial)
    sup = supervisor or Supervisor(config, em, configuration=configuration, solver=solver, jit=jit)
    plant = ModelPlant(config, em, x0, u, friction_factor=friction_factor)
    u = supervisor_input(config, u, initial)
    plant.influx_m3s = influx_m3s
    ts = config.nmpc.sample_time_s
    in_at = in_at if in_at is not None else 0.6 * samples * ts
    log = LoopLog()
    bhp_ref = float(outputs(em, x0)[2])
    for k in range(samples):
        t = k * ts
        x = plant.state(em)
        sp = trip_setpoints(t, out_at, in_at, bhp_ref, dp_band_upper_pa)
        res = sup.step(x, sp, u, actuators=plant.actuators() if measured_actuators else None)
        y = outputs(em, x)
        log.time_s.append(t)
        log.block_position_m.append(float(y[0]))
        log.velocity_mps.append(float(x[em.velocity]))
        log.bhp_pa.append(float(y[2]))
        log.bhp_ref_pa.append(bhp_ref)
        log.choke_dp_pa.append(float(y[1]))
        log.inputs.append(res.u.copy())
        log.solve_time_s.append(res.solve_time_s)
        log.iterations.append(res.iterations)
        log.fallback.append(res.fallback.value)
        log.status.append(res.status)
        u = res.u
        plant.advance(u)
    return log, sup


def distribution(times) -> dict:
    t = np.asarray(times, dtype=float)
    return {"median_s": float(np.median(t)), "p95_s": float(np.percentile(t, 95)),
            "p99_s": float(np.percentile(t, 99)), "max_s": float(np.max(t)),
            "mean_s": float(np.mean(t)), "samples": int(t.size)}


def run_benchmark(samples: int = 150, configurations=("NMPC0", "NMPC1", "NMPC2"),
                  solver: str | None = None, jit: bool | None = None,
                  config_dir: str | os.PathLike | None = None) -> dict:
    """Solve-time distribution per configuration on the Case 1 trip (in-process loop).

    Returns a flat mapping (one table row per key): per configuration the median, p95,
    p99 and max solve time [s], the speed-up over the paper's 16.4 s per solve, mean
    iterations, fallbacks, BHP RMSE [Pa] and the build time [s] (not in the solve times);
    ``targets_met`` checks median <= 10 ms and p99 <= 30 ms for all (the tripping issue's
    targets).
    ``jit`` None follows config/nmpc.yaml; True compiles the prediction step (cached).
    """
    config = load_rig(config_dir or default_config_dir())
    out: dict = {"solver": solver or config.nmpc.solver,
                 "max_iterations": config.nmpc.max_iterations,
                 "jit": bool(config.nmpc.jit if jit is None else jit),
                 "samples_per_configuration": samples,
                 "paper_solve_time_s": PAPER_SOLVE_TIME_S}
    met = True
    for conf in configurations:
        em = nmpc_estimation_model(config, conf)
        t0 = time.perf_counter()
        sup = Supervisor(config, em, configuration=conf, solver=solver, jit=jit)
        build_s = time.perf_counter() - t0
        log, sup = closed_loop(config, conf, samples, supervisor=sup,
                               friction_factor=1.1 if conf != "NMPC0" else 1.0)
        arr = log.arrays()
        dist = distribution(arr["solve_time_s"])
        err = arr["bhp_pa"] - arr["bhp_ref_pa"]
        key = conf.lower()
        out[f"{key}_median_s"] = dist["median_s"]
        out[f"{key}_p95_s"] = dist["p95_s"]
        out[f"{key}_p99_s"] = dist["p99_s"]
        out[f"{key}_max_s"] = dist["max_s"]
        out[f"{key}_speedup_vs_paper"] = PAPER_SOLVE_TIME_S / dist["median_s"]
        out[f"{key}_mean_iterations"] = float(np.mean(arr["iterations"]))
        out[f"{key}_fallbacks"] = int(np.sum(arr["fallback"] != "none"))
        out[f"{key}_bhp_rmse_pa"] = float(np.sqrt(np.mean(err ** 2)))
        out[f"{key}_build_s"] = build_s
        met = met and dist["median_s"] <= 0.010 and dist["p99_s"] <= 0.030
    out["targets_met"] = bool(met)
    return out


def solve_profile(samples: int = 150, configuration: str = "NMPC1",
                  config_dir: str | os.PathLike | None = None,
                  config: RigConfig | None = None) -> dict:
    """Where a solve's wall time goes, on ``run_benchmark``'s loop: per part of the
    real-time iteration (drill_nmpc.transcription.RTI_PARTS) and the rest of the
    supervisor's step (Python: parameters, bounds, warm start, the step's checks, the
    result), the mean per solve [s] and its share of the solves' total; the median and
    p99 solve [s], the share of the QP and the compiled evaluations (the linearisation and
    the evaluation) and the supervisor's build time [s]. ``config`` (a loaded configuration)
    replaces ``config_dir``'s."""
    config = config or load_rig(config_dir or default_config_dir())
    em = nmpc_estimation_model(config, configuration)
    start = time.perf_counter()
    sup = Supervisor(config, em, configuration=configuration)
    build_s = time.perf_counter() - start
    log, sup = closed_loop(config, configuration, samples, supervisor=sup, friction_factor=1.1)
    total_s = float(np.sum(log.solve_time_s))
    problems = {id(p): p for p in (sup.problem_for(True), sup.problem_for(False))}.values()
    parts = {part: sum(p.part_seconds[part] for p in problems) for part in RTI_PARTS}
    parts["other"] = total_s - sum(parts.values())
    dist = distribution(log.solve_time_s)
    out: dict = {"configuration": configuration, "solves": samples, "build_s": build_s,
                 "median_solve_s": dist["median_s"], "p99_solve_s": dist["p99_s"]}
    for part, seconds in parts.items():
        out[f"{part}_s_per_solve"] = seconds / samples
        out[f"{part}_share"] = seconds / total_s
    out["qp_and_compiled_share"] = 1.0 - out["other_share"]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=150)
    parser.add_argument("--solver", default=None, choices=("ipopt", "fatrop", "sqpmethod"))
    parser.add_argument("--jit", action="store_true", help="compile the prediction step to C")
    parser.add_argument("--configurations", default="NMPC0,NMPC1,NMPC2")
    parser.add_argument("--config-dir", default=None)
    args = parser.parse_args(argv)
    result = run_benchmark(args.samples, tuple(args.configurations.split(",")), args.solver,
                           jit=True if args.jit else None, config_dir=args.config_dir)
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
