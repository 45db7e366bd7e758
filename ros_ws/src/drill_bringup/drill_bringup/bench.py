"""Benchmarks (scripts/bench): plant step cost, estimator and NMPC timings, and the
real-time factor of the graph in fast mode. Results go to docs/benchmarks.md; all
ratios in one file come from one run on one machine."""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import numpy as np
import yaml

from drill_bringup import launcher, runs
from drill_core.ros import graph as graph_decl
from drill_core.ros import topics
from drill_core import hydraulics as hy
from drill_core.scenario import load_scenario_config
from drill_plant.plant_model import steady_state
from drill_plant.simulator import PlantSimulator

PAPER_SOLVE_S = 16.4


def plant_frame_cost(repetitions: int = 2000) -> dict:
    """Wall time of one 0.1 s plant frame (10 steps x 2 SRK substeps) in-process."""
    _, config = load_scenario_config(runs.ROOT / "config/scenarios/case2.yaml", runs.ROOT / "config")
    wm = hy.build_well_model(config.well, config.plant.yield_regularisation_velocity_mps,
                             config.plant.choke_regularisation_pa)
    ss = steady_state(wm, 0.016667, 2.0e6, 0.0)
    sim = PlantSimulator(config, ss, seed=1)
    inputs = np.tile(ss.inputs[:, None], (1, sim.steps_per_frame))
    times = []
    for _ in range(repetitions):
        start = time.perf_counter()
        sim.advance(inputs)
        times.append(time.perf_counter() - start)
    frame_s = statistics.median(times)
    return {"plant_frame_median_s": frame_s, "plant_step_median_s": frame_s / sim.steps_per_frame,
            "plant_core_rtf": frame_s / config.plant.sensor_period_s}


def graph_rtf(scenario: str, domain_id: int, friction_law: str | None = None) -> dict:
    """Wall time of a whole scenario through the process graph in fast mode: from starting
    the processes to the recorder closing its file (the report afterwards is timed apart).
    ``friction_law`` runs the scenario with that annular friction law instead of the
    configured one (a copy of the scenario file with the estimator override)."""
    path = runs.scenario_path(scenario)
    with tempfile.TemporaryDirectory() as tmp:
        if friction_law is not None:
            data = yaml.safe_load(path.read_text())
            data.setdefault("overrides", {}).setdefault("estimator", {})["annular_friction_law"] = friction_law
            path = Path(tmp) / path.name
            path.write_text(yaml.safe_dump(data))
        scenario_obj, config = load_scenario_config(path, runs.ROOT / "config")
        start = time.monotonic()
        code, run_dir = runs.run_scenario(path, runs_dir=Path(tmp), domain_id=domain_id, quiet=True)
        total = time.monotonic() - start
        launch = json.loads((run_dir / "launch.json").read_text())
        if code != 0:
            raise RuntimeError(f"{scenario} failed: {launch}")
    wall = launch["wall_time_s"]
    return {"scenario": scenario, "friction_law": config.estimator.annular_friction_law,
            "simulated_s": scenario_obj.duration_s, "wall_s": wall,
            "rtf": wall / scenario_obj.duration_s, "report_s": total - wall}


def plant_actuators_rtf(domain_id: int) -> dict:
    """Plant + the four actuator processes alone (no estimator/controller) over Case 2's 600 s."""
    path = runs.scenario_path("case2")
    with tempfile.TemporaryDirectory() as tmp:
        common = {"config_dir": str(runs.ROOT / "config"), "scenario": str(path), "mode": "fast"}
        declared = [graph_decl.BY_NAME[n] for n in (*topics.ACTUATORS, "plant")]
        nodes = [launcher.NodeSpec(n, "drill_plant.actuator_node",
                                   {"actuator": n, "command_period_s": 0.0})
                 for n in topics.ACTUATORS]
        wait = graph_decl.lockstep_endpoints(declared, fast=True)
        nodes.append(launcher.NodeSpec("plant", "drill_plant.plant_node", {"wait_for": wait},
                                       finishes=True))
        for node in nodes:
            node.params.update(common)
            node.params["use_sim_time"] = launcher.uses_sim_time(node.name, fast=True)
        launch = launcher.Launch(nodes, Path(tmp), domain_id)
        start = time.monotonic()
        launch.start()
        ok, message = launch.watch(600)
        wall = time.monotonic() - start
        launch.stop()
        if not ok:
            raise RuntimeError(message)
    return {"wall_s": wall, "rtf": wall / 600.0}


def write_doc(results: dict, path: Path) -> None:
    lines = [
        "# Benchmarks",
        "",
        f"Measured by `scripts/bench` on {datetime.now():%Y-%m-%d %H:%M} "
        f"({platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}). One run; all ratios below come from it.",
        "",
        "## Plant",
        "",
        "| quantity | value |",
        "| --- | --- |",
        f"| one 0.1 s plant frame (10 steps x 2 SRK substeps, compiled CasADi) | "
        f"{results['plant']['plant_frame_median_s'] * 1e3:.3f} ms |",
        f"| one 0.01 s plant step | {results['plant']['plant_step_median_s'] * 1e6:.1f} us |",
        f"| plant core alone, real-time factor | {results['plant']['plant_core_rtf']:.4f} |",
        f"| plant + 4 actuator processes over DDS, 600 s Case 2 (fast mode) | "
        f"{results['plant_actuators']['wall_s']:.1f} s wall, RTF {results['plant_actuators']['rtf']:.3f} "
        "(target: < 10 s) |",
        "",
    ]
    for key, title in (("estimator", "Estimator"), ("nmpc", "NMPC")):
        if key in results:
            lines += [f"## {title}", "", "| quantity | value |", "| --- | --- |"]
            lines += [f"| {k} | {v:.6g} |" if isinstance(v, float) else f"| {k} | {v} |"
                      for k, v in results[key].items()]
            lines.append("")
    if "graph" in results:
        lines += ["## Whole graph", "",
                  "Case 2 (600 s) through all processes over DDS in fast mode, from process start "
                  "to the recording closed (target: <= 60 s wall, RTF <= 0.1), with each annular "
                  "friction law of the shared estimation model (docs/nmpc.md):", "",
                  "| friction law | wall | real-time factor | report afterwards |",
                  "| --- | --- | --- | --- |"]
        lines += [f"| {g['friction_law']} | {g['wall_s']:.1f} s | {g['rtf']:.3f} | {g['report_s']:.1f} s |"
                  for g in results["graph"]]
        lines.append("")
    path.write_text("\n".join(lines))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="bench", description=__doc__)
    parser.add_argument("--output", type=Path, default=runs.ROOT / "docs" / "benchmarks.md")
    parser.add_argument("--skip-graph", action="store_true", help="skip the 10-minute Case 2 run")
    args = parser.parse_args(argv)
    domain = launcher.default_domain_id()
    results = {"plant": plant_frame_cost()}
    print(f"[bench] plant frame {results['plant']['plant_frame_median_s'] * 1e3:.3f} ms", flush=True)
    results["plant_actuators"] = plant_actuators_rtf(domain)
    print(f"[bench] plant + actuators: {results['plant_actuators']['wall_s']:.1f} s", flush=True)
    from drill_estimator import bench as estimator_bench
    results["estimator"] = estimator_bench.run_benchmark()
    print("[bench] estimator done", flush=True)
    from drill_nmpc import bench as nmpc_bench
    results["nmpc"] = nmpc_bench.run_benchmark()
    print("[bench] nmpc done", flush=True)
    if not args.skip_graph:
        results["graph"] = [graph_rtf("case2", domain), graph_rtf("case2", domain, "quadratic")]
        for g in results["graph"]:
            print(f"[bench] case2 graph ({g['friction_law']}): {g['wall_s']:.1f} s", flush=True)
    write_doc(results, args.output)
    print(f"[bench] wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
