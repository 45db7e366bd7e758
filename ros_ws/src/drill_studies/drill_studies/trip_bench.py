"""An in-process multi-stand trip of the truth plant (no ROS): the rig floor's tick
(drill_plant.floor_tick, as the floor node runs it: the block's encoder from the
drawworks' frames) driving the drawworks and the mud pump (drill_plant.actuators), the
plant (drill_plant.simulator) slipping, racking and filling from the trip tank, the trip
sheet, and the estimator tick (drill_estimator.tick) told what the floor does, or not
(``floor_aware``).

The controller (``controller``): ``held_choke``, the choke held at its opening (nothing
holds the BHP through a connection) and each stand's move on a block reference at a fixed
speed, braking at BRAKING_MPS2; or ``baseline``, the PI baseline's tick
(drill_nmpc.advisor_ticks.BaselineTick, given the floor's command as its node gives it)
once a second on the measured BHP and position, its choke-flow reference through the
choke's flow loop (drill_plant.actuators.Choke), its back-pressure pump command (run
through the connections) through the pump's lag. A test bed for the floor, the plant and
the estimator and a first look at a controller through connections, not a substitute for
the node graph (no process protection, no DDS: ``rig run trip_out``). ``automated_mpd``:
its tick (drill_nmpc.advisor_ticks.AutomatedMpdTick) once a second on the UKF's estimate,
given the floor's command as its node gives it, its choke on the choke's pressure loop,
its back-pressure pump command through the pump's lag, its model the full string's.
``nmpc``: its tick (drill_nmpc.advisor_ticks.NmpcTick) once a second on the UKF's
estimate with the floor's command (the inputs the floor decides pinned over its horizon,
its model the string's as racked), its choke flow reference through the choke's flow
loop, its back-pressure pump through the pump's lag.

    python -m drill_studies.trip_bench [--stands 2] [--round-trip] [--controller baseline]
                                       [--connection-s 90] [--pump-stop-share 0.38]
                                       [--settle-s 180] [--seed 12]
                                       [--mismatch thick_report] [--state truth]
                                       [--prediction] [--set nmpc.KEY=VALUE]

prints the trip sheet (per stand, slips to slips), the trip's figures and the seconds
outside the band under and over it by the floor's phase; with
``--prediction`` the NMPC's BHP prediction errors by the floor's phase, as the run report
gives them from a recording.
"""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from drill_analysis import band_report, prediction_report
from drill_core.config import RigConfig, load_rig, parse_settings
from drill_core.schema import ConfigError, build
from drill_core.hydraulics import rig_well_model
from drill_core.mismatch import resolve, truth_config
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import RigFloor
from drill_core.tripping.sequence import DONE, MOVING
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import TripSheet, stands_per_hour
from drill_core.rig_root import config_dir
from drill_core.units import L_PER_M3, PA_PER_BAR
from drill_core.scenario import ActiveSetpoints
from drill_ros.stamps import seconds_to_ns
from drill_estimator.tick import EstimatorTick
from drill_studies.loop_bench import TruthState, ukf_view
from drill_core.estimation_model import build_estimation_model
from drill_nmpc.advisor_ticks import AutomatedMpdTick, BaselineTick, NmpcTick, StartInputs
from drill_nmpc.prediction_model import measured_actuators, nmpc_estimation_model
from drill_plant import plant_model as pm
from drill_plant.actuators import Choke, Drawworks, FrameOutput, Pump
from drill_plant.floor_tick import FloorTick
from drill_plant.simulator import PlantSimulator

CIRCULATION_M3S = 1000.0 / 60000.0
CHOKE_DP_PA = 2.0e6
BHP_REF_PA = 6.85e7
BHP_BAND_PA = 2.0e5
BRAKING_MPS2 = 0.05
CONTROLLERS = ("held_choke", "baseline", "automated_mpd", "nmpc")
STATE_SOURCES = ("ukf", "truth")


@dataclass
class TripRun:
    """A finished bench trip: the plant and the last floor as they ended, a trip sheet per
    programme, their alarms, the per-sample log (arrays by name, SI) and the trip tank's
    settled draw."""
    sim: PlantSimulator
    floor: RigFloor
    sheets: list[TripSheet]
    alarms: list
    log: dict[str, np.ndarray] = field(default_factory=dict)
    drawn_m3: float = math.nan      # the trip tank's volume before less after, settled [m^3]
    solve_times_s: list = field(default_factory=list)   # the NMPC's, per sample
    # the NMPC's solves: (stamp ns, predicted times after it [s], predicted BHP [Pa])
    # (drill_analysis.prediction_report), and the floor's phase at each frame by its stamp
    predictions: list = field(default_factory=list)
    phases: dict = field(default_factory=dict)


def run_trip(config: RigConfig, programmes: Sequence[TripProgramme], seed: int,
             trip_speed_mps: float = 0.5, settle_s: float = 180.0,
             floor_aware: bool = True, max_s: float = 7200.0,
             controller: str = "held_choke", plant_config: RigConfig | None = None,
             state: str = "ukf") -> TripRun:
    """The trips ``programmes`` one after the other (each from the stands the last left
    pulled) from the steady state circulating 1000 L/min at 20 bar of choke dp, then
    ``settle_s`` at rest with the pump on; the estimator follows the floor if
    ``floor_aware``; ``controller`` one of CONTROLLERS. ``plant_config``: the plant and
    the actuators are built from it, the estimator and the controller from ``config``
    (drill_core.mismatch.truth_config; None: the same); the mud pump starts at the plant's
    own stand-pipe pressure and is commanded the model's times the floor's share, as the
    graph's advisors command it. ``state``: what the NMPC plans
    from, one of STATE_SOURCES (``truth``: the oracle of drill_studies.loop_bench)."""
    if controller not in CONTROLLERS:
        raise ValueError(f"controller {controller!r} is not one of {', '.join(CONTROLLERS)}")
    if state not in STATE_SOURCES:
        raise ValueError(f"state {state!r} is not one of {', '.join(STATE_SOURCES)}")
    model_wm = rig_well_model(config)
    plant_config = config if plant_config is None else plant_config
    wm = rig_well_model(plant_config)
    start = pm.steady_state(wm, CIRCULATION_M3S, CHOKE_DP_PA, 0.0)
    sim = PlantSimulator(plant_config, start, seed=seed)
    sim.line_up_trip_tank(True)
    steps, step_s = sim.steps_per_frame, config.plant.step_s
    frame_s = steps * step_s
    remaining = list(programmes)
    drawworks = Drawworks(plant_config.actuators, wm.geometry.static_stretch_m,
                          start.inputs[0])
    floor_tick = FloorTick(config.well, remaining.pop(0), float(start.inputs[0]), step_s)
    floor = floor_tick.floor
    mud_pump = Pump(plant_config.actuators.mud_pump, start.inputs[3])   # the plant's own
    estimator = EstimatorTick(config)
    oracle = TruthState(sim, plant_config, drawworks, estimator.ukf.em) \
        if state == "truth" else None
    choke = Choke(plant_config.actuators, wm, float(start.inputs[1]))
    designed = pm.steady_state(model_wm, CIRCULATION_M3S, CHOKE_DP_PA, 0.0)  # the model's
    start_inputs = StartInputs(designed.choke_flow_m3s, CHOKE_DP_PA, 0.0, designed.inputs[3],
                               True)
    baseline = BaselineTick(config, trip_speed_mps, start_inputs, trip=floor.programme) \
        if controller == "baseline" else None
    bpp = Pump(plant_config.actuators.bpp, 0.0)
    mpd = AutomatedMpdTick(config, build_estimation_model(config), start_inputs,
                           trip=floor.programme) if controller == "automated_mpd" else None
    nmpc = NmpcTick(config, nmpc_estimation_model(config), start_inputs, trip=floor.programme) \
        if controller == "nmpc" else None
    solve_times: list[float] = []
    predictions: list = []
    phases: dict = {}
    advised_at_frame = 0
    per_command = int(round(config.nmpc.sample_time_s / frame_s))
    advice = None
    volumes = StandVolumes.of(wm.geometry, floor.programme.stand_length_m)
    sheets = [TripSheet(floor.programme, volumes, BHP_BAND_PA)]
    u = start.inputs.copy()
    reference_m, frames, string_held, settled_at = 0.0, {}, False, None
    alarms, rows = [], []
    tank_start_m3 = sim.measure(True).trip_tank_volume_m3
    pump_stopped = False
    for k in range(int(round(max_s / frame_s))):
        t = k * frame_s
        m = sim.measure(not pump_stopped)   # the string-flow meter reads while the pump is
        #                                     commanded on (drill_plant.plant_tick)
        if "drawworks" in frames:
            floor_tick.drawworks_frame(frames["drawworks"].output)
        command = floor_tick.step(t, m.hook_load_n, m.block_position_m)
        if command.step.phase == DONE and remaining:
            alarms += sheets[-1].observe(t, command.step, m.bhp_pa, BHP_REF_PA,
                                         m.trip_tank_volume_m3)
            floor = floor_tick.floor = RigFloor(config.well, remaining.pop(0), t,
                                                floor.stands_pulled)
            sheets.append(TripSheet(floor.programme, volumes, BHP_BAND_PA))
            command = floor_tick.step(t, m.hook_load_n, m.block_position_m)
        step = command.step
        phases[seconds_to_ns(t)] = step.phase
        estimator.step(t, m, frames, steps, string_held and floor_aware,
                       pump_stopped and floor_aware)
        if command.racked_to_m is not None and floor_aware:
            estimator.rack(command.racked_from_m, command.racked_to_m)
        alarms += sheets[-1].observe(t, step, m.bhp_pa, BHP_REF_PA, m.trip_tank_volume_m3)
        rows.append((t, step.stand, step.phase == MOVING, sim.line_tension_n(),
                     sim.state[sim.layout.velocity],
                     sim.wm.geometry.bit_above_bhp_node_m + sim.state[sim.layout.position],
                     sim.state[sim.layout.pressure(wm.n)],
                     estimator.ukf.bhp_pa if estimator.ukf.initialised else math.nan))
        if step.phase == DONE:
            settled_at = t + settle_s if settled_at is None else settled_at
            if t >= settled_at:
                break
        if command.racked_to_m is not None:
            sim.rack_string(command.racked_to_m)
        sim.set_hoisting(step.latched, step.slips_set)
        string_held, pump_stopped = command.string_held, command.pump_stopped
        target = step.bit_height_target_m - floor.pulled_m
        if baseline is not None and k % per_command == 0:
            advice, _ = baseline.step(m.block_position_m, m.bhp_pa,
                                      _setpoints(trip_speed_mps), True, math.nan,
                                      m.return_flow_m3s, command)
        if mpd is not None and k % per_command == 0 and estimator.ukf.initialised:
            advice, _ = mpd.step(ukf_view(estimator.ukf, bool(m.string_flow_valid)),
                                 _setpoints(trip_speed_mps), True,
                                 (trip_speed_mps, trip_speed_mps), math.nan, command)
            advised_at_frame = k
        if nmpc is not None and k % per_command == 0 and estimator.ukf.initialised:
            x_hat = estimator.ukf.mean
            if oracle is not None:
                oracle.em = estimator.ukf.em                 # the model as racked
                x_hat = oracle.observe(m, None, t)[1]
            result = nmpc.step(x_hat, _setpoints(trip_speed_mps),
                               measured_actuators(frames), command, t)
            solve_times.append(result.solve_time_s)
            predictions.append((seconds_to_ns(t), list(result.predicted_time_s),
                                list(result.predicted.get("bhp_pa", []))))
            advice = nmpc.command(result, True)
        if step.phase == MOVING and advice is not None and controller != "held_choke":
            block = drawworks.frame(advice.block_position_ref_m, m.block_position_m, step_s,
                                    steps)
        elif step.phase == MOVING:
            gap = abs(target - reference_m)
            speed = min(trip_speed_mps, math.sqrt(2.0 * BRAKING_MPS2 * gap))
            reference_m += math.copysign(min(speed * frame_s, gap), target - reference_m)
            block = drawworks.frame(reference_m, m.block_position_m, step_s, steps)
        else:
            reference_m = m.block_position_m
            block = drawworks.drive_block(command.block_target_m if step.phase != DONE
                                          else drawworks.lag.value, step_s, steps)
        pump = mud_pump.frame(start_inputs.spp_pa * step.pump_factor, step_s, steps)
        inputs = np.repeat(u[:, None], steps, axis=1)
        valve = FrameOutput(u[1], u[1], inputs[1])
        if (baseline is not None or nmpc is not None) and advice is not None:
            valve = choke.frame(advice.choke_flow_ref_m3s, m.choke_dp_pa, step_s, steps,
                                return_flow_m3s=m.return_flow_m3s)
        elif mpd is not None and advice is not None:
            valve = choke.pressure_frame(advice.choke_dp_ref_pa, advice.choke_dp_ref_rate_pa_s,
                                         (k - advised_at_frame) * frame_s,
                                         advice.choke_flow_ref_m3s, m.choke_dp_pa, step_s,
                                         steps)
        back = FrameOutput(u[2], u[2], inputs[2]) if advice is None \
            else bpp.frame(advice.bpp_flow_m3s, step_s, steps)
        inputs[0], inputs[1], inputs[2], inputs[3] = block.output, valve.output, back.output, \
            pump.output
        sim.advance(inputs)
        frames = {"drawworks": block, "mud_pump": pump, "choke": valve, "bpp": back}
    tank_end_m3 = float(np.mean([sim.measure(True).trip_tank_volume_m3 for _ in range(50)]))
    names = ("time_s", "stand", "moving", "line_tension_n", "string_velocity_mps",
             "bit_height_m", "bhp_pa", "bhp_estimate_pa")
    log = {name: np.array(column) for name, column in zip(names, zip(*rows))}
    return TripRun(sim, floor, sheets, alarms, log, tank_start_m3 - tank_end_m3, solve_times,
                   predictions, phases)


def band_figures(run: TripRun) -> dict:
    """The seconds outside the band under and over it by the floor's phase, from the first
    stand's start to the last one's end, as the run report gives them from a recording
    (drill_analysis.band_report)."""
    during = _during_trip(run)
    return band_report.outside_band_by_phase(run.log["time_s"][during], run.log["bhp_pa"][during],
                                             BHP_REF_PA, BHP_BAND_PA, run.phases)


def prediction_figures(run: TripRun) -> dict:
    """The NMPC's prediction errors against the truth plant's BHP, as the run report gives
    them from a recording (drill_analysis.prediction_report); {} without NMPC solves."""
    return prediction_report.errors_over_run(run.predictions, run.log["time_s"],
                                             run.log["bhp_pa"], run.phases)


def _setpoints(trip_speed_mps: float) -> ActiveSetpoints:
    """trip_out's setpoints (Case 2's, the choke dp free to rise to the BHP band's bottom);
    no block target: the advisors take each stand's from the floor's command."""
    return ActiveSetpoints(bhp_ref_pa=BHP_REF_PA, bhp_band_pa=BHP_BAND_PA,
                           choke_dp_ref_pa=CHOKE_DP_PA, choke_dp_band_pa=5.0e5,
                           choke_dp_band_upper_pa=6.63e7,
                           block_position_target_m=math.nan,
                           trip_speed_limit_mps=trip_speed_mps, controller_enabled=True,
                           mud_pump_on=True)


def _during_trip(run: TripRun) -> np.ndarray:
    """The log's samples from the first stand's start to the last one's end."""
    rows = [row for sheet in run.sheets for row in sheet.rows]
    t = run.log["time_s"]
    return (t >= rows[0].start_s) & (t <= rows[-1].end_s)


def trip_figures(run: TripRun, pore_pressure_pa: float) -> dict[str, float]:
    """The trip's figures from the first stand's start to the last one's end (SI)."""
    rows = [row for sheet in run.sheets for row in sheet.rows]
    t = run.log["time_s"]
    during = _during_trip(run)
    bhp = run.log["bhp_pa"][during]
    frame_s = float(t[1] - t[0])
    truth = run.sim.truth()
    return {"stands_per_hour": stands_per_hour(rows),
            "bhp_rmse_pa": float(np.sqrt(np.mean((bhp - BHP_REF_PA) ** 2))),
            "outside_band_s": frame_s * float(np.sum(np.abs(bhp - BHP_REF_PA) > BHP_BAND_PA)),
            "bhp_min_pa": float(bhp.min()), "bhp_max_pa": float(bhp.max()),
            "under_pore_pressure_s": frame_s * float(np.sum(bhp < pore_pressure_pa)),
            "influx_m3": truth.influx_volume_m3, "loss_m3": truth.loss_volume_m3,
            "trip_tank_drawn_m3": run.drawn_m3,
            "trip_sheet_gain_m3": sum(sheet.cumulative_gain_m3 for sheet in run.sheets)}


def sheet_table(run: TripRun) -> list[str]:
    """The trip sheet as a markdown table (display units: s, bar, L)."""
    lines = ["| trip | stand | slips to slips [s] | out of slips [s] | peak surge / swab [bar] "
             "| outside band [s] | expected / measured fill [L] | gain, running [L] |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for sheet in run.sheets:
        for row in sheet.rows:
            lines.append(
                f"| {sheet.programme.direction} | {row.stand} | {row.end_s - row.start_s:.0f} "
                f"| {row.out_of_slips_s:.0f} | {row.peak_surge_pa / PA_PER_BAR:.2f} / "
                f"{row.peak_swab_pa / PA_PER_BAR:.2f} | {row.outside_band_s:.0f} "
                f"| {row.expected_fill_m3 * L_PER_M3:.0f} / {row.measured_fill_m3 * L_PER_M3:.0f} "
                f"| {row.gain_m3 * L_PER_M3:+.0f}, {row.cumulative_gain_m3 * L_PER_M3:+.0f} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m drill_studies.trip_bench",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--stands", type=int, default=2)
    parser.add_argument("--round-trip", action="store_true",
                        help="pull the stands out, then run them back in")
    parser.add_argument("--controller", choices=CONTROLLERS, default="held_choke")
    parser.add_argument("--connection-s", type=float, default=90.0,
                        help="slips to slips of each connection [s]")
    parser.add_argument("--pump-stop-share", type=float, default=None,
                        help="the ramp-down shaped for the flow: the share at which the "
                             "bit's flow stops (drill_core.tripping.programme; unset: linear)")
    parser.add_argument("--settle-s", type=float, default=180.0,
                        help="at rest after the trip, the pump on, before the tank is read [s]")
    parser.add_argument("--seed", type=int, default=12)
    parser.add_argument("--mismatch", help="the plant differs from the model: a member of "
                                           "config/mismatch.yaml or draw:N")
    parser.add_argument("--state", choices=STATE_SOURCES, default="ukf",
                        help="what the NMPC plans from (truth: an oracle)")
    parser.add_argument("--prediction", action="store_true",
                        help="the NMPC's BHP prediction errors by the floor's phase")
    parser.add_argument("--set", action="append", default=[],
                        help="config override FILE.KEY=VALUE of the estimator's and the "
                             "controller's side only (the plant keeps config/), e.g. "
                             "nmpc.floor_pump_on_share=0.3")
    args = parser.parse_args(argv)
    written = load_rig(config_dir())           # the plant's side: config/ as it is
    try:
        config = load_rig(config_dir(), parse_settings(args.set)) if args.set else written
    except ConfigError as error:
        parser.error(str(error))
    plant_config = written if args.mismatch is None else \
        truth_config(written, resolve(args.mismatch, config_dir())[1])
    directions = ("out", "in") if args.round_trip else ("out",)
    try:
        programmes = [build(TripProgramme, {"direction": d, "stands": args.stands,
                                            "connection_s": args.connection_s,
                                            "pump_stop_share": args.pump_stop_share},
                            "the command line", "trip") for d in directions]
    except ConfigError as error:
        parser.error(str(error))
    run = run_trip(config, programmes, args.seed, settle_s=args.settle_s,
                   controller=args.controller, plant_config=plant_config, state=args.state)
    print("\n".join(sheet_table(run)) + "\n")
    f = trip_figures(run, config.well.formation.pore_pressure_pa)
    print(f"stands per hour {f['stands_per_hour']:.1f}; BHP RMSE "
          f"{f['bhp_rmse_pa'] / PA_PER_BAR:.2f} bar, {f['outside_band_s']:.0f} s outside the band, "
          f"{f['bhp_min_pa'] / PA_PER_BAR:.1f}-{f['bhp_max_pa'] / PA_PER_BAR:.1f} bar, "
          f"{f['under_pore_pressure_s']:.0f} s under the pore pressure; influx "
          f"{f['influx_m3'] * L_PER_M3:.0f} L, losses {f['loss_m3'] * L_PER_M3:.0f} L; trip "
          f"tank {f['trip_tank_drawn_m3'] * L_PER_M3:.0f} L drawn ({args.settle_s:.0f} s "
          f"after), the sheet's gain {f['trip_sheet_gain_m3'] * L_PER_M3:+.0f} L")
    print("\n".join(band_report.format_rows(band_figures(run))))
    errors = prediction_figures(run) if args.prediction else {}
    if errors:
        print("\n".join(prediction_report.format_rows(errors)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
