"""Benchmarks (scripts/bench): plant step cost, estimator and NMPC timings, the real-time
factor of the graph in fast mode per process layout with its time budget, and the realtime
plant's frame lateness. Results go to docs/benchmarks.md; all
ratios in one file come from one run on one machine. Each whole-graph figure is the
median of ``REPEATS`` runs with their range: this machine's speed drifts between runs
(the same run's CPU time varied by up to 15 %)."""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from drill_analysis import report
from drill_bringup import launcher, runs
from drill_ros import budget
from drill_ros.executors import DEFAULT_EXECUTOR
from drill_ros import graph as graph_decl
from drill_ros import topics
from drill_core.config import load_rig
from drill_core.scenario import MULTI_STAND_CONTROLLERS, load_scenario_config
from drill_plant.bench import plant_frame_cost
from drill_nmpc.transcription import RTI_PARTS
from drill_studies import scaling_bench, sweep_bench
from drill_studies.graph_runs import graph_rtf, with_executor

PAPER_SOLVE_S = 16.4
REPEATS = 3


def median_run(measure, repeats: int = REPEATS) -> dict:
    """The run of median wall time of ``repeats`` calls of ``measure``, with every wall
    time (``walls_s``, sorted)."""
    done = sorted((measure() for _ in range(repeats)), key=lambda r: r["wall_s"])
    return {**done[len(done) // 2], "walls_s": [r["wall_s"] for r in done]}


def _walls(r: dict) -> str:
    """'median s (min-max)' of a median_run."""
    return f"{r['wall_s']:.1f} s ({r['walls_s'][0]:.1f}-{r['walls_s'][-1]:.1f})"


# (process layout, executor): the one-process-per-node graph on the single-threaded
# executor first (the path before composition), then each layout on the default executor,
# then the command users run (no layout named: graph.default_layout)
GRAPH_CONFIGURATIONS = (("separate", "single_threaded"), ("separate", DEFAULT_EXECUTOR),
                        ("actuators", DEFAULT_EXECUTOR), ("plant", DEFAULT_EXECUTOR),
                        ("two", DEFAULT_EXECUTOR), (None, DEFAULT_EXECUTOR))
DEFAULT_WALL_GOAL = 1.05        # the default command's wall over the fastest layout's
# a whole section tripped (drill_core.tripping) under each controller that plans one, in the
# default layout, one run each; the goal: ten stands in under two minutes of wall
MULTI_STAND_RUNS = tuple((case, controller) for case in ("trip_out", "trip_in")
                         for controller in MULTI_STAND_CONTROLLERS)
MULTI_STAND_WALL_GOAL_S = 120.0
PROFILE_SHARE_GOAL = 0.80       # the QP's and the compiled evaluations' share of a solve
PEER_SPEEDUP_GOAL = 20.0        # the NMPC's median solve against the faster peer's
DRILLING_RTF_GOAL = 0.5         # every drilling scenario's graph wall over its simulated time
FLOOR_GOAL = 2.0                # the default layout's Case 2 CPU over its arithmetic
FLOOR_NMPC = "nmpc1"            # Case 2's NMPC configuration (its solves in the floor)


def plant_actuators_rtf(domain_id: int, layout: str = "separate",
                        executor: str = DEFAULT_EXECUTOR) -> dict:
    """Plant + the four actuators alone (no estimator/controller) over Case 2's 600 s."""
    path = runs.scenario_path("case2")
    with with_executor(executor), tempfile.TemporaryDirectory() as tmp:
        common = {"config_dir": str(runs.ROOT / "config"), "scenario": str(path), "mode": "fast"}
        declared = [graph_decl.BY_NAME[n] for n in (*topics.ACTUATORS, "plant")]
        nodes = [launcher.NodeSpec.of(n, {"actuator": n, "command_period_s": 0.0})
                 for n in topics.ACTUATORS]
        wait = graph_decl.lockstep_endpoints(declared, fast=True,
                                             local=graph_decl.local_subscriptions(layout, declared))
        nodes.append(launcher.NodeSpec.of("plant", {"wait_for": wait}, finishes=True))
        for node in nodes:
            node.params.update(common)
            node.params["use_sim_time"] = launcher.uses_sim_time(node.name, fast=True)
        launch = launcher.Launch(nodes, Path(tmp), domain_id, layout)
        start = time.monotonic()
        launch.start()
        ok, message = launch.watch(600)
        wall = time.monotonic() - start
        launch.stop()
        if not ok:
            raise RuntimeError(message)
    return {"layout": layout, "executor": executor, "wall_s": wall, "rtf": wall / 600.0}


def realtime_margins(domain_id: int, busy_domain_id: int | None = None) -> dict:
    """How late the realtime plant's frames are on the short trip, alone or (with
    ``busy_domain_id``) while a fast-mode Case 2 run shares the machine."""
    busy = None
    with tempfile.TemporaryDirectory() as tmp:
        if busy_domain_id is not None:
            busy = subprocess.Popen(
                [sys.executable, "-c", "import sys; from drill_bringup import runs; "
                 "from pathlib import Path; sys.exit(runs.run_scenario(runs.scenario_path("
                 f"'case2'), runs_dir=Path({tmp!r}) / 'busy', domain_id={busy_domain_id}, "
                 "quiet=True)[0])"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            code, run_dir = runs.run_scenario(runs.scenario_path("short_trip"), realtime=True,
                                              runs_dir=Path(tmp), domain_id=domain_id,
                                              quiet=True)
            if code != 0:
                raise RuntimeError(f"realtime short trip failed: {run_dir}")
            summary = json.loads((run_dir / "summary.json").read_text())
        finally:
            if busy is not None:
                busy.wait()
    return {"shared": busy_domain_id is not None,
            **{key: summary[key] for key in report.REALTIME_MARGINS}}


DRILLING_SCENARIOS = ("drilling_12in_op1", "drilling_12in_op2", "drilling_36in")


def drilling_speed(scenario: str, domain_id: int) -> dict:
    """A drilling scenario (Paper IV) against real time: the string model alone (its
    simulated seconds per CPU second) and the whole run through the graph (simulated
    seconds per wall second, from process start to the recording closed)."""
    from drill_string.scenario import load_drilling_scenario
    from drill_string.simulate import simulate
    path = runs.scenario_path(scenario)
    scenario_obj, _ = load_drilling_scenario(path, runs.ROOT / "config")
    cpu = time.process_time()
    simulate(scenario_obj.drilling_config(), scenario_obj.duration_s)
    cpu = time.process_time() - cpu
    with tempfile.TemporaryDirectory() as tmp:
        code, run_dir = runs.run_scenario(path, runs_dir=Path(tmp), domain_id=domain_id,
                                          quiet=True)
        launch = json.loads((run_dir / "launch.json").read_text())
        if code != 0:
            raise RuntimeError(f"{scenario} failed: {launch}")
    return {"scenario": scenario, "simulated_s": scenario_obj.duration_s,
            "model_cpu_s": cpu, "graph_wall_s": launch["wall_time_s"]}


def write_doc(results: dict, path: Path) -> None:
    lines = [
        "# Benchmarks",
        "",
        f"Measured by `scripts/bench` on {datetime.now():%Y-%m-%d %H:%M} "
        f"({platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}). One bench run; all ratios below come from it.",
        "",
    ]
    if "plant" in results:
        lines += [
            "## Plant",
            "",
            "| quantity | value |",
            "| --- | --- |",
            f"| one 0.1 s plant frame (10 steps x 2 SRK substeps, compiled CasADi) | "
            f"{results['plant']['plant_frame_median_s'] * 1e3:.3f} ms |",
            f"| one 0.01 s plant step | {results['plant']['plant_step_median_s'] * 1e6:.1f} us |",
            f"| plant core alone, real-time factor | {results['plant']['plant_core_rtf']:.4f} |",
            *(f"| plant + 4 actuators, 600 s Case 2 (fast mode), layout {r['layout']}, "
              f"{r['executor']} executor, median of {len(r['walls_s'])} (range) | "
              f"{_walls(r)} wall, RTF {r['rtf']:.3f} (target: <= 6 s) |"
              for r in results["plant_actuators"]),
            "",
        ]
    for key, title in (("estimator", "Estimator"), ("nmpc", "NMPC")):
        if key in results:
            lines += [f"## {title}", "", "| quantity | value |", "| --- | --- |"]
            lines += [f"| {k} | {v:.6g} |" if isinstance(v, float) else f"| {k} | {v} |"
                      for k, v in results[key].items()]
            lines.append("")
    if "nmpc_profile" in results:
        lines += solve_profile_markdown(results["nmpc_profile"])
    if "peers" in results:
        lines += peers_markdown(results["peers"], results.get("nmpc_profile"))
    if "graph" in results:
        first = results["graph"][0]
        lines += ["## Whole graph by process layout", "",
                  "Case 2 (600 s) through the graph over DDS in fast mode, from process start to "
                  "the recording closed (target: <= 30 s wall, RTF <= 0.05), in each process "
                  "layout (`scripts/rig run --layout`; drill_ros.graph.LAYOUTS), median "
                  f"of {len(first['walls_s'])} runs with their range; the time budget is the "
                  "median run's:", "",
                  "| layout | executor | wall | real-time factor | vs the first row | report afterwards |",
                  "| --- | --- | --- | --- | --- | --- |"]
        lines += [f"| {g['layout']}{' (default, no --layout)' if g.get('default') else ''} | "
                  f"{g['executor']} | {_walls(g)} | {g['rtf']:.3f} | "
                  f"{g['wall_s'] / first['wall_s']:.2f} | {g['report_s']:.1f} s |"
                  for g in results["graph"]]
        lines.append("")
        default = [g for g in results["graph"] if g.get("default")]
        layouts = [g for g in results["graph"] if not g.get("default")]
        if default and layouts:
            fastest = min(layouts, key=lambda g: g["wall_s"])
            ratio = default[0]["wall_s"] / fastest["wall_s"]
            lines += [f"The command users run (`rig run case2`, no `--layout`: "
                      f"{default[0]['layout']}) took {ratio:.2f} times the fastest layout's "
                      f"wall ({fastest['layout']}, {fastest['executor']}) in this run (goal: <= "
                      f"{DEFAULT_WALL_GOAL}{'' if ratio <= DEFAULT_WALL_GOAL else ': missed'}).", ""]
        if results.get("floor"):
            lines += floor_markdown(results["floor"])
        for g in results["graph"]:
            lines += [f"### Time budget, layout {g['layout']}{' (default)' if g.get('default') else ''}, "
                      f"{g['executor']} executor", "",
                      budget.markdown(g["budget"]), ""]
        lines += [budget.__doc__.split("\n\n")[1].replace("\n", " "), ""]
    if "multi_stand" in results:
        lines += ["## Multi-stand trips", "",
                  "Ten 28 m stands through their connections (`trip_out`, `trip_in`; "
                  "docs/results.md, *Multi-stand trips*) through the graph in fast mode in the "
                  "default layout, one run each, from process start to the recording closed "
                  f"(goal: under {MULTI_STAND_WALL_GOAL_S:.0f} s of wall):", "",
                  "| scenario | controller | simulated | wall | real-time factor | goal |",
                  "| --- | --- | --- | --- | --- | --- |"]
        lines += [f"| {m['scenario']} | {m['controller']} | {m['simulated_s']:.0f} s | "
                  f"{m['wall_s']:.1f} s | {m['rtf']:.3f} | "
                  f"{'met' if m['wall_s'] < MULTI_STAND_WALL_GOAL_S else 'missed'} |"
                  for m in results["multi_stand"]]
        lines.append("")
    if "drilling" in results:
        lines += drilling_markdown(results["drilling"])
    if "scaling" in results:
        lines += scaling_bench.markdown(results["scaling"])
    if "sweeps" in results:
        lines += sweep_bench.markdown(**results["sweeps"])
    if "realtime" in results:
        lines += ["## Realtime margins", "",
                  "The short trip in realtime mode: how late the plant's 0.1 s frames started "
                  "against their timer's schedule (target: < 50 ms), and the periods the timer "
                  "skipped (a stall longer than a period: the physics then lags the wall clock "
                  "by as many frames), alone and while a fast-mode Case 2 run shares the "
                  "machine:", "",
                  "| machine | p99 | max | frames skipped |", "| --- | --- | --- | --- |"]
        lines += [f"| {'shared with a fast-mode run' if r['shared'] else 'alone'} | "
                  f"{r['frame_late_p99_s'] * 1e3:.1f} ms | {r['frame_late_max_s'] * 1e3:.1f} ms | "
                  f"{r['frames_skipped']:.0f} |" for r in results["realtime"]]
        lines.append("")
    path.write_text("\n".join(lines))


def drilling_markdown(drilling: list[dict]) -> list[str]:
    """The drilling section: each scenario against real time, alone and through the graph,
    with the goal and, where it is missed, the graph's fixed cost that bounds it (the
    intercept of its wall against the simulated time over the scenarios)."""
    lines = ["## Drilling mode (Paper IV)", "",
             "Each drilling scenario's simulated time against the string model alone (CPU "
             "time of `drill_string.simulate`) and against the whole run through the graph "
             "(wall time from process start to the recording closed, start-up included; "
             "the paper notes that solving for the bit's delay can take seconds per step):",
             "", "| scenario | simulated | model alone | x real time | graph run | "
             "x real time | real-time factor | goal |", "| --- " * 8 + "|"]
    lines += [f"| {d['scenario']} | {d['simulated_s']:.2f} s | {d['model_cpu_s']:.3f} s | "
              f"{d['simulated_s'] / d['model_cpu_s']:.0f} | {d['graph_wall_s']:.1f} s | "
              f"{d['simulated_s'] / d['graph_wall_s']:.2f} | "
              f"{d['graph_wall_s'] / d['simulated_s']:.2f} | "
              f"{'met' if d['graph_wall_s'] / d['simulated_s'] <= DRILLING_RTF_GOAL else 'missed'} |"
              for d in drilling]
    missed = [d for d in drilling if d["graph_wall_s"] / d["simulated_s"] > DRILLING_RTF_GOAL]
    if missed:
        shortest = min(drilling, key=lambda d: d["graph_wall_s"])
        lines += ["", f"Goal: real-time factor <= {DRILLING_RTF_GOAL:g} (graph wall over simulated "
                  f"time). What bounds "
                  + ", ".join(f"{d['scenario']} ({d['simulated_s']:.1f} s simulated: "
                              f"{d['simulated_s'] * DRILLING_RTF_GOAL:.1f} s of wall allowed, "
                              f"its string model {d['model_cpu_s']:.2f} s of CPU)" for d in missed)
                  + f": a run through the graph costs at least {shortest['graph_wall_s']:.1f} s "
                    f"whatever its simulated time (the shortest run here, {shortest['scenario']}, "
                    f"{shortest['simulated_s']:.1f} s simulated): processes, imports, DDS "
                    "discovery and the recording, not the string model."]
    return lines + [""]


def arithmetic_floor(results: dict, sensor_period_s: float, sample_time_s: float) -> dict | None:
    """The arithmetic of the default layout's Case 2 run from this bench's own per-frame
    figures (a plant frame and a UKF frame per sensor period, an NMPC solve per sample)
    against the CPU its processes used; None without those sections."""
    default = next((g for g in results.get("graph", []) if g.get("default")), None)
    if default is None or not all(key in results for key in ("plant", "estimator", "nmpc")):
        return None
    frames = round(default["simulated_s"] / sensor_period_s)
    solves = round(default["simulated_s"] / sample_time_s)
    parts = {"plant frames": (frames, results["plant"]["plant_frame_median_s"]),
             "UKF frames": (frames, results["estimator"]["ukf_n4_frame_ms"] * 1e-3),
             f"{FLOOR_NMPC.upper()} solves": (solves, results["nmpc"][f"{FLOOR_NMPC}_median_s"])}
    floor_s = sum(count * seconds for count, seconds in parts.values())
    spent = budget.totals(default["budget"])
    return {"parts": parts, "floor_s": floor_s, **spent, "ratio": spent["cpu_s"] / floor_s,
            "layout": default["layout"]}


def floor_markdown(floor: dict) -> list[str]:
    """The line of the whole-graph section on the arithmetic floor."""
    terms = " + ".join(f"{count} {name} x {seconds * 1e3:.3g} ms"
                       for name, (count, seconds) in floor["parts"].items())
    met = floor["ratio"] <= FLOOR_GOAL
    return [f"The arithmetic of a Case 2 run, from this run's per-frame figures above: {terms} "
            f"= {floor['floor_s']:.1f} s of CPU; the default layout's ({floor['layout']}) "
            f"processes used {floor['cpu_s']:.1f} s, {floor['ratio']:.2f} times that floor "
            f"(goal: <= {FLOOR_GOAL:g}{'' if met else ': missed'}; the rest is executors, DDS, "
            "serialisation and Python glue: the time budget below)."
            + ("" if met else
               f" What bounds it: the goal allows {FLOOR_GOAL * floor['floor_s']:.1f} s; over the "
               f"floor's {floor['floor_s']:.1f} s the processes spent {floor['executor_s']:.1f} s "
               f"in their executors and DDS, {floor['publish_s']:.1f} s publishing and "
               f"{floor['compute_s'] - floor['floor_s']:.1f} s of callback compute beyond the "
               "arithmetic (message conversion, the nodes' ticks, the recorder's writing)."), ""]


def solve_profile_markdown(profile: dict) -> list[str]:
    """The NMPC section's profile: where a solve's time goes (drill_nmpc.bench.solve_profile)."""
    share = profile["qp_and_compiled_share"]
    rows = [(part, RTI_PARTS[part]) for part in RTI_PARTS] + [
        ("other", "the supervisor's Python around the solve: parameters, bounds, warm start, "
                  "the step's checks, the result")]
    return ["### Where a solve's time goes", "",
            f"{profile['configuration']} on the loop above, {profile['solves']} solves (one "
            f"real-time-iteration step each), each part's wall time summed over them; median "
            f"solve {profile['median_solve_s'] * 1e3:.1f} ms.", "",
            "| part | what | per solve | share |", "| --- | --- | --- | --- |",
            *(f"| {part} | {what} | {profile[f'{part}_s_per_solve'] * 1e3:.2f} ms | "
              f"{profile[f'{part}_share']:.0%} |" for part, what in rows), "",
            f"The QP and the compiled evaluations take {share:.0%} of the solves' time (goal: "
            f">= {PROFILE_SHARE_GOAL:.0%}{'' if share >= PROFILE_SHARE_GOAL else ': missed'}).",
            ""]


PEERS = (("do_mpc", "do-mpc (orthogonal collocation, IPOPT to convergence)"),
         ("gekko", "GEKKO (APMonitor IMODE 6, implicit Euler, IPOPT)"))


def peers_markdown(peers: dict, profile: dict | None = None) -> list[str]:
    """The NMPC against its peers on the same problem (drill_nmpc.peers.compare); with the
    solve's ``profile`` (drill_nmpc.bench.solve_profile), what bounds a missed speed-up."""
    present = [(n, what) for n, what in PEERS if f"{n}_median_s" in peers]
    names = [("project", "this project (CasADi, one real-time iteration, HPIPM)"), *present]
    faster = min(present, key=lambda p: peers[f"{p[0]}_median_s"])
    ratio = peers[f"{faster[0]}_median_s"] / peers["project_median_s"]
    met = ratio >= PEER_SPEEDUP_GOAL
    lines = ["### Against its peers", "",
             f"Case 2's NMPC1 (the same prediction model, horizon, weights and constraints: "
             f"`drill_nmpc.peers`; what each peer could not express: its module's docstring) on "
             f"the loop above, {peers['samples']} samples, one run each in this process:", "",
             "| solver | solve median | p99 | max | BHP RMSE | worst BHP error | fallbacks | build |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |",
             *(f"| {what} | {peers[f'{n}_median_s'] * 1e3:.1f} ms | {peers[f'{n}_p99_s'] * 1e3:.1f} ms "
               f"| {peers[f'{n}_max_s'] * 1e3:.1f} ms | {peers[f'{n}_bhp_rmse_pa'] / 1e5:.3f} bar | "
               f"{peers[f'{n}_bhp_max_error_pa'] / 1e5:.2f} bar | {peers[f'{n}_fallbacks']} | "
               f"{peers[f'{n}_build_s']:.1f} s |" for n, what in names), "",
             f"The project's median solve is {ratio:.1f} times faster than the faster peer's "
             f"({faster[1].split(' (')[0]}; goal: >= {PEER_SPEEDUP_GOAL:.0f}{'' if met else ': missed'})."]
    missing = [what.split(" (")[0] for n, what in PEERS if f"{n}_median_s" not in peers]
    if missing:
        lines.append(f"Not in the comparison: {', '.join(missing)} (not built).")
    if not met and profile is not None:
        needed_s = peers[f"{faster[0]}_median_s"] / PEER_SPEEDUP_GOAL
        compiled_s = sum(profile[f"{part}_s_per_solve"] for part in RTI_PARTS)
        lines.append(f"What bounds it: the goal needs a median solve of {needed_s * 1e3:.1f} ms; "
                     f"the QP and the compiled evaluations alone take {compiled_s * 1e3:.1f} ms "
                     f"of a solve (the profile above), the Python around them "
                     f"{profile['other_s_per_solve'] * 1e3:.1f} ms.")
    return lines + [""]


def _sweeps(default: dict) -> dict:
    """The sweep section's results against ``default``, Case 2's run alone in the default
    layout (graph_rtf's median)."""
    case, controller, single = "case2", default["controller"], default["wall_s"]
    cpu = budget.totals(default["budget"])["cpu_s"]
    results = sweep_bench.sweep_efficiency(case, controller, single, cpu)
    for r in results:
        print(f"[bench] sweep on the {r['pool']}: {r['wall_s']:.0f} s for {r['runs']} runs, "
              f"efficiency {r['efficiency']:.2f}", flush=True)
    return {"results": results, "case": case, "controller": controller, "single_wall_s": single,
            "single_cpu_s": cpu}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="bench", description=__doc__)
    parser.add_argument("--output", type=Path,
                        help="the page written (default: docs/benchmarks.md)")
    parser.add_argument("--skip-graph", action="store_true",
                        help="skip every run through the graph (the in-process figures only)")
    parser.add_argument("--sweeps-only", action="store_true",
                        help="only Case 2 alone in the default layout and the sweeps, to "
                             "--output (which must then be given)")
    args = parser.parse_args(argv)
    domain = launcher.default_domain_id()
    if args.sweeps_only:
        if args.output is None:
            parser.error("--sweeps-only writes a partial page: give --output")
        default = median_run(lambda: graph_rtf("case2", domain, None, DEFAULT_EXECUTOR))
        write_doc({"graph": [default], "sweeps": _sweeps(default)}, args.output)
        print(f"[bench] wrote {args.output}")
        return 0
    _, case2 = load_scenario_config(runs.scenario_path("case2"), runs.ROOT / "config")
    results = {"plant": plant_frame_cost(case2)}
    print(f"[bench] plant frame {results['plant']['plant_frame_median_s'] * 1e3:.3f} ms", flush=True)
    results["plant_actuators"] = [
        median_run(lambda: plant_actuators_rtf(domain, layout, executor))
        for layout, executor in (("separate", "single_threaded"), ("separate", DEFAULT_EXECUTOR),
                                 ("plant", DEFAULT_EXECUTOR))]
    for r in results["plant_actuators"]:
        print(f"[bench] plant + actuators ({r['layout']}, {r['executor']}): {_walls(r)}",
              flush=True)
    from drill_estimator import bench as estimator_bench
    results["estimator"] = estimator_bench.run_benchmark()
    print("[bench] estimator done", flush=True)
    from drill_nmpc import bench as nmpc_bench
    results["nmpc"] = nmpc_bench.run_benchmark()
    results["nmpc_profile"] = nmpc_bench.solve_profile()
    from drill_nmpc import peers
    results["peers"] = peers.compare()
    print("[bench] nmpc done", flush=True)
    if args.skip_graph:
        results["scaling"] = scaling_bench.run(domain, skip_graph=True)
    else:
        results["graph"] = []
        for layout, executor in GRAPH_CONFIGURATIONS:
            results["graph"].append(
                median_run(lambda: graph_rtf("case2", domain, layout, executor)))
            print(f"[bench] case2 graph ({layout}, {executor}): {_walls(results['graph'][-1])}",
                  flush=True)
        config = load_rig(runs.ROOT / "config")
        results["floor"] = arithmetic_floor(results, config.plant.sensor_period_s,
                                            config.nmpc.sample_time_s)
        results["sweeps"] = _sweeps(next(g for g in results["graph"] if g["default"]))
        results["multi_stand"] = [graph_rtf(name, domain, None, DEFAULT_EXECUTOR, controller)
                                  for name, controller in MULTI_STAND_RUNS]
        for m in results["multi_stand"]:
            print(f"[bench] {m['scenario']} ({m['controller']}): {m['wall_s']:.1f} s wall",
                  flush=True)
        results["drilling"] = [drilling_speed(name, domain) for name in DRILLING_SCENARIOS]
        for d in results["drilling"]:
            print(f"[bench] {d['scenario']}: model {d['model_cpu_s']:.2f} s CPU, graph "
                  f"{d['graph_wall_s']:.1f} s for {d['simulated_s']:.1f} s", flush=True)
        results["scaling"] = scaling_bench.run(domain)
        busy_domain = launcher.default_domain_id()
        results["realtime"] = [realtime_margins(domain), realtime_margins(domain, busy_domain)]
        for r in results["realtime"]:
            print(f"[bench] realtime frame lateness (shared {r['shared']}): p99 "
                  f"{r['frame_late_p99_s'] * 1e3:.1f} ms, max {r['frame_late_max_s'] * 1e3:.1f} ms, "
                  f"{r['frames_skipped']:.0f} frames skipped",
                  flush=True)
    output = args.output or runs.ROOT / "docs" / "benchmarks.md"
    write_doc(results, output)
    print(f"[bench] wrote {output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
