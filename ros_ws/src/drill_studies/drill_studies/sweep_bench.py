"""How near a sweep comes to the machine's ideal (scripts/bench, issue 32 item 7): the
same seeds of one scenario through ``rig sweep``'s runner (drill_studies.batch) on the
local process pool and on a Dask ``LocalCluster``, each with one worker per core.

The ideal is one run's wall alone (measured in the same bench run) times the runs, over
the cores. Efficiency is that ideal over the sweep's wall. It assumes a run keeps one
core busy; a graph alone keeps more than one busy for part of its run (its processes
overlap), so the runs' CPU alone over the cores is a wall no runner can beat, and the
ideal over it the efficiency's ceiling. The scheduler's overhead per run is the cores'
time the workers were not inside a run: (sweep wall x workers - the runs' time in their
workers) / runs. A run's time in its worker splits into the graph (the launcher's wall)
and the rest (the report and plots, the run directory)."""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from drill_bringup import runs
from drill_studies import batch, sweep

SEEDS = 8
FIRST_SEED = 1
EFFICIENCY_GOAL = 0.85


def timed_run(spec: batch.RunSpec) -> dict:
    """``batch.run_one`` with the time the run held its worker (s)."""
    started = time.monotonic()
    row = batch.run_one(spec)
    row["worker_s"] = time.monotonic() - started
    return row


def _sweep(case: str, controller: str, workers: int, cluster: str | None,
           output: Path) -> tuple[float, list[dict]]:
    specs = sweep.plan(case, runs.scenario_path(case), [controller], SEEDS, FIRST_SEED, output)
    started = time.monotonic()
    rows = batch.execute(specs, run=timed_run, workers=workers, cluster=cluster)
    return time.monotonic() - started, rows


def figures(pool: str, wall_s: float, rows: list[dict], workers: int,
            single_wall_s: float, single_cpu_s: float) -> dict:
    """One sweep's figures against the ideal of ``single_wall_s`` per run and the bound
    of ``single_cpu_s`` per run (one run's wall and CPU alone)."""
    n = len(rows)
    ideal_s = single_wall_s * n / workers
    cpu_bound_s = single_cpu_s * n / workers
    graph_s = sum(r["wall_s"] or 0.0 for r in rows)
    worker_s = sum(r["worker_s"] for r in rows)
    return {"pool": pool, "workers": workers, "runs": n,
            "failed": sum(not r["ok"] for r in rows), "wall_s": wall_s,
            "runs_per_hour": n / wall_s * 3600.0, "ideal_wall_s": ideal_s,
            "efficiency": ideal_s / wall_s, "cpu_bound_wall_s": cpu_bound_s,
            "efficiency_ceiling": ideal_s / cpu_bound_s, "run_graph_median_s": sorted(
                r["wall_s"] or 0.0 for r in rows)[n // 2],
            "outside_graph_per_run_s": (worker_s - graph_s) / n,
            "scheduler_overhead_per_run_s": (wall_s * workers - worker_s) / n}


def sweep_efficiency(case: str, controller: str, single_wall_s: float, single_cpu_s: float,
                     workers: int | None = None) -> list[dict]:
    """The local pool's and a Dask LocalCluster's sweep of ``SEEDS`` seeds of ``case``."""
    from distributed import LocalCluster
    workers = workers or len(os.sched_getaffinity(0))
    out = []
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        wall_s, rows = _sweep(case, controller, workers, None, Path(tmp) / "pool")
        out.append(figures("local process pool", wall_s, rows, workers, single_wall_s,
                           single_cpu_s))
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster:
            wall_s, rows = _sweep(case, controller, 1, cluster.scheduler_address,
                                  Path(tmp) / "dask")
        out.append(figures("Dask LocalCluster", wall_s, rows, workers, single_wall_s,
                           single_cpu_s))
    return out


def markdown(results: list[dict], case: str, controller: str, single_wall_s: float,
             single_cpu_s: float) -> list[str]:
    """benchmarks.md's section."""
    lines = ["## Sweeps", "",
             f"`rig sweep {case} --seeds {SEEDS}` ({controller}), one worker per core, against "
             f"the ideal of one run's wall alone ({single_wall_s:.1f} s, the default layout's "
             "median above) times the runs over the cores (goal: efficiency >= "
             f"{EFFICIENCY_GOAL}). A run alone keeps more than a core busy ({single_cpu_s:.1f} s "
             "of CPU over its processes' spin): the runs' CPU over the cores is a wall no "
             "runner beats, and the ideal over it the efficiency's ceiling. Scheduler "
             "overhead: the cores' time outside any run, per run.",
             "", "| runner | runs/h | wall (ideal; CPU bound) | efficiency (ceiling) | a run's "
             "graph, median | per run outside the graph (report) | scheduler overhead per "
             "run | failed |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        met = "met" if r["efficiency"] >= EFFICIENCY_GOAL else "missed"
        lines.append(f"| {r['pool']}, {r['workers']} workers | {r['runs_per_hour']:.0f} | "
                     f"{r['wall_s']:.0f} s ({r['ideal_wall_s']:.0f} s; "
                     f"{r['cpu_bound_wall_s']:.0f} s) | {r['efficiency']:.2f} ({met}; "
                     f"{r['efficiency_ceiling']:.2f}) | {r['run_graph_median_s']:.1f} s | "
                     f"{r['outside_graph_per_run_s']:.1f} s | "
                     f"{r['scheduler_overhead_per_run_s']:.1f} s | {r['failed']} |")
    return lines + [""]
