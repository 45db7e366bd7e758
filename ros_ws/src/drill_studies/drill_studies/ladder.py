"""Where a controller's loss comes from: the same trip, seeds and controller on rungs that
add one source of error each (docs/nmpc.md), and the design steps from the paper's NMPC
formulation to the shipped one, one at a time.

Rungs, all in-process (drill_studies.loop_bench) except the last:
  model plant   the prediction model itself as the plant, its state known exactly
                (drill_nmpc.bench: the upper bound of this formulation and actuation);
  truth state   the truth plant (Herschel-Bulkley friction, noise), the controller fed
                its true state (an oracle: friction factors fitted to the truth);
  UKF state     the truth plant, the controller fed the UKF's estimates;
  full graph    the process graph over DDS (docs/results.json of ``rig compare``).

    python -m drill_studies.ladder [--seeds N] [--case case2] > ladder.md
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from drill_bringup import runs
from drill_studies import loop_bench
from drill_analysis.report import ARRIVAL_TOLERANCE_M, format_legs, tracking_metrics
from drill_core.config import RigConfig
from drill_core.scenario import load_scenario_config
from drill_core.units import PA_PER_BAR
from drill_nmpc.bench import closed_loop
from drill_nmpc.motion_profile import MotionProfile

# The paper's formulation (Tengesdal & Holden 2020) in this code base, then the design
# steps of docs/nmpc.md, each added to the ones before it.
PAPER = {"choke_control": "flow", "block_reference": "exponential", "control_horizon_s": 3.0,
         "bhp_bias_gain": 0.0, "max_iterations": 1,
         "input_move_weight": {"block_position_m": 10.0, "choke_flow_m3s": 1.0,
                               "bpp_flow_m3s": 1.0, "spp_pa": 10.0},
         "output_weight": {"block_position_m": 10.0, "choke_dp_pa": 0.0, "bhp_pa": 50.0}}
STEPS = (   # (label, NMPC overrides added, block integral from the drawworks)
    ("paper formulation (flow-controlled choke, eq. 59 reference, N_c = 3, 1 SQP step)",
     {}, False),
    ("+ block-controller integral from the drawworks' command", {}, True),
    ("+ choke on its pressure loop (the NMPC plans the dp set-point)",
     {"choke_control": "pressure"}, True),
    ("+ block reference = the trip's motion profile", {"block_reference": "profile"}, True),
    ("+ control horizon = prediction horizon (15 s)", {"control_horizon_s": 15.0}, True),
    ("+ pumps hold the circulation (move weight 1e4)",
     {"input_move_weight": {"block_position_m": 10.0, "choke_flow_m3s": 1.0,
                            "bpp_flow_m3s": 1.0e4, "spp_pa": 1.0e4}}, True),
    ("+ offset-free BHP (bias from one-step prediction errors, gain 0.2)",
     {"bhp_bias_gain": 0.2}, True),
    ("+ choke-flow input again, on the real-time iteration (shipped)",
     {"choke_control": "flow"}, True),
)


def _merge(base: dict, over: dict) -> dict:
    return {**base, **over}


def _row(label: str, results: list[dict]) -> str:
    def stat(key, scale=1.0, digits=2):
        values = [r[key] for r in results]
        return f"{np.mean(values) / scale:.{digits}f} / {max(values) / scale:.{digits}f}"
    legs = "; ".join(format_legs(r["trip_legs"]) for r in results)
    speed = max(r["max_string_speed_mps"] for r in results)
    solve = ""
    if "solve_time_median_s" in results[0]:
        solve = f"{max(r['solve_time_median_s'] for r in results) * 1e3:.0f}"
    return (f"| {label} | {stat('bhp_rmse_pa', PA_PER_BAR)} | "
            f"{stat('bhp_time_outside_settled_s', 1.0, 1)} | "
            f"{stat('bhp_worst_excursion_pa', PA_PER_BAR)} | {legs} | {speed:.2f} | "
            f"{stat('trip_overshoot_m')} | {solve} |")


HEADER = ("| rung / design | BHP RMSE [bar] | outside band, settled [s] | worst excursion [bar] "
          "| trip legs per seed | max string speed [m/s] | past target [m] | solve median [ms] |"
          "\n| --- | --- | --- | --- | --- | --- | --- | --- |")


def model_plant(config: RigConfig, scenario) -> dict:
    """The case's trip with the prediction model as the plant and its exact state."""
    times = [c.time_s for c in scenario.schedule if not math.isnan(c.block_position_target_m)]
    upper = scenario.schedule[0].choke_dp_band_upper_pa
    log, sup = closed_loop(config, config.nmpc.configuration, int(scenario.duration_s),
                           out_at=times[1], in_at=times[2],
                           dp_band_upper_pa=0.0 if math.isnan(upper) else upper)
    a = log.arrays()
    target = np.where((a["time_s"] >= times[1]) & (a["time_s"] < times[2]), 28.0, 0.0)
    out = tracking_metrics(a["time_s"], a["bhp_pa"], a["block_position_m"], a["bhp_ref_pa"],
                           np.full(len(target), config.nmpc.bhp_band_pa), target)
    out["solve_time_median_s"] = float(np.median(a["solve_time_s"]))
    out["max_string_speed_mps"] = float(np.max(np.abs(a["velocity_mps"])))
    return out


def profile_leg_s(config: RigConfig, scenario) -> float:
    """The trip's motion profile alone (the block reference at the scenario's speed limit
    and the protection's acceleration limit, from rest): seconds until it is within the
    report's arrival tolerance of the first target. A string that never exceeds the speed
    limit and starts behind its reference arrives no earlier."""
    first = next(c for c in scenario.schedule[1:] if not math.isnan(c.block_position_target_m))
    speed = scenario.schedule[0].trip_speed_limit_mps
    accel = config.protection.trip_acceleration_max_mps2
    ts = config.nmpc.sample_time_s
    profile, time_s = MotionProfile(0.0), 0.0
    while abs(profile.position_m - first.block_position_target_m) > ARRIVAL_TOLERANCE_M:
        profile.step(first.block_position_target_m, speed, accel, ts)
        time_s += ts
    return time_s


def rungs(case: str, seeds: list[int], results_json: Path | None) -> list[str]:
    scenario, config = load_scenario_config(runs.scenario_path(case), runs.ROOT / "config")
    lines = [f"The motion profile alone reaches the first target (within "
             f"{ARRIVAL_TOLERANCE_M} m) after {profile_leg_s(config, scenario):.1f} s.", "",
             HEADER, _row("model plant, exact state", [model_plant(config, scenario)])]
    for state, label in (("truth", "truth plant, true state"), ("ukf", "truth plant, UKF state")):
        lines.append(_row(label, [loop_bench.run(case, "nmpc", state, seed) for seed in seeds]))
    if results_json is not None and results_json.exists():
        rows = [r["summary"] for r in json.loads(results_json.read_text())
                if r["case"] == case and r["controller"] == "nmpc" and r["seed"] in seeds]
        if rows:
            lines.append(_row("full graph over DDS", rows))
    return lines


def design_steps(case: str, seeds: list[int]) -> list[str]:
    lines = [HEADER]
    overrides = dict(PAPER)
    for label, change, block_integral in STEPS:
        overrides = _merge(overrides, change)
        results = [loop_bench.run(case, "nmpc", "ukf", seed, {"nmpc": overrides}, block_integral)
                   for seed in seeds]
        lines.append(_row(label, results))
        print(lines[-1], file=sys.stderr, flush=True)
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="case2")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--results", type=Path, default=runs.ROOT / "docs" / "results.json")
    parser.add_argument("--only", choices=("rungs", "steps"))
    args = parser.parse_args(argv)
    scenario, _ = load_scenario_config(runs.scenario_path(args.case), runs.ROOT / "config")
    seeds = [scenario.seed + offset for offset in (0, 1000, 2000)[:args.seeds]]
    print(f"{args.case}, seeds {', '.join(map(str, seeds))} (mean / worst)\n")
    if args.only != "steps":
        print("\n".join(rungs(args.case, seeds, args.results)) + "\n", flush=True)
    if args.only != "rungs":
        print("\n".join(design_steps(args.case, seeds)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
