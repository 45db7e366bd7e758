"""In-process closed loops for controller studies: the truth plant, the actuator models,
a state source and a controller stepped in one process, in the graph's lockstep order,
without DDS (the rungs below the full graph in docs/nmpc.md's ladder).

A bench, not a product path: the ``truth`` state source reads the truth plant's state
(an oracle); ``ukf`` runs the estimator on the noisy measurements as the graph does.
It steps the nodes' own classes (the estimator's and the advisors' ticks, the
protection's measurement watch and limiter), so with ``ukf`` and ``--protection`` it
reproduces the graph's fast-mode run sample by sample (test/test_closed_loop.py).
The scenario's events act as in the graph (sensor faults and formation changes on the
plant, a pump trip or a stuck actuator on its actuator). The process protection
(drill_protection.protection, with the kick detector's trip hold and the well-control
window whose target the advisor's setpoint book takes) is in the loop with
``--protection``; without it the controllers' commands go to the actuators as they are
(they respect its limits on the normal cases).

    python -m drill_bringup.loop_bench case2 --controller automated_mpd --state ukf --seeds 1 2 3
    python -m drill_bringup.loop_bench pump_trip --controller baseline --protection
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import asdict, dataclass

import numpy as np

from drill_bringup.runs import ROOT, scenario_path
from drill_bringup.report import format_legs, tracking_metrics
from drill_core import hydraulics as hy
from drill_core.config import RigConfig, parse_settings
from drill_core.backend import NUMPY
from drill_core.estimation_model import (BLOCK_INTEGRAL, BULK_MODULUS, DENSITY_OFFSET,
                                         STRING_FRICTION, build_estimation_model,
                                         fitted_friction_parameters)
from drill_core.event_codes import Notice
from drill_core.events import ACTUATORS, of_owner
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.mismatch import Mismatch, resolve, truth_config
from drill_core.scenario import initial_setpoints, load_scenario_config
from drill_core.units import L_PER_M3, PA_PER_BAR
from drill_estimator.tick import EstimatorTick
from drill_nmpc.advisor_ticks import (AdvisorCommand, AutomatedMpdTick, BaselineTick, NmpcTick,
                                      StartInputs)
from drill_nmpc.automated_mpd import EstimateView
from drill_nmpc.prediction_model import nmpc_estimation_model
from drill_nmpc.setpoint_book import SetpointBook, as_delivered, within_speed_limits
from drill_nmpc.setpoint_validation import Envelope
from drill_nmpc.supervisor import Fallback
from drill_plant.actuators import Choke, Drawworks, FrameOutput, Pump
from drill_plant.plant_model import EVENT_PARAMETERS, PARAMETER_NAMES, PlantLayout, steady_state
from drill_plant.sensor_faults import SensorFaults
from drill_plant.simulator import PlantSimulator
from drill_protection.tick import ProtectionTick
from drill_protection.watch import DETECTOR_CODES

CONTROLLERS = ("automated_mpd", "nmpc", "baseline")
NO_ANSWER = (math.nan, math.nan)    # trip-speed limits without a protection in the loop
PORE, FRACTURE = (PARAMETER_NAMES.index(n) for n in ("pore_pressure_pa", "fracture_pressure_pa"))


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
    mud_pump_on: bool = True

    @classmethod
    def of(cls, c: AdvisorCommand, stamp_s: float) -> "Command":
        """An advisor's command as the actuators take it, acting from ``stamp_s``."""
        pressure = c.choke_pressure_control
        return cls(c.block_position_ref_m, c.choke_flow_ref_m3s, c.bpp_flow_m3s, c.spp_pa,
                   c.choke_dp_ref_pa if pressure else math.nan,
                   c.choke_dp_ref_rate_pa_s if pressure else 0.0, stamp_s, c.mud_pump_on)


@dataclass
class Request(AdvisorCommand):
    """An advisor's command as the protection reads it off drill_msgs/RigCommand: with the
    BHP reference it rides with (an advisor never asks for a manual choke)."""
    bhp_ref_pa: float = math.nan
    choke_manual: bool = False
    choke_opening_ref: float = 0.0


class Rig:
    """Truth plant and the four actuator models, one sensor frame per call, with the
    scenario's events: the plant's parameter steps and sensor faults, the actuators' own
    faults (stuck, trip)."""

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
        self.frames: dict[str, FrameOutput] = {}    # every actuator's last frame, by name
        self.circulating = ini.circulation_m3s > 0.0
        self.parameter_events = [e for e in of_owner(scenario.events, "plant")
                                 if e.kind in EVENT_PARAMETERS]
        self.actuator_faults = of_owner(scenario.events, "actuator")
        self.sensor_faults = SensorFaults(scenario.events, seed)

    def measure(self, t_s: float):
        """The sample at t_s: parameter events due first, then the sensors and their faults."""
        for event in [e for e in self.parameter_events if t_s + 1e-9 >= e.time_s]:
            self.sim.set_parameter(EVENT_PARAMETERS[event.kind], event.value)
            self.parameter_events.remove(event)
        return self.sensor_faults.apply(t_s, self.sim.measure(self.circulating))

    def _fault(self, name: str, t_s: float) -> str:
        return next((e.kind for e in self.actuator_faults
                     if e.target == name and e.active(t_s)), "")

    def _frame(self, name: str, model, target: float, t_s: float, act) -> FrameOutput:
        """An actuator's frame under its fault: stuck freezes the output, a trip stops the
        pump whatever it is commanded."""
        fault = self._fault(name, t_s)
        if fault == "stuck":
            return FrameOutput(target, target, np.full(self.steps, model.lag.value))
        return act(0.0 if fault == "trip" else target)

    def frame(self, cmd: Command, m, t_s: float) -> np.ndarray:
        """Actuator outputs over the frame [4 x steps] and the plant advanced by them."""
        step, steps = self.step_s, self.steps
        dw = self._frame("drawworks", self.drawworks, cmd.block_ref_m, t_s,
                         lambda r: self.drawworks.frame(r, m.block_position_m, step, steps))
        if math.isfinite(cmd.dp_ref_pa):
            ch = self._frame("choke", self.choke, cmd.choke_flow_m3s, t_s,
                             lambda q: self.choke.pressure_frame(
                                 cmd.dp_ref_pa, cmd.dp_rate_pa_s, t_s - cmd.stamp_s, q,
                                 m.choke_dp_pa, step, steps))
        else:
            ch = self._frame("choke", self.choke, cmd.choke_flow_m3s, t_s,
                             lambda q: self.choke.frame(q, m.choke_dp_pa, step, steps,
                                                        return_flow_m3s=m.return_flow_m3s))
        bpp = self._frame("bpp", self.bpp, cmd.bpp_m3s, t_s,
                          lambda q: self.bpp.frame(q, step, steps))
        pump = self._frame("mud_pump", self.pump, cmd.spp_pa if cmd.mud_pump_on else 0.0, t_s,
                           lambda p: self.pump.frame(p, step, steps))
        self.frames = dict(zip(ACTUATORS, (dw, ch, bpp, pump)))
        self.circulating = pump.command > 0.0
        rows = np.vstack([dw.output, ch.output, bpp.output, pump.output])
        self.sim.advance(rows)
        return rows


class TruthState:
    """Oracle: the estimate view of the true state (friction factors fitted to the truth)."""

    def __init__(self, rig: Rig, em):
        self.rig, self.em = rig, em

    def _string_friction_factor(self, x, lay) -> float:
        """The truth's string friction over the model's at the true flow and speed."""
        q, v = float(x[lay.string_flow]), float(x[lay.velocity])
        model = float(hy.string_friction(NUMPY, self.em.wm, q, v))
        return float(hy.string_friction(NUMPY, self.rig.sim.wm, q, v)) / model if model else 1.0

    def observe(self, m, inputs, t: float) -> tuple[EstimateView, np.ndarray]:
        truth, lay = self.rig.sim.truth(), self.rig.layout
        x = truth.state
        flows = [x[lay.flow(i)] for i in range(2, self.em.n + 1)]
        theta = fitted_friction_parameters(self.em, flows, truth.annulus_friction_pa,
                                           float(x[lay.velocity]))
        x_hat = self.em.vector({**dict(zip(lay.names, x)),
                                BLOCK_INTEGRAL: self.rig.drawworks.integral_m_s,
                                DENSITY_OFFSET: self.rig.config.well.mud.density_kgm3
                                - self.em.wm.well.mud.density_kgm3,
                                STRING_FRICTION: self._string_friction_factor(x, lay),
                                BULK_MODULUS: self.rig.config.well.mud.bulk_modulus_pa
                                / self.em.wm.well.mud.bulk_modulus_pa,
                                **{self.em.theta_name(i): v for i, v in enumerate(theta, 2)}})
        return EstimateView(bhp_pa=float(x[lay.pressure(self.em.n)]),
                            string_position_m=float(x[lay.position]),
                            string_velocity_mps=float(x[lay.velocity]),
                            string_flow_m3s=float(x[lay.string_flow]),
                            friction_factor=tuple(float(v) for v in theta),
                            density_offset_kgm3=float(self.em.density_offset_of(x_hat)),
                            string_flow_observable=bool(m.string_flow_valid)), x_hat


class UkfState:
    """The estimator as in the graph: the same sample step (drill_estimator.tick) on the
    actuators' frames."""

    def __init__(self, config: RigConfig, rig: Rig):
        self.tick = EstimatorTick(config)
        self.rig = rig

    def observe(self, m, inputs, t: float) -> tuple[EstimateView, np.ndarray]:
        self.tick.step(t, m, self.rig.frames, self.rig.steps)
        ukf = self.tick.ukf
        x = ukf.mean
        return EstimateView(bhp_pa=ukf.bhp_pa, string_position_m=float(x[ukf.em.position]),
                            string_velocity_mps=float(x[ukf.em.velocity]),
                            string_flow_m3s=float(x[ukf.em.string_flow]),
                            friction_factor=tuple(float(v) for v in ukf.theta),
                            density_offset_kgm3=float(ukf.em.density_offset_of(x)),
                            string_flow_observable=bool(m.string_flow_valid)), ukf.mean


class NmpcController:
    """The nmpc node's tick (drill_nmpc.advisor_ticks) fed as the node feeds it: the
    actuator outputs of the last frames, the pump planned off while the string-flow meter
    reads nothing; its solve times and fallbacks kept."""

    def __init__(self, config: RigConfig, rig: Rig, start: StartInputs,
                 block_integral_from_drawworks: bool):
        self.rig = rig
        self.block_integral = block_integral_from_drawworks
        self.tick = NmpcTick(config, nmpc_estimation_model(config), start)
        self.solve_times: list[float] = []
        self.statuses: list[tuple] = []        # per fallback: (t, fallback, status, reasons)

    def step(self, x_hat, sp, inputs, t: float, flow_observable: bool,
             mud_pump_on: bool) -> AdvisorCommand:
        frame = self.rig.frames.get("drawworks") if self.block_integral else None
        actuators = {} if not self.rig.frames else {     # the node's: no frame before t_0
            "block_m": inputs[U_BLOCK, -1], "bpp_flow_m3s": inputs[U_BPP_FLOW, -1],
            "spp_pa": inputs[U_PUMP_PRESSURE, -1],
            "block_command_m": frame.command if frame else None,
            "block_reference_m": frame.reference if frame else None}
        r = self.tick.step(x_hat, as_delivered(sp, flow_observable), actuators)
        self.solve_times.append(r.solve_time_s)
        if r.fallback is not Fallback.NONE:
            self.statuses.append((t, r.fallback.value, r.status, r.reasons))
        return self.tick.command(r, mud_pump_on)


class Protection:
    """The protection node's tick (drill_protection.tick) fed as the node feeds it; its
    clamps, alarms and last answer kept."""

    def __init__(self, config: RigConfig, scenario, wm: hy.WellModel, op):
        self.tick = ProtectionTick(config, wm, scenario.initial, op)
        self.protection = self.tick.protection
        self.speed_limit = config.protection.trip_speed_max_mps
        self.clamps: list[tuple[float, str]] = []
        self.alarms: list[tuple[float, Notice]] = []     # the answers' events (t, notice)
        self.raised: list[tuple[float, str]] = []        # the detector's alarms (t, kind)
        self.answer = None          # (window Pa, BHP reference in force Pa, the advisor's Pa)
        self.speed_limits_mps = (math.nan, math.nan)     # of the last answer (running in,
        self.applied_block_m = math.nan                  # pulling out) and its block reference

    def measurement(self, m, t: float) -> None:
        for notice in self.tick.observe(round(t * 1e9), m):
            if notice.code.endswith("_detected"):
                self.raised.append((t, notice.code.removesuffix("_detected")))
            elif notice.code not in DETECTOR_CODES:
                self.alarms.append((t, notice))

    def limit(self, advised: AdvisorCommand, m, sp, t: float) -> Command:
        if math.isfinite(sp.trip_speed_limit_mps) and sp.trip_speed_limit_mps > 0.0:
            self.speed_limit = sp.trip_speed_limit_mps
        d = self.tick.limit(Request(**asdict(advised), bhp_ref_pa=sp.bhp_ref_pa), m,
                            round(t * 1e9), self.speed_limit)
        self.clamps += [(t, text) for text in d.clamps]
        self.answer = (self.protection.window_pa, d.bhp_ref_pa, sp.bhp_ref_pa)
        self.speed_limits_mps = d.standing_speed_limits_mps
        self.applied_block_m = float(d.command[U_BLOCK])
        dp = d.choke_dp_setpoint
        c = d.command
        return Command(float(c[U_BLOCK]), float(c[U_CHOKE]), float(c[U_BPP_FLOW]),
                       float(c[U_PUMP_PRESSURE]),
                       dp[0] if dp else math.nan, dp[1] if dp else 0.0, t, advised.mud_pump_on)


def run(scenario_name: str, controller: str = "automated_mpd", state: str = "ukf",
        seed: int | None = None, overrides: dict | None = None,
        block_integral_from_drawworks: bool = True, protection: bool = False,
        mismatch: Mismatch | None = None) -> dict:
    """One scenario in-process; the report's tracking figures, the time BHP spent outside
    the formation window, the BHP estimate RMSE. ``block_integral_from_drawworks`` False
    withholds the drawworks' command from the NMPC (as before it took its block-controller
    integral from there: docs/nmpc.md); ``protection`` puts the process protection between
    the controller and the actuators; ``mismatch``: the plant (and the actuators) differ
    from the model the rest reads (drill_core.mismatch)."""
    if controller not in CONTROLLERS:
        raise ValueError(f"controller {controller!r} is not one of {', '.join(CONTROLLERS)}")
    scenario, config = load_scenario_config(scenario_path(scenario_name), ROOT / "config",
                                            overrides)
    plant_config = config if mismatch is None else truth_config(config, mismatch)
    rig = Rig(plant_config, scenario, scenario.seed if seed is None else seed)
    wm = hy.build_well_model(config.well, config.plant.yield_regularisation_velocity_mps,
                             config.plant.choke_regularisation_pa)      # the model's
    em = build_estimation_model(config)
    source = TruthState(rig, em) if state == "truth" else UkfState(config, rig)
    book = SetpointBook(scenario, initial_setpoints(config, scenario),
                        Envelope.from_config(config, wm.geometry))
    ini = scenario.initial      # where the controllers believe the run starts: the model's
    op = steady_state(wm, ini.circulation_m3s, ini.choke_dp_pa, ini.bpp_flow_m3s)
    start = StartInputs.of(ini, op)
    mpd = AutomatedMpdTick(config, em, start) if controller == "automated_mpd" else None
    nmpc = NmpcController(config, rig, start, block_integral_from_drawworks) \
        if controller == "nmpc" else None
    baseline = BaselineTick(config, scenario.baseline_trip_speed_mps, start) \
        if controller == "baseline" else None
    guard = Protection(config, scenario, wm, op) if protection else None
    cmd = Command(0.0, start.choke_flow_m3s, start.bpp_flow_m3s, start.spp_pa)
    frames = int(round(scenario.duration_s / config.plant.sensor_period_s))
    per_sample = int(round(config.nmpc.sample_time_s / config.plant.sensor_period_s))
    log = {k: [] for k in ("t", "bhp", "pos", "ref", "band", "target", "bhp_est", "velocity",
                           "choke_dp", "choke_dp_ref", "opening", "block_ref", "pore",
                           "fracture", "choke_flow_ref", "bpp", "spp", "return_flow")}
    inputs = np.repeat(rig.op.inputs[:, None], rig.steps, axis=1)
    for k in range(frames):
        t = k * config.plant.sensor_period_s
        m = rig.measure(t)
        view, x_hat = source.observe(m, inputs, t)
        if guard is not None:
            guard.measurement(m, t)
        if k % per_sample == 0:         # the advisor's sample, as advisor_node runs it
            if guard is not None and guard.answer is not None:
                book.follow_protection(*guard.answer)
            book.advance(t)
            book.resolve_bhp(m.bhp_pa if baseline is not None else view.bhp_pa)   # as each node
            sp = book.active
            limits = guard.speed_limits_mps if guard is not None else NO_ANSWER
            applied = guard.applied_block_m if guard is not None else math.nan
            if nmpc is not None:
                advised = nmpc.step(x_hat, within_speed_limits(sp, limits, view.string_position_m),
                                    inputs, t, bool(m.string_flow_valid), sp.mud_pump_on)
            elif baseline is not None:
                advised, _ = baseline.step(m.block_position_m, m.bhp_pa, sp, book.bhp_resolved,
                                           applied)
            else:
                advised, _ = mpd.step(view, sp, book.bhp_resolved, limits, applied)
            cmd = Command.of(advised, t) if guard is None else guard.limit(advised, m, sp, t)
        truth = rig.sim.state
        log["t"].append(t)
        log["bhp"].append(truth[rig.layout.pressure(em.n)])
        log["pos"].append(truth[rig.layout.position])
        log["ref"].append(sp.bhp_ref_pa)
        log["band"].append(sp.bhp_band_pa)
        log["target"].append(sp.block_position_target_m)
        log["bhp_est"].append(view.bhp_pa)
        log["velocity"].append(truth[rig.layout.velocity])
        log["choke_dp"].append(m.choke_dp_pa)
        log["choke_dp_ref"].append(cmd.dp_ref_pa + cmd.dp_rate_pa_s * (t - cmd.stamp_s))
        log["block_ref"].append(cmd.block_ref_m)
        log["choke_flow_ref"].append(cmd.choke_flow_m3s)
        log["return_flow"].append(m.return_flow_m3s)
        log["pore"].append(rig.sim.parameters[PORE])
        log["fracture"].append(rig.sim.parameters[FRACTURE])
        inputs = rig.frame(cmd, m, t)
        log["opening"].append(inputs[U_CHOKE, 0])
        log["bpp"].append(inputs[U_BPP_FLOW, 0])
        log["spp"].append(inputs[U_PUMP_PRESSURE, 0])
    a = {k: np.asarray(v, dtype=float) for k, v in log.items()}
    out = tracking_metrics(a["t"], a["bhp"], a["pos"], a["ref"], a["band"], a["target"])
    dt = config.plant.sensor_period_s
    out["bhp_under_pore_s"] = float(np.count_nonzero(a["bhp"] < a["pore"]) * dt)
    out["bhp_over_fracture_s"] = float(np.count_nonzero(a["bhp"] > a["fracture"]) * dt)
    out["worst_underbalance_pa"] = float(max(np.max(a["pore"] - a["bhp"]), 0.0))
    out["worst_over_fracture_pa"] = float(max(np.max(a["bhp"] - a["fracture"]), 0.0))
    out["bhp_estimate_rmse_pa"] = float(np.sqrt(np.mean((a["bhp_est"] - a["bhp"]) ** 2)))
    out["max_string_speed_mps"] = float(np.max(np.abs(a["velocity"])))
    out["influx_volume_m3"] = float(rig.sim.state[rig.layout.influx_volume])
    out["loss_volume_m3"] = float(rig.sim.state[rig.layout.loss_volume])
    out["trace"] = a
    if nmpc is not None:
        out["solve_time_median_s"] = float(np.median(nmpc.solve_times))
        out["solve_time_p99_s"] = float(np.percentile(nmpc.solve_times, 99))
        out["fallbacks"] = len(nmpc.statuses)
        out["fallback_log"] = nmpc.statuses
    if guard is not None:
        out["clamps"], out["alarms"], out["raised"] = guard.clamps, guard.alarms, guard.raised
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--controller", default="automated_mpd", choices=CONTROLLERS)
    parser.add_argument("--state", default="ukf", choices=("truth", "ukf"))
    parser.add_argument("--seeds", type=int, nargs="*")
    parser.add_argument("--protection", action="store_true",
                        help="the process protection between the controller and the actuators")
    parser.add_argument("--set", action="append", default=[],
                        help="config override FILE.KEY=VALUE, e.g. automated_mpd.feedforward_lead_s=2")
    parser.add_argument("--mismatch", help="the plant differs from the model: a member of "
                                           "config/mismatch.yaml or draw:N")
    args = parser.parse_args(argv)
    overrides = parse_settings(args.set)
    mismatch = None if args.mismatch is None else resolve(args.mismatch, ROOT / "config")[1]
    for seed in args.seeds or [None]:
        r = run(args.scenario, args.controller, args.state, seed, overrides,
                protection=args.protection, mismatch=mismatch)
        print(f"{args.scenario} seed {seed}: BHP RMSE {r['bhp_rmse_pa'] / PA_PER_BAR:.2f} bar, "
              f"outside {r['bhp_time_outside_s']:.1f} s ({r['bhp_time_outside_settled_s']:.1f} s "
              f"after 30 s), worst {r['bhp_worst_excursion_pa'] / PA_PER_BAR:.2f} bar, "
              f"under pore {r['bhp_under_pore_s']:.1f} s (worst "
              f"{r['worst_underbalance_pa'] / PA_PER_BAR:.2f} bar), over fracture "
              f"{r['bhp_over_fracture_s']:.1f} s (worst {r['worst_over_fracture_pa'] / PA_PER_BAR:.2f} bar), "
              f"influx {r['influx_volume_m3'] * L_PER_M3:.0f} L, "
              f"lost {r['loss_volume_m3'] * L_PER_M3:.0f} L, "
              f"legs {format_legs(r['trip_legs'])}, estimate RMSE "
              f"{r['bhp_estimate_rmse_pa'] / PA_PER_BAR:.2f} bar" + (
                  f", solve median {r['solve_time_median_s'] * 1e3:.1f} ms, p99 "
                  f"{r['solve_time_p99_s'] * 1e3:.1f} ms, {r['fallbacks']} fallbacks"
                  if "fallbacks" in r else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
