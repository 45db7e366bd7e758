"""``simulate`` and ``load_run``: the rig's closed loop and its recordings as DataFrames.

``simulate`` steps the nodes' own tick classes in this process (drill_studies.loop_bench:
the truth plant, the actuators, the UKF, the scenario's controller and the process
protection, in the graph's lockstep order, without DDS), so a notebook gets the run the
graph would record, sample by sample, in a fraction of its time. ``load_run`` reads a run
directory's recording (``rig run``) one topic at a time. Errors are ``RunError`` (a
ValueError) with the reason; nothing here exits the interpreter.
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from drill_bag import export
from drill_studies import loop_bench
from drill_bringup.runs import scenario_path
from drill_core.config import ConfigError, parse_settings
from drill_core.mismatch import resolve
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario

TIME_INDEX = "time_s"


class RunError(ValueError):
    """A scenario, controller, mismatch or run the API cannot use; the message says why."""


def scenarios() -> list[str]:
    """The scenarios in config/scenarios, by name."""
    return sorted(p.stem for p in (config_dir() / "scenarios").glob("*.yaml"))


def simulate(scenario: str = "case2", controller: str | None = None, seed: int | None = None,
             mismatch: str | None = None, settings: list[str] | tuple[str, ...] = ()
             ) -> pd.DataFrame:
    """A scenario's closed loop in process: one row per sensor sample (10 Hz), indexed by
    simulated time ``time_s``, columns as drill_studies.loop_bench.TRACE lists them (the
    truth, the estimate, the setpoints, the machine command and the actuators' outputs,
    SI). ``controller``: nmpc, automated_mpd or baseline (default: the scenario's own);
    ``seed``: the noise seed (default: the scenario's); ``mismatch``: the plant differs
    from the model by this member of config/mismatch.yaml (or ``draw:N``); ``settings``:
    config overrides ``FILE.KEY=VALUE``. The run's figures (SI) are in
    ``frame.attrs["summary"]``."""
    try:
        path = scenario_path(scenario)
        spec, _ = load_scenario(path)
        chosen = controller or spec.controller
        if chosen not in loop_bench.CONTROLLERS:
            raise RunError(f"controller {chosen!r}: the in-process loop runs "
                           f"{', '.join(loop_bench.CONTROLLERS)}")
        plant = None if mismatch is None else resolve(mismatch, config_dir(), "mismatch")[1]
        result = loop_bench.run(str(path), chosen, "ukf", seed, parse_settings(settings),
                                protection=True, mismatch=plant)
    except ConfigError as err:
        raise RunError(str(err)) from err
    trace = result.pop("trace")
    frame = pd.DataFrame(trace).set_index(TIME_INDEX)
    frame.attrs["summary"] = {k: v for k, v in result.items() if isinstance(v, (int, float))}
    frame.attrs["scenario"], frame.attrs["controller"] = spec.name, chosen
    return frame


def load_run(run: str | Path, topic: str = "/rig/measurement") -> pd.DataFrame:
    """One topic of a recorded run (a run directory of ``rig run``), one row per message,
    indexed by its stamp (``time_utc``, UTC; simulated time from 1970-01-01 in fast mode),
    columns named with their SI units as ``rig export`` names them; the run's summary
    (summary.json) in ``frame.attrs["summary"]`` when it has one."""
    run_dir = Path(run)
    try:
        tables = export.topic_tables(export.run_mcap(run_dir), [topic])
    except export.ExportError as err:
        raise RunError(str(err)) from err
    if topic not in tables:
        raise RunError(f"{run_dir}: no message on {topic}")
    table = tables[topic]
    frame = table.drop(["time_utc"]).to_pandas()
    frame.index = pd.to_datetime(frame.pop("stamp_ns"), unit="ns", utc=True)
    frame.index.name = "time_utc"
    summary = run_dir / "summary.json"
    if summary.exists():
        frame.attrs["summary"] = json.loads(summary.read_text())
    return frame
