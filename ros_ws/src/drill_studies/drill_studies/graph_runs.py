"""A scenario through the whole graph in fast mode, timed for the benches: its wall time
from starting the processes to the recorder closing its file, and where the processes'
time went (drill_ros.budget)."""
from __future__ import annotations

import contextlib
import json
import os
import tempfile
import time
from pathlib import Path

from drill_bringup import runs
from drill_core.scenario import load_scenario_config
from drill_ros import budget
from drill_ros.executors import DEFAULT_EXECUTOR, EXECUTOR_ENV


@contextlib.contextmanager
def with_executor(kind: str):
    """The graph's processes spin with executor ``kind`` (drill_ros.executors)."""
    previous = os.environ.get(EXECUTOR_ENV)
    os.environ[EXECUTOR_ENV] = kind
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop(EXECUTOR_ENV)
        else:
            os.environ[EXECUTOR_ENV] = previous


def graph_rtf(scenario: str, domain_id: int, layout: str | None = "separate",
              executor: str = DEFAULT_EXECUTOR, controller: str | None = None,
              config_source: Path | None = None) -> dict:
    """Wall time of a whole scenario through the graph in fast mode in a process layout
    (None: the default one, as ``rig run`` without ``--layout``) with an executor, under
    its own controller or ``controller``: from starting the processes to the recorder
    closing its file (the report afterwards is timed apart), and where the processes' time
    went (drill_ros.budget); ``config_source``: the rig configuration's directory (the
    checkout's config/ unless given)."""
    path = runs.scenario_path(scenario)
    with with_executor(executor), tempfile.TemporaryDirectory() as tmp:
        scenario_obj, _ = load_scenario_config(path, runs.ROOT / "config")
        start = time.monotonic()
        code, run_dir = runs.run_scenario(path, runs_dir=Path(tmp), domain_id=domain_id,
                                          quiet=True, layout=layout, controller=controller,
                                          config_source=config_source)
        total = time.monotonic() - start
        launch = json.loads((run_dir / "launch.json").read_text())
        if code != 0:
            raise RuntimeError(f"{scenario} ({layout}, {executor}) failed: {launch}")
        rows = budget.summarise(run_dir / "budget")
    wall = launch["wall_time_s"]
    return {"scenario": scenario, "layout": launch["layout"], "default": layout is None,
            "executor": executor, "controller": launch["controller"],
            "simulated_s": scenario_obj.duration_s, "wall_s": wall,
            "rtf": wall / scenario_obj.duration_s, "report_s": total - wall, "budget": rows}
