"""Where a process's wall time goes: per node, the time in its subscription callbacks (wall
and CPU) and, within them, the CPU time spent publishing; per process, wall and CPU time. A process writes its budget
as JSON to $DRILL_BUDGET_DIR/<process>.json when it ends (the launcher sets the directory
to <run>/budget); ``summarise`` turns a run's files into the table ``scripts/bench`` and
the run summary print.

For a process over its spin: idle = wall - CPU (waiting in the middleware for the
lockstep's other processes, or for a core); executor = CPU - callback CPU (rclpy's wait
set, DDS take and deserialisation, timers, the middleware's threads); compute = callback
CPU - publish CPU; preempted = callback wall - callback CPU (a callback ready to run but
off the CPU: the machine's cores were busy with other processes).
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

BUDGET_DIR_ENV = "DRILL_BUDGET_DIR"


@dataclass
class NodeBudget:
    """Time one node spent in its callbacks and in publishing [s]."""
    callbacks: int = 0
    callback_s: float = 0.0          # wall time in callbacks
    callback_cpu_s: float = 0.0      # CPU time of the executor thread in callbacks
    publish_cpu_s: float = 0.0       # of which publishing


class ProcessClock:
    """Wall and CPU time of this process: its start-up (building the nodes) and its spin."""

    def __init__(self):
        self.wall0, self.cpu0 = time.perf_counter(), time.process_time()
        self.startup_s = 0.0

    def spinning(self) -> None:
        """The nodes are built; the spin starts now."""
        now = time.perf_counter()
        self.startup_s = now - self.wall0
        self.wall0, self.cpu0 = now, time.process_time()

    def write(self, process: str, nodes: dict[str, NodeBudget]) -> Path | None:
        """Write the budget file if the launcher asked for one; returns its path."""
        directory = os.environ.get(BUDGET_DIR_ENV)
        if not directory:
            return None
        path = Path(directory) / f"{process}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({
            "process": process, "startup_s": self.startup_s,
            "wall_s": time.perf_counter() - self.wall0,
            "cpu_s": time.process_time() - self.cpu0,
            "nodes": {name: asdict(b) for name, b in nodes.items()}}, indent=1))
        return path


def summarise(budget_dir: Path) -> list[dict]:
    """One row per process of a run: start-up, then over the spin wall, CPU, idle,
    executor, compute, publish, preempted [s]."""
    rows = []
    for path in sorted(Path(budget_dir).glob("*.json")):
        data = json.loads(path.read_text())
        nodes = data["nodes"].values()
        callbacks = sum(n["callback_cpu_s"] for n in nodes)
        publish = sum(n["publish_cpu_s"] for n in nodes)
        preempted = sum(n["callback_s"] for n in nodes) - callbacks
        rows.append({"process": data["process"], "nodes": ", ".join(sorted(data["nodes"])),
                     "startup_s": data["startup_s"], "wall_s": data["wall_s"], "cpu_s": data["cpu_s"],
                     "idle_s": data["wall_s"] - data["cpu_s"],
                     "executor_s": data["cpu_s"] - callbacks,
                     "compute_s": callbacks - publish, "publish_s": publish,
                     "preempted_s": preempted})
    return rows


SUMMED = ("cpu_s", "executor_s", "compute_s", "publish_s", "preempted_s")   # add up over processes


def totals(rows: list[dict]) -> dict[str, float]:
    """The run's total of each figure that adds up over its processes [s]."""
    return {key: sum(r[key] for r in rows) for key in SUMMED}


def markdown(rows: list[dict]) -> str:
    """The budget as a markdown table."""
    head = ("| process | nodes | start-up [s] | spin wall [s] | CPU [s] | idle [s] | "
            "executor, DDS [s] | compute [s] | publish [s] | preempted [s] |\n"
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    keys = ("startup_s", "wall_s", "cpu_s", "idle_s", "executor_s", "compute_s", "publish_s",
            "preempted_s")
    lines = [f"| {r['process']} | {r['nodes']} | " + " | ".join(f"{r[k]:.1f}" for k in keys)
             + " |" for r in rows]
    total = totals(rows)
    lines.append("| all | | | | " + " | ".join(
        f"{total[k]:.1f}" if k in total else "" for k in keys[2:]) + " |")
    return "\n".join([head, *lines])
