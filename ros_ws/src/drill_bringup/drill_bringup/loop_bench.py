"""In-process closed loops for controller studies: the truth plant, the actuator models,
a state source and a controller stepped in one process, in the graph's lockstep order,
without DDS (the rungs below the full graph in docs/nmpc.md's ladder).

A bench, not a product path: the ``truth`` state source reads the truth plant's state
(an oracle); ``ukf`` runs the estimator on the noisy measurements as the graph does.
Process protection is not in the loop (the controllers' commands respect its limits).

    python -m drill_bringup.loop_bench case2 --controller automated_mpd --state ukf --seeds 1 2 3
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass

import numpy as np

from drill_bringup.runs import scenario_path
from drill_bringup.report import format_legs, tracking_metrics
from drill_core import hydraulics as hy
from drill_core.config import RigConfig
from drill_core.estimation_model import (BLOCK_INTEGRAL, build_estimation_model,
                                         fitted_friction_parameters)
from drill_core.scenario import initial_setpoints, load_scenario_config, setpoints_at
from drill_core.units import PA_PER_BAR
from drill_estimator.model_inputs import frame_inputs
from drill_estimator.ukf import RigUkf
from drill_nmpc.automated_mpd import AutomatedMpd, EstimateView
from drill_nmpc.inputs import choke_command, choke_input
from drill_nmpc.supervisor import Supervisor
from drill_plant.actuators import Choke, Drawworks, Pump
from drill_plant.plant_model import PlantLayout, steady_state
from drill_plant.simulator import PlantSimulator


@dataclass
class Command:
    """What the actuators act on (SI); choke in pressure mode when dp_ref is finite."""
    block_ref_m: float
    choke_flow_m3s: float
    bpp_m3s: float
    spp_pa: float
    dp_ref_pa: float = math.nan
    dp_rate_pa_s: float = 0.0
    stamp_s: float = 0.0


class Rig:
    """Truth plant and the four actuator models, one sensor frame per call."""

    def __init__(self, config: RigConfig, scenario, seed: int):
        ini = scenario.initial
        self.config = config
        self.op = steady_state(hy.build_well_model(config.well,
                                                   config.plant.yield_regularisation_velocity_mps,
                                                   config.plant.choke_regularisation_pa),
                               ini.circulation_m3s, ini.choke_dp_pa, ini.bpp_flow_m3s)
        self.sim = PlantSimulator(config, self.op, seed)
        u_b, opening, bpp, spp = (float(v) for v in self.op.inputs)
        a = config.actuators
        self.drawworks = Drawworks(a, self.sim.wm.geometry.static_stretch_m, u_b)
        self.choke = Choke(a, self.sim.wm, opening)
        self.bpp = Pump(a.bpp, bpp)
        self.pump = Pump(a.mud_pump, spp)
        self.step_s, self.steps = config.plant.step_s, config.plant.steps_per_frame
        self.layout = PlantLayout(self.sim.wm.n)
        self.block_frame = None       # the drawworks' last frame (command and reference)

    def frame(self, cmd: Command, m, t_s: float) -> np.ndarray:
        """Actuator outputs over the frame [4 x steps] and the plant advanced by them."""
        dw = self.drawworks.frame(cmd.block_ref_m, m.block_position_m, self.step_s, self.steps)
        if math.isfinite(cmd.dp_ref_pa):
            ch = self.choke.pressure_frame(cmd.dp_ref_pa, cmd.dp_rate_pa_s, t_s - cmd.stamp_s,
                                           cmd.choke_flow_m3s, m.choke_dp_pa, self.step_s,
                                           self.steps)
        else:
            ch = self.choke.frame(cmd.choke_flow_m3s, m.choke_dp_pa, self.step_s, self.steps)
        self.block_frame = dw
        rows = np.vstack([dw.output, ch.output,
                          self.bpp.frame(cmd.bpp_m3s, self.step_s, self.steps).output,
                          self.pump.frame(cmd.spp_pa, self.step_s, self.steps).output])
        self.sim.advance(rows)
        return rows


class TruthState:
    """Oracle: the estimate view of the true state (friction factors fitted to the truth)."""

    def __init__(self, rig: Rig, em):
        self.rig, self.em = rig, em

    def observe(self, m, inputs) -> tuple[EstimateView, np.ndarray]:
        truth, lay = self.rig.sim.truth(), self.rig.layout
        x = truth.state
        flows = [x[lay.flow(i)] for i in range(2, self.em.n + 1)]
        theta = fitted_friction_parameters(self.em, flows, truth.annulus_friction_pa,
                                           float(x[lay.velocity]))
        x_hat = self.em.vector({**dict(zip(lay.names, x)),
                                BLOCK_INTEGRAL: self.rig.drawworks.integral_m_s,
                                **{self.em.theta_name(i): v for i, v in enumerate(theta, 2)}})
        return EstimateView(bhp_pa=float(x[lay.pressure(self.em.n)]),
                            string_position_m=float(x[lay.position]),
                            string_velocity_mps=float(x[lay.velocity]),
                            string_flow_m3s=float(x[lay.string_flow]),
                            friction_factor=tuple(float(v) for v in theta)), x_hat


class UkfState:
    """The estimator as in the graph: time update over the last frame, then the sample."""

    def __init__(self, config: RigConfig, rig: Rig):
        self.ukf = RigUkf(config)
        self.wm = rig.sim.wm
        self.dp_pa = math.nan

    def observe(self, m, inputs) -> tuple[EstimateView, np.ndarray]:
        y = np.array([m.block_position_m, m.choke_dp_pa, m.bhp_pa, m.string_flow_m3s])
        ukf = self.ukf
        if not ukf.initialised:
            ukf.initialise(ukf.initial_state(y, True))
        else:
            ukf.predict_frame(frame_inputs(self.wm, inputs[0], inputs[1], inputs[2], inputs[3],
                                           self.dp_pa))
            ukf.update(y, True)
        self.dp_pa = m.choke_dp_pa
        x = ukf.mean
        return EstimateView(bhp_pa=ukf.bhp_pa, string_position_m=float(x[ukf.em.position]),
                            string_velocity_mps=float(x[ukf.em.velocity]),
                            string_flow_m3s=float(x[ukf.em.string_flow]),
                            friction_factor=tuple(float(v) for v in ukf.theta)), ukf.mean


class NmpcController:
    """The NMPC supervisor as the nmpc node runs it (u_{-1}, actuator outputs, command)."""

    def __init__(self, config: RigConfig, rig: Rig, ini, block_integral_from_drawworks: bool):
        self.rig = rig
        self.block_integral = block_integral_from_drawworks
        self.sup = Supervisor(config, build_estimation_model(
            config, with_disturbance=config.nmpc.configuration == "NMPC2"))
        self.cfg = config.nmpc
        u_b, opening, bpp, spp = (float(v) for v in rig.op.inputs)
        self.operating_flow_m3s = float(rig.op.choke_flow_m3s)   # before any solve
        self.u = None
        self.initial = (choke_input(self.cfg, self.operating_flow_m3s, ini.choke_dp_pa), bpp, spp)
        self.solve_times: list[float] = []
        self.fallbacks = 0

    def step(self, x_hat, sp, inputs, t: float) -> Command:
        if self.u is None:
            self.u = self.sup.safe_input([x_hat[0], *self.initial])
        frame = self.rig.block_frame if self.block_integral else None
        r = self.sup.step(x_hat, sp, self.u, actuators={
            "block_m": inputs[0, -1], "bpp_flow_m3s": inputs[2, -1], "spp_pa": inputs[3, -1],
            "block_command_m": frame.command if frame else None,
            "block_reference_m": frame.reference if frame else None})
        self.solve_times.append(r.solve_time_s)
        self.fallbacks += r.fallback != "none"
        u = self.u = np.asarray(r.u, dtype=float)
        choke = choke_command(self.cfg, r, self.operating_flow_m3s)
        if not choke.pressure_control:
            return Command(u[0], choke.flow_m3s, u[2], u[3], stamp_s=t)
        return Command(u[0], choke.flow_m3s, u[2], u[3], choke.dp_ref_pa, choke.dp_ref_rate_pa_s, t)


def run(scenario_name: str, controller: str = "automated_mpd", state: str = "ukf",
        seed: int | None = None, overrides: dict | None = None,
        block_integral_from_drawworks: bool = True) -> dict:
    """One scenario in-process; the report's tracking figures plus the BHP estimate RMSE.
    ``block_integral_from_drawworks`` False withholds the drawworks' command from the NMPC
    (as before it took its block-controller integral from there: docs/nmpc.md)."""
    scenario, config = load_scenario_config(scenario_path(scenario_name),
                                            scenario_path(scenario_name).parent.parent, overrides)
    rig = Rig(config, scenario, scenario.seed if seed is None else seed)
    em = build_estimation_model(config)
    source = TruthState(rig, em) if state == "truth" else UkfState(config, rig)
    start = initial_setpoints(config, scenario)
    u_b, opening, bpp, spp = (float(v) for v in rig.op.inputs)
    mpd = AutomatedMpd(config, em, bpp, spp) if controller == "automated_mpd" else None
    nmpc = NmpcController(config, rig, scenario.initial, block_integral_from_drawworks) \
        if controller == "nmpc" else None
    cmd = Command(0.0, rig.op.choke_flow_m3s, bpp, spp)
    frames = int(round(scenario.duration_s / config.plant.sensor_period_s))
    per_sample = int(round(config.nmpc.sample_time_s / config.plant.sensor_period_s))
    log = {k: [] for k in ("t", "bhp", "pos", "ref", "band", "target", "bhp_est", "velocity",
                           "choke_dp", "choke_dp_ref", "opening", "block_ref")}
    inputs = np.repeat(rig.op.inputs[:, None], rig.steps, axis=1)
    bhp_ref = math.nan
    for k in range(frames):
        t = k * config.plant.sensor_period_s
        m = rig.sim.measure(True)
        view, x_hat = source.observe(m, inputs)
        sp = setpoints_at(scenario, t, start)
        if math.isnan(bhp_ref):
            bhp_ref = sp.bhp_ref_pa if math.isfinite(sp.bhp_ref_pa) else view.bhp_pa
        if k % per_sample == 0:
            if math.isfinite(sp.bhp_ref_pa):
                bhp_ref = sp.bhp_ref_pa
            if nmpc is not None:
                cmd = nmpc.step(x_hat, sp, inputs, t)
            else:
                c = mpd.step(view, sp, bhp_ref)
                cmd = Command(c.block_position_ref_m, c.choke_flow_feedforward_m3s,
                              c.bpp_flow_m3s, c.spp_pa, c.choke_dp_ref_pa,
                              c.choke_dp_ref_rate_pa_s, t)
        truth = rig.sim.state
        log["t"].append(t)
        log["bhp"].append(truth[rig.layout.pressure(em.n)])
        log["pos"].append(truth[rig.layout.position])
        log["ref"].append(bhp_ref)
        log["band"].append(sp.bhp_band_pa)
        log["target"].append(sp.block_position_target_m)
        log["bhp_est"].append(view.bhp_pa)
        log["velocity"].append(truth[rig.layout.velocity])
        log["choke_dp"].append(m.choke_dp_pa)
        log["choke_dp_ref"].append(cmd.dp_ref_pa + cmd.dp_rate_pa_s * (t - cmd.stamp_s))
        log["block_ref"].append(cmd.block_ref_m)
        inputs = rig.frame(cmd, m, t)
        log["opening"].append(inputs[1, 0])
    a = {k: np.asarray(v, dtype=float) for k, v in log.items()}
    out = tracking_metrics(a["t"], a["bhp"], a["pos"], a["ref"], a["band"], a["target"])
    out["bhp_estimate_rmse_pa"] = float(np.sqrt(np.mean((a["bhp_est"] - a["bhp"]) ** 2)))
    out["max_string_speed_mps"] = float(np.max(np.abs(a["velocity"])))
    out["trace"] = a
    if nmpc is not None:
        out["solve_time_median_s"] = float(np.median(nmpc.solve_times))
        out["solve_time_p99_s"] = float(np.percentile(nmpc.solve_times, 99))
        out["fallbacks"] = nmpc.fallbacks
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--controller", default="automated_mpd", choices=("automated_mpd", "nmpc"))
    parser.add_argument("--state", default="ukf", choices=("truth", "ukf"))
    parser.add_argument("--seeds", type=int, nargs="*")
    parser.add_argument("--set", action="append", default=[],
                        help="config override FILE.KEY=VALUE, e.g. automated_mpd.feedforward_lead_s=2")
    args = parser.parse_args(argv)
    overrides: dict = {}
    for item in args.set:
        key, value = item.split("=", 1)
        stem, name = key.split(".", 1)
        overrides.setdefault(stem, {})[name] = json.loads(value)
    for seed in args.seeds or [None]:
        r = run(args.scenario, args.controller, args.state, seed, overrides)
        print(f"{args.scenario} seed {seed}: BHP RMSE {r['bhp_rmse_pa'] / PA_PER_BAR:.2f} bar, "
              f"outside {r['bhp_time_outside_s']:.1f} s ({r['bhp_time_outside_settled_s']:.1f} s "
              f"after 30 s), worst {r['bhp_worst_excursion_pa'] / PA_PER_BAR:.2f} bar, "
              f"legs {format_legs(r['trip_legs'])}, estimate RMSE "
              f"{r['bhp_estimate_rmse_pa'] / PA_PER_BAR:.2f} bar" + (
                  f", solve median {r['solve_time_median_s'] * 1e3:.1f} ms, p99 "
                  f"{r['solve_time_p99_s'] * 1e3:.1f} ms, {r['fallbacks']} fallbacks"
                  if "fallbacks" in r else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
