"""In-process closed loops for controller studies: the truth plant, the actuator models,
a state source and a controller stepped in one process, in the graph's lockstep order,
without DDS (the rungs below the full graph in docs/nmpc.md's ladder).

A bench, not a product path: the ``truth`` state source reads the truth plant's state
(an oracle); ``ukf`` runs the estimator on the noisy measurements as the graph does.
It steps the nodes' own tick classes (the plant's, the actuators', the estimator's, the
advisors', the protection's), so with ``ukf`` and ``--protection`` it reproduces the
graph's fast-mode run sample by sample (test/test_closed_loop.py): the scenario's events
act as in the graph (sensor faults and formation changes on the plant, a pump trip or a
stuck actuator on its actuator), and with the protection in the loop so do its operator
actions (the emergency stop, the automation level). Without ``--protection`` the
controllers' commands go to the actuators as they are (they respect its limits on the
normal cases).

    python -m drill_studies.loop_bench case2 --controller automated_mpd --state ukf --seeds 1 2 3
    python -m drill_studies.loop_bench pump_trip --controller baseline --protection
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from drill_bringup.runs import ROOT, scenario_path
from drill_analysis.report import format_legs, tracking_metrics
from drill_core import hydraulics as hy
from drill_core.config import RigConfig, parse_settings
from drill_core.backend import NUMPY
from drill_core.estimation_model import (BLOCK_INTEGRAL, BULK_MODULUS, DENSITY_OFFSET,
                                         STRING_FRICTION, build_estimation_model,
                                         fitted_friction_parameters)
from drill_core.event_codes import Notice
from drill_core.events import ACTUATORS
from drill_core.input_layout import U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.mismatch import Mismatch, resolve, truth_config
from drill_core.operating_point import initial_operating_point
from drill_ros.stamps import NS_PER_S, seconds_to_ns
from drill_core.scenario import initial_setpoints, load_scenario_config
from drill_core.units import L_PER_M3, PA_PER_BAR
from drill_estimator.tick import EstimatorTick
from drill_nmpc.advisor_ticks import (AdvisorCommand, AutomatedMpdTick, BaselineTick, NmpcTick,
                                      StartInputs, SupervisorRequest)
from drill_nmpc.automated_mpd import EstimateView
from drill_nmpc.prediction_model import measured_actuators, nmpc_estimation_model
from drill_nmpc.setpoint_book import SetpointBook, as_delivered, within_speed_limits
from drill_nmpc.setpoint_validation import Envelope
from drill_nmpc.solve_result import Fallback
from drill_plant.actuator_tick import ActuatorTick
from drill_plant.actuators import FrameOutput
from drill_plant.plant_model import PARAMETER_NAMES, PlantLayout, steady_state
from drill_plant.plant_tick import PlantTick
from drill_protection.tick import MachineCommand, ProtectionTick
from drill_protection.watch import DETECTOR_CODES

CONTROLLERS = ("automated_mpd", "nmpc", "baseline")
NO_ANSWER = (math.nan, math.nan)    # trip-speed limits without a protection in the loop
PORE, FRACTURE = (PARAMETER_NAMES.index(n) for n in ("pore_pressure_pa", "fracture_pressure_pa"))


TRACE = {   # the trace's columns (SI, named with their units) -> what each holds
    "time_s": "simulated time",
    "bhp_pa": "the plant's BHP (truth)",
    "string_position_m": "the string's position, up (truth)",
    "bhp_ref_pa": "the setpoints' BHP reference",
    "bhp_band_pa": "its control band (half width)",
    "block_target_m": "the trip's block target",
    "bhp_estimate_pa": "the state source's BHP (the UKF's estimate, or the truth)",
    "string_velocity_mps": "the string's velocity, up (truth)",
    "choke_dp_pa": "choke differential pressure (measured)",
    "choke_dp_ref_pa": "the choke's pressure set-point (NaN: flow control)",
    "choke_opening_1": "choke opening (the actuator's output)",
    "block_position_ref_m": "the machine command's block reference",
    "pore_pressure_pa": "pore pressure in force",
    "fracture_pressure_pa": "fracture pressure in force",
    "choke_flow_ref_m3s": "the machine command's choke-flow reference",
    "bpp_flow_m3s": "back-pressure pump flow (its output)",
    "spp_pa": "stand-pipe pressure (the mud pump's output)",
    "return_flow_m3s": "return flow (measured)",
}


class Rig:
    """Truth plant and the four actuators, one sensor frame per call: the plant node's and
    the actuator nodes' ticks (drill_plant.plant_tick, drill_plant.actuator_tick), with
    the scenario's events acting on them as in the graph."""

    def __init__(self, config: RigConfig, scenario, seed: int):
        self.config = config
        wm = hy.rig_well_model(config)
        self.op = initial_operating_point(wm, scenario.initial)
        self.plant = PlantTick(config, self.op, scenario, seed)
        self.sim = self.plant.sim
        self.actuators = {name: ActuatorTick(name, config, wm, self.op, scenario.events)
                          for name in ACTUATORS}
        self.drawworks = self.actuators["drawworks"].model
        self.steps = config.plant.steps_per_frame
        self.layout = PlantLayout(self.sim.wm.n)
        self.frames: dict[str, FrameOutput] = {}    # every actuator's last frame, by name
        self.bad_frames = 0

    def measure(self, stamp_ns: int):
        """The sample stamped ``stamp_ns``: the events due first, then the sensors."""
        return self.plant.sample(stamp_ns / NS_PER_S)[1]

    def command(self, command, stamp_ns: int) -> None:
        """The machine command stamped ``stamp_ns`` to every actuator."""
        for tick in self.actuators.values():
            tick.command(command, stamp_ns, stamp_ns)

    def frame(self, m, stamp_ns: int) -> np.ndarray:
        """Actuator outputs over the frame [4 x steps] and the plant advanced by them."""
        time_s = stamp_ns / NS_PER_S
        self.frames = {name: tick.step(m, stamp_ns, stamp_ns, time_s).output
                       for name, tick in self.actuators.items()}
        self.bad_frames += len(self.plant.advance(
            {name: (f.output, f.command) for name, f in self.frames.items()}))
        return np.vstack([f.output for f in self.frames.values()])


class TruthState:
    """Oracle: the estimate view of the true state of the plant simulator ``sim`` (built from
    ``config``; friction factors fitted to the truth for the model ``em``, which a caller
    may swap as the string is racked), the block controller's integral from ``drawworks``."""

    def __init__(self, sim, config: RigConfig, drawworks, em):
        self.sim, self.config, self.drawworks, self.em = sim, config, drawworks, em

    def _string_friction_factor(self, x, lay) -> float:
        """The truth's string friction over the model's at the true flow and speed."""
        q, v = float(x[lay.string_flow]), float(x[lay.velocity])
        model = float(hy.string_friction(NUMPY, self.em.wm, q, v))
        return float(hy.string_friction(NUMPY, self.sim.wm, q, v)) / model if model else 1.0

    def observe(self, m, inputs, t: float) -> tuple[EstimateView, np.ndarray]:
        truth, lay = self.sim.truth(), self.sim.layout
        x = truth.state
        flows = [x[lay.flow(i)] for i in range(2, self.em.n + 1)]
        theta = fitted_friction_parameters(self.em, flows, truth.annulus_friction_pa,
                                           float(x[lay.velocity]))
        x_hat = self.em.vector({**dict(zip(lay.names, x)),
                                BLOCK_INTEGRAL: self.drawworks.integral_m_s,
                                DENSITY_OFFSET: self.config.well.mud.density_kgm3
                                - self.em.wm.well.mud.density_kgm3,
                                STRING_FRICTION: self._string_friction_factor(x, lay),
                                BULK_MODULUS: self.config.well.mud.bulk_modulus_pa
                                / self.em.wm.well.mud.bulk_modulus_pa,
                                **{self.em.theta_name(i): v for i, v in enumerate(theta, 2)}})
        return EstimateView(bhp_pa=float(x[lay.pressure(self.em.n)]),
                            string_position_m=float(x[lay.position]),
                            string_velocity_mps=float(x[lay.velocity]),
                            string_flow_m3s=float(x[lay.string_flow]),
                            friction_factor=tuple(float(v) for v in theta),
                            density_offset_kgm3=float(self.em.density_offset_of(x_hat)),
                            string_flow_observable=bool(m.string_flow_valid),
                            bottom_annulus_flow_m3s=float(x[lay.flow(self.em.n)])), x_hat


class UkfState:
    """The estimator as in the graph: the same sample step (drill_estimator.tick) on the
    actuators' frames."""

    def __init__(self, config: RigConfig, rig: Rig):
        self.tick = EstimatorTick(config)
        self.rig = rig

    def observe(self, m, inputs, t: float) -> tuple[EstimateView, np.ndarray]:
        self.tick.step(t, m, self.rig.frames, self.rig.steps)
        return ukf_view(self.tick.ukf, bool(m.string_flow_valid)), self.tick.ukf.mean


def ukf_view(ukf, string_flow_observable: bool) -> EstimateView:
    """What automated MPD reads of the UKF's estimate, as its node reads the message."""
    x = ukf.mean
    return EstimateView(bhp_pa=ukf.bhp_pa, string_position_m=float(x[ukf.em.position]),
                        string_velocity_mps=float(x[ukf.em.velocity]),
                        string_flow_m3s=float(x[ukf.em.string_flow]),
                        friction_factor=tuple(float(v) for v in ukf.theta),
                        density_offset_kgm3=float(ukf.em.density_offset_of(x)),
                        string_flow_observable=string_flow_observable,
                        bottom_annulus_flow_m3s=float(x[ukf.em.flow(ukf.em.n)]))


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

    def step(self, x_hat, sp, t: float, flow_observable: bool,
             mud_pump_on: bool) -> AdvisorCommand:
        actuators = measured_actuators(self.rig.frames)     # the node's: no frame before t_0
        if not self.block_integral and actuators:
            actuators.update(block_command_m=None, block_reference_m=None)
        r = self.tick.step(x_hat, as_delivered(sp, flow_observable), actuators)
        self.solve_times.append(r.solve_time_s)
        if r.fallback is not Fallback.NONE:
            self.statuses.append((t, r.fallback.value, r.status, r.reasons))
        return self.tick.command(r, mud_pump_on)


class Protection:
    """The protection node's tick (drill_protection.tick) fed as the node feeds it; its
    clamps, alarms, operator and window notices and its last machine command kept."""

    def __init__(self, config: RigConfig, scenario, wm: hy.WellModel, op):
        self.tick = ProtectionTick(config, wm, scenario, op)
        self.latched_speed_limit_mps = config.protection.trip_speed_max_mps
        self.clamps: list[tuple[float, Notice]] = []
        self.alarms: list[tuple[float, Notice]] = []     # the answers' events (t, notice)
        self.raised: list[tuple[float, str]] = []        # the detector's alarms (t, kind)
        self.notices: list[tuple[float, Notice]] = []    # operator actions, window exits
        self.answer: MachineCommand | None = None        # to the last request

    def measurement(self, m, stamp_ns: int) -> None:
        t = stamp_ns / NS_PER_S
        for notice in self.tick.observe(stamp_ns, m):
            if notice.code.endswith("_detected"):
                self.raised.append((t, notice.code.removesuffix("_detected")))
            elif notice.code not in DETECTOR_CODES:
                self.alarms.append((t, notice))

    def frames(self, stamp_ns: int, frames: dict[str, FrameOutput]) -> None:
        for name, frame in frames.items():
            self.tick.observe_frame(name, stamp_ns, frame.reference, frame.output)

    def limit(self, request: SupervisorRequest, m, stamp_ns: int) -> MachineCommand:
        t = stamp_ns / NS_PER_S
        self.notices += [(t, n) for n in self.tick.press_due(t)]
        d = self.tick.limit(request, m, stamp_ns, self.latched_speed_limit_mps)
        self.clamps += [(t, notice) for notice in d.clamps]
        self.notices += [(t, n) for n in self.tick.check_window(m)]
        self.answer = self.tick.machine_command(d, request)
        return self.answer


def run(scenario_name: str, controller: str = "automated_mpd", state: str = "ukf",
        seed: int | None = None, overrides: dict | None = None,
        block_integral_from_drawworks: bool = True, protection: bool = False,
        mismatch: Mismatch | None = None, machines=None) -> dict:
    """One scenario in-process; the report's tracking figures, the time BHP spent outside
    the formation window, the BHP estimate RMSE. ``block_integral_from_drawworks`` False
    withholds the drawworks' command from the NMPC (as before it took its block-controller
    integral from there: docs/nmpc.md); ``protection`` puts the process protection between
    the controller and the actuators; ``mismatch``: the plant (and the actuators) differ
    from the model the rest reads (drill_core.mismatch); ``machines(t, m, command)``, when
    given, replaces each machine command before the actuators take it (an oracle's
    answer for a bound: drill_studies.fault_bound)."""
    if controller not in CONTROLLERS:
        raise ValueError(f"controller {controller!r} is not one of {', '.join(CONTROLLERS)}")
    scenario, config = load_scenario_config(scenario_path(scenario_name), ROOT / "config",
                                            overrides)
    plant_config = config if mismatch is None else truth_config(config, mismatch)
    rig = Rig(plant_config, scenario, scenario.seed if seed is None else seed)
    wm = hy.rig_well_model(config)      # the model's
    em = build_estimation_model(config)
    source = TruthState(rig.sim, rig.config, rig.drawworks, em) if state == "truth" \
        else UkfState(config, rig)
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
    request = None
    frames = int(round(scenario.duration_s / config.plant.sensor_period_s))
    per_sample = int(round(config.nmpc.sample_time_s / config.plant.sensor_period_s))
    log = {k: [] for k in TRACE}
    inputs = np.repeat(rig.op.inputs[:, None], rig.steps, axis=1)
    frame_ns = seconds_to_ns(config.plant.sensor_period_s)
    for k in range(frames):
        t, stamp = k * config.plant.sensor_period_s, k * frame_ns
        m = rig.measure(stamp)
        view, x_hat = source.observe(m, inputs, t)
        if guard is not None:
            guard.measurement(m, stamp)
        if k % per_sample == 0:         # the advisor's sample, as advisor_node runs it
            answer = guard.answer if guard is not None else None
            if answer is not None:
                book.follow_protection((answer.bhp_window_low_pa, answer.bhp_window_high_pa),
                                       answer.bhp_ref_pa, request.bhp_ref_pa)
            book.advance(t)
            book.resolve_bhp(m.bhp_pa if baseline is not None else view.bhp_pa)   # as each node
            sp = book.active
            limits = NO_ANSWER if answer is None else (answer.trip_speed_limit_in_mps,
                                                       answer.trip_speed_limit_out_mps)
            applied = math.nan if answer is None else answer.block_position_ref_m
            if nmpc is not None:
                advised = nmpc.step(x_hat, within_speed_limits(sp, limits, view.string_position_m),
                                    t, bool(m.string_flow_valid), sp.mud_pump_on)
            elif baseline is not None:
                advised, _ = baseline.step(m.block_position_m, m.bhp_pa, sp, book.bhp_resolved,
                                           applied, m.return_flow_m3s)
            else:
                advised, _ = mpd.step(view, sp, book.bhp_resolved, limits, applied)
            request = SupervisorRequest.of(advised, book)
            cmd = MachineCommand.as_requested(request) if guard is None \
                else guard.limit(request, m, stamp)
            if machines is not None:
                cmd = machines(t, m, cmd)
            rig.command(cmd, stamp)
            cmd_t = t
        truth = rig.sim.state
        log["time_s"].append(t)
        log["bhp_pa"].append(truth[rig.layout.pressure(em.n)])
        log["string_position_m"].append(truth[rig.layout.position])
        log["bhp_ref_pa"].append(sp.bhp_ref_pa)
        log["bhp_band_pa"].append(sp.bhp_band_pa)
        log["block_target_m"].append(sp.block_position_target_m)
        log["bhp_estimate_pa"].append(view.bhp_pa)
        log["string_velocity_mps"].append(truth[rig.layout.velocity])
        log["choke_dp_pa"].append(m.choke_dp_pa)
        log["choke_dp_ref_pa"].append(
            cmd.choke_dp_ref_pa + cmd.choke_dp_ref_rate_pa_s * (t - cmd_t)
            if cmd.choke_pressure_control else math.nan)
        log["block_position_ref_m"].append(cmd.block_position_ref_m)
        log["choke_flow_ref_m3s"].append(cmd.choke_flow_ref_m3s)
        log["return_flow_m3s"].append(m.return_flow_m3s)
        log["pore_pressure_pa"].append(rig.sim.parameters[PORE])
        log["fracture_pressure_pa"].append(rig.sim.parameters[FRACTURE])
        inputs = rig.frame(m, stamp)
        if guard is not None:
            guard.frames(stamp, rig.frames)
        log["choke_opening_1"].append(inputs[U_CHOKE, 0])
        log["bpp_flow_m3s"].append(inputs[U_BPP_FLOW, 0])
        log["spp_pa"].append(inputs[U_PUMP_PRESSURE, 0])
    a = {k: np.asarray(v, dtype=float) for k, v in log.items()}
    bhp, pore, fracture = a["bhp_pa"], a["pore_pressure_pa"], a["fracture_pressure_pa"]
    out = tracking_metrics(a["time_s"], bhp, a["string_position_m"], a["bhp_ref_pa"],
                           a["bhp_band_pa"], a["block_target_m"])
    dt = config.plant.sensor_period_s
    out["bhp_under_pore_s"] = float(np.count_nonzero(bhp < pore) * dt)
    out["bhp_over_fracture_s"] = float(np.count_nonzero(bhp > fracture) * dt)
    out["worst_underbalance_pa"] = float(max(np.max(pore - bhp), 0.0))
    out["worst_over_fracture_pa"] = float(max(np.max(bhp - fracture), 0.0))
    out["bhp_estimate_rmse_pa"] = float(np.sqrt(np.mean((a["bhp_estimate_pa"] - bhp) ** 2)))
    out["max_string_speed_mps"] = float(np.max(np.abs(a["string_velocity_mps"])))
    out["influx_volume_m3"] = float(rig.sim.state[rig.layout.influx_volume])
    out["loss_volume_m3"] = float(rig.sim.state[rig.layout.loss_volume])
    out["trace"] = a
    out["bad_frames"] = rig.bad_frames
    if nmpc is not None:
        out["solve_time_median_s"] = float(np.median(nmpc.solve_times))
        out["solve_time_p99_s"] = float(np.percentile(nmpc.solve_times, 99))
        out["fallbacks"] = len(nmpc.statuses)
        out["fallback_log"] = nmpc.statuses
    if guard is not None:
        out["clamps"], out["alarms"], out["raised"] = guard.clamps, guard.alarms, guard.raised
        out["notices"] = guard.notices
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
        print(f"{args.scenario} seed {seed}: BHP RMSE {r['bhp_rmse_pa'] / PA_PER_BAR:.2f} bar "
              f"({r['bhp_rmse_settled_pa'] / PA_PER_BAR:.2f} after 30 s), "
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
