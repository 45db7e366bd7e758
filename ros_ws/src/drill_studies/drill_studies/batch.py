"""Many graph runs at once: ``rig sweep``'s and ``rig compare``'s one way of running them,
one after another in this process, on a local process pool, or on a Dask distributed
cluster (docs/exports-and-sweeps.md says why Dask).

Each run is a whole graph (drill_bringup.runs.run_scenario) on a ROS domain of its own:
every worker thread holds one free domain (launcher.default_domain_id, an flock kept while
its process lives) and runs all its graphs on it, one at a time, so concurrent graphs
never see each other and a worker does not take a new domain for every run. A run that
fails comes back as a row with ``ok`` false and the launcher's message; the others go on.
Progress (runs done, the time left) goes to stderr: a bar on a terminal, a line per run
in a log.
"""
from __future__ import annotations

import dataclasses
import json
import multiprocessing
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from drill_bringup import launcher, runs

_worker = threading.local()


class Progress:
    """Runs done of a batch, with the rate and the time left: a tqdm bar on a terminal
    (stderr), a plain line after each run otherwise (a CI log)."""

    def __init__(self, total: int, stream=None, clock=time.monotonic):
        self.stream = stream or sys.stderr
        self.total, self.done, self.clock, self.started_s = total, 0, clock, clock()
        self.bar = tqdm(total=total, unit="run", file=self.stream, dynamic_ncols=True) \
            if self.stream.isatty() else None

    def step(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.update()
            return
        elapsed_s = self.clock() - self.started_s
        left_s = elapsed_s / self.done * (self.total - self.done)
        self.stream.write(f"[batch] {self.done} / {self.total} runs, {elapsed_s:.0f} s, "
                          f"about {left_s:.0f} s left\n")
        self.stream.flush()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@dataclass(frozen=True)
class RunSpec:
    """One graph run: ``case`` labels it (the scenario's name as asked for), ``scenario`` is
    the file run, ``runs_dir`` where its run directory is made (None: runs/)."""

    case: str
    scenario: str
    controller: str
    seed: int
    runs_dir: str | None = None
    alone: bool = True          # no other graph runs at once (launcher.cpu_sets may pin)
    mismatch: str | None = None  # the plant's mismatch (drill_core.mismatch), None: the model

    @property
    def label(self) -> str:
        plant = f" / {self.mismatch}" if self.mismatch else ""
        return f"{self.case}{plant} / {self.controller} / seed {self.seed}"


def worker_domain() -> int:
    """The ROS domain of this worker thread, taken on its first run and kept."""
    if not hasattr(_worker, "domain"):
        _worker.domain = launcher.default_domain_id()
    return _worker.domain


def result_row(spec: RunSpec, run_dir: Path | None, message: str = "") -> dict:
    """The row of a finished run: its spec, outcome, directory, wall time and summary."""
    launch = {}
    if run_dir is not None and (run_dir / "launch.json").exists():
        launch = json.loads((run_dir / "launch.json").read_text())
    summary_path = None if run_dir is None else run_dir / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path and summary_path.exists() \
        else None
    return {"case": spec.case, "controller": spec.controller, "seed": spec.seed,
            "mismatch": spec.mismatch,
            "ok": summary is not None and launch.get("ok", False),
            "message": message or launch.get("message", "no run directory"),
            "run_dir": None if run_dir is None else str(run_dir),
            "wall_s": launch.get("wall_time_s"), "summary": summary}


def run_one(spec: RunSpec) -> dict:
    """Run one graph on this worker's domain; its row (never raises for a failed run)."""
    if not (runs.ROOT / "config").is_dir():
        return result_row(spec, None, f"{runs.ROOT} holds no rig checkout (config/): start "
                                      "the worker in the checkout or set RIG_ROOT")
    try:
        _, run_dir = runs.run_scenario(
            Path(spec.scenario), runs_dir=Path(spec.runs_dir) if spec.runs_dir else None,
            seed=spec.seed, domain_id=worker_domain(), quiet=True, controller=spec.controller,
            pin_cpus=spec.alone, mismatch=spec.mismatch)
    except Exception as err:           # noqa: BLE001 - a run's failure is its row's message
        return result_row(spec, None, f"{type(err).__name__}: {err}")
    return result_row(spec, run_dir)


def execute(specs: Sequence[RunSpec], run: Callable[[RunSpec], dict] = run_one,
            workers: int = 1, cluster: str | None = None,
            on_done: Callable[[dict], None] | None = None) -> list[dict]:
    """Run every spec; the rows in the specs' order. ``workers`` 1 runs them one after
    another in this process, more a local process pool of that size; ``cluster`` (a Dask
    scheduler address, tcp://host:port) submits them to that cluster instead.
    ``on_done`` sees each row as its run finishes."""
    if workers < 1:
        raise ValueError(f"--workers: value {workers} must be at least 1")
    progress = Progress(len(specs))

    def done(row: dict) -> None:
        if on_done is not None:
            on_done(row)
        progress.step()
    rows: list[dict | None] = [None] * len(specs)
    if cluster or (workers > 1 and len(specs) > 1):
        specs = [dataclasses.replace(spec, alone=False) for spec in specs]
    try:
        if cluster:
            from distributed import Client
            from distributed import as_completed as dask_completed
            with Client(cluster) as client:
                futures = {client.submit(run, spec, pure=False): i for i, spec in enumerate(specs)}
                for future in dask_completed(futures):
                    rows[futures[future]] = future.result()
                    done(rows[futures[future]])
        elif workers > 1 and len(specs) > 1:
            context = multiprocessing.get_context("spawn")     # no fork of a process with threads
            with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
                futures = {pool.submit(run, spec): i for i, spec in enumerate(specs)}
                for future in as_completed(futures):
                    rows[futures[future]] = future.result()
                    done(rows[futures[future]])
        else:
            for i, spec in enumerate(specs):
                rows[i] = run(spec)
                done(rows[i])
    finally:
        progress.close()
    return rows
