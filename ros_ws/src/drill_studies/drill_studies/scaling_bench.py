"""Cost as the well grows (scripts/bench, docs/benchmarks.md): the reference well's annulus
cut into n segments (the cased part into n - 1 equal ones over the open-hole bottom
segment, so the casing shoe and the depths stay where they are and n = 4 is the reference
well itself) and, per n, one plant frame, one UKF frame, the NMPC1 solve on the
in-process loop (drill_nmpc.bench) and Case 2 through the whole graph in fast mode in the
default layout; the growth exponents are least-squares slopes on log-log axes.

    python -m drill_studies.scaling_bench [--counts 4 6 8] [--skip-graph]
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path

import numpy as np
import yaml

from drill_bringup import launcher, runs
from drill_core.config import RigConfig, load_rig, replace
from drill_ros import budget
from drill_estimator.bench import time_filter
from drill_nmpc.bench import solve_profile
from drill_nmpc.transcription import RTI_PARTS
from drill_plant.bench import plant_frame_cost
from drill_studies.graph_runs import graph_rtf

SEGMENT_COUNTS = (4, 6, 8, 12, 16)
CONFIGURATION = "NMPC1"          # Case 2's
SAMPLES = 150                    # NMPC solves per n, drill_nmpc.bench's loop
FRICTION_FACTOR = 1.1            # the loop plant's friction over the model's, as drill_nmpc.bench
EXPONENT_GOAL = 1.0              # the NMPC solve and the UKF frame: no faster than linear in n
WALL_RATIO_GOAL = 1.5            # Case 2's graph wall at n = 6 over n = 4
PARTS = (*RTI_PARTS, "other")   # a solve's parts (drill_nmpc.bench.solve_profile), per solve
GROWTH = (("plant_frame_s", "plant frame"), ("ukf_frame_s", "UKF frame"),
          ("ukf_time_update_s", "the UKF's time update"),
          ("ukf_measurement_update_s", "the UKF's measurement update"),
          ("solve_median_s", "NMPC solve median"), ("solve_p99_s", "NMPC solve p99"),
          *((f"{part}_s", f"the solve's {part}") for part in PARTS),
          ("graph_wall_s", "Case 2 graph wall"))
# the growths with a goal, each with the parts it adds up from (what bounds a missed goal)
GOALS = {"ukf_frame_s": ("ukf_time_update_s", "ukf_measurement_update_s"),
         "solve_median_s": tuple(f"{part}_s" for part in PARTS)}


def segment_lengths_m(lengths_m, n: int) -> tuple[float, ...]:
    """The annulus of ``lengths_m`` (top first, the open hole last) in ``n`` segments: the
    cased part above the bottom segment cut into n - 1 equal ones."""
    if n < 2:
        raise ValueError(f"n = {n}: a well has at least 2 annulus segments")
    cased_m = sum(lengths_m[:-1])
    return (cased_m / (n - 1),) * (n - 1) + (lengths_m[-1],)


def segmented(config: RigConfig, n: int) -> RigConfig:
    """``config`` with its well in ``n`` segments (segment_lengths_m)."""
    if config.well.segment_hole_diameters_m is not None:
        raise ValueError("segment_hole_diameters_m is set: the scaling bench cuts a gauge hole")
    return replace(config, well=replace(config.well, segment_lengths_m=segment_lengths_m(
        config.well.segment_lengths_m, n)))


def exponent(counts, values) -> float:
    """The slope of log(value) against log(n), least squares."""
    return float(np.polyfit(np.log(counts), np.log(values), 1)[0])


def growth_exponents(rows: list[dict]) -> dict:
    """k per figure of GROWTH over the rows (cost ~ n^k), where every row has it positive
    and the rows span more than one n."""
    counts = [r["n"] for r in rows]
    return {key: exponent(counts, [r[key] for r in rows]) for key, _ in GROWTH
            if len(set(counts)) > 1 and all(r.get(key, 0.0) > 0.0 for r in rows)}


def in_process(config: RigConfig, samples: int = SAMPLES) -> dict:
    """One plant frame, one UKF frame (time update over the frame plus the measurement
    update) and the NMPC1 solves of the in-process loop with their parts
    (drill_nmpc.bench.solve_profile), for ``config``'s well."""
    plant = plant_frame_cost(config, repetitions=500)
    ukf = time_filter(config, repetitions=150)
    profile = solve_profile(samples, CONFIGURATION, config=config)
    return {"states": int(ukf["states"]),
            "plant_frame_s": plant["plant_frame_median_s"],
            "ukf_frame_s": ukf["frame_ms"] * 1e-3,
            "ukf_time_update_s": ukf["frame_time_update_ms"] * 1e-3,
            "ukf_measurement_update_s": ukf["measurement_update_ms"] * 1e-3,
            "solve_median_s": profile["median_solve_s"], "solve_p99_s": profile["p99_solve_s"],
            **{f"{part}_s": profile[f"{part}_s_per_solve"] for part in PARTS},
            "nmpc_build_s": profile["build_s"]}


def staged_config(n: int, directory: Path) -> Path:
    """The checkout's config/ staged under ``directory`` (runs.stage_config) with well.yaml's
    annulus in ``n`` segments; returns the staged configuration's directory."""
    directory = runs.stage_config(directory)
    well = yaml.safe_load((directory / "well.yaml").read_text())
    well["segment_lengths_m"] = list(segment_lengths_m(well["segment_lengths_m"], n))
    (directory / "well.yaml").write_text(yaml.safe_dump(well, sort_keys=False))
    return directory


def run(domain_id: int, counts=SEGMENT_COUNTS, skip_graph: bool = False) -> dict:
    """Every figure per n in ``counts`` (``skip_graph``: the in-process ones only)."""
    base = load_rig(runs.ROOT / "config")
    rows = []
    for n in counts:
        row = {"n": n, **in_process(segmented(base, n))}
        if not skip_graph:
            with tempfile.TemporaryDirectory() as tmp:
                graph = graph_rtf("case2", domain_id, None, config_source=staged_config(n, Path(tmp)))
            row.update(graph_wall_s=graph["wall_s"], graph_rtf=graph["rtf"],
                       graph_cpu_s=budget.totals(graph["budget"])["cpu_s"])
        print(f"[bench] scaling n = {n}: {json.dumps(row)}", flush=True)
        rows.append(row)
    exponents = growth_exponents(rows)
    by_n = {r["n"]: r for r in rows}
    wall_ratio = (by_n[6]["graph_wall_s"] / by_n[4]["graph_wall_s"]
                  if {4, 6} <= by_n.keys() and "graph_wall_s" in by_n[4] else math.nan)
    return {"rows": rows, "exponents": exponents, "wall_ratio_6_4": wall_ratio}


def _goal(met: bool) -> str:
    return "" if met else ": missed"


def markdown(scaling: dict) -> list[str]:
    """The section of docs/benchmarks.md."""
    rows, exponents = scaling["rows"], scaling["exponents"]
    graph = "graph_wall_s" in rows[0]
    lines = ["## Cost as the well grows", "",
             "The reference well's annulus in n segments (the cased 3276 m cut into n - 1 equal "
             "ones over the open-hole bottom segment; n = 4 is the reference well; "
             "`drill_studies.scaling_bench`): one plant frame and one UKF frame in process "
             f"(medians), {CONFIGURATION}'s solves on the NMPC section's loop ({SAMPLES} "
             "samples)" + (", and Case 2 through the graph in fast mode in the default layout "
                           "(one run each, start-up included)" if graph else "") + ":", "",
             "| n | states | plant frame | UKF frame | NMPC solve median | p99 | "
             + " | ".join(f"{part} (mean)" for part in PARTS) + " | NMPC build"
             + (" | graph wall | real-time factor | graph CPU |" if graph else " |"),
             "| --- " * (7 + len(PARTS) + 3 * graph) + "|"]
    for r in rows:
        lines.append(
            f"| {r['n']} | {r['states']} | {r['plant_frame_s'] * 1e3:.3f} ms | "
            f"{r['ukf_frame_s'] * 1e3:.2f} ms | {r['solve_median_s'] * 1e3:.1f} ms | "
            f"{r['solve_p99_s'] * 1e3:.1f} ms | "
            + "".join(f"{r[f'{part}_s'] * 1e3:.2f} ms | " for part in PARTS)
            + f"{r['nmpc_build_s']:.1f} s |" + (
                f" {r['graph_wall_s']:.1f} s | {r['graph_rtf']:.3f} | {r['graph_cpu_s']:.1f} s |"
                if graph else ""))
    if exponents:
        lines += ["", "Growth with n (cost ~ n^k, k fitted over the rows): " + "; ".join(
            f"{what} k = {exponents[key]:.2f}"
            + (f" (goal: <= {EXPONENT_GOAL:g}{_goal(exponents[key] <= EXPONENT_GOAL)})"
               if key in GOALS else "")
            for key, what in GROWTH if key in exponents) + "."]
    names = dict(GROWTH)
    first, last = rows[0], rows[-1]
    for key, parts in GOALS.items():
        if exponents.get(key, -math.inf) > EXPONENT_GOAL:
            part = max(parts, key=lambda p: last[p] - first[p])
            lines.append(f"What bounds the {names[key]}'s growth: {names[part]}, k = "
                         f"{exponents[part]:.2f}, {(last[part] - first[part]) * 1e3:.1f} ms of "
                         f"the {(sum(last[p] for p in parts) - sum(first[p] for p in parts)) * 1e3:.1f} ms "
                         f"its parts (mean) grew from n = {first['n']} to n = {last['n']}.")
    ratio = scaling["wall_ratio_6_4"]
    if not math.isnan(ratio):
        lines.append(f"Case 2's graph wall at n = 6 is {ratio:.2f} times n = 4's (goal: <= "
                     f"{WALL_RATIO_GOAL:g}{_goal(ratio <= WALL_RATIO_GOAL)}).")
    return lines + [""]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", type=int, nargs="+", default=list(SEGMENT_COUNTS))
    parser.add_argument("--skip-graph", action="store_true",
                        help="the in-process figures only")
    args = parser.parse_args(argv)
    result = run(launcher.default_domain_id(), args.counts, args.skip_graph)
    print(json.dumps(result, indent=2))
    print("\n".join(markdown(result)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
