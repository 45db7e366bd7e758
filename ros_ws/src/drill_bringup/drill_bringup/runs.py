"""Run one scenario through the whole graph: launch, record, report (the rig's main job,
shared by ``rig run``/``rig demo`` and ``rig compare``)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import yaml

from drill_analysis import report
from drill_bringup import launcher
from drill_bringup.progress_display import ProgressDisplay
from drill_core.config import ConfigError
from drill_core.mismatch import resolve, truth_config, write_truth_file
from drill_core.rig_root import rig_root
from drill_ros import graph as graph_decl, progress
from drill_core.scenario import (MULTI_STAND_CONTROLLERS, load_scenario, load_scenario_config,
                                 scenario_kind, scenario_truth, without_truth)

ROOT = rig_root()


RUN_SOURCES = ("ros_ws/src", "config", "scripts", "requirements.lock")   # what makes a run


def source_commit() -> str | None:
    """The checkout's commit (short hash, ``+changes`` when a tracked file of what makes a
    run, its code, configuration and scripts, differs from it), None outside a git
    checkout: what a run was measured with."""
    def git(*args) -> str:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True,
                              check=True).stdout.strip()
    try:
        commit = git("rev-parse", "--short", "HEAD")
        changed = git("status", "--porcelain", "--untracked-files=no", "--", *RUN_SOURCES)
    except (OSError, subprocess.CalledProcessError):
        return None
    return commit + ("+changes" if changed else "")


RUN_STAMP = "%Y%m%d-%H%M%S"      # a run directory's name: SCENARIO[-TAGS]-STAMP-PID


def run_started(run_dir: str | Path) -> datetime | None:
    """When the run in ``run_dir`` was launched (its name's stamp), None for another name."""
    parts = Path(run_dir).name.rsplit("-", 3)
    try:
        return datetime.strptime(f"{parts[-3]}-{parts[-2]}", RUN_STAMP) if len(parts) == 4 else None
    except ValueError:
        return None


def scenario_path(name: str) -> Path:
    path = Path(name)
    if path.suffix in (".yaml", ".yml") and path.exists():
        return path.resolve()
    candidate = ROOT / "config" / "scenarios" / f"{name}.yaml"
    if not candidate.exists():
        known = ", ".join(sorted(p.stem for p in (ROOT / "config" / "scenarios").glob("*.yaml")))
        raise ConfigError(f"unknown scenario '{name}'; known: {known}")
    return candidate


def reported_url(log_path: Path, key: str, timeout_s: float = 10.0) -> str:
    """A server's address, as its node prints it once it serves (``key`` <url>: the console
    CONSOLE_URL, the gateways FOXGLOVE_URL and OPCUA_URL)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if log_path.exists():
            for line in log_path.read_text(errors="replace").splitlines():
                if key in line:
                    return line.split(key, 1)[1].strip()
        time.sleep(0.2)
    return f"not reported yet (see {log_path})"


def _drilling_scenario(path: Path, realtime: bool, controller: str | None):
    """A drilling scenario (drill_string.scenario), checked with the rig's configuration
    before launch; it runs in fast mode, on its own node set."""
    from drill_string.scenario import load_drilling_scenario
    if realtime:
        raise ConfigError(f"{path.name}: a drilling scenario runs in fast mode only")
    if controller:
        raise ConfigError(f"{path.name}: a drilling scenario has no --controller (its driller "
                         "follows the scenario's schedule)")
    return load_drilling_scenario(path, ROOT / "config")[0]


TRUTH_FILE = "truth.json"       # the plant's mismatch in a run directory (drill_core.mismatch)


def stage_config(run_dir: Path, source: Path = ROOT / "config") -> Path:
    """Copy the rig configuration (``source``/*.yaml: the checkout's config/ unless given)
    into ``run_dir`` and return the copy's directory: the nodes launched here read it and
    the report judges the run with it (report.RUN_CONFIG), so a run keeps what it ran with."""
    target = run_dir / report.RUN_CONFIG
    target.mkdir(parents=True, exist_ok=True)
    for file in sorted(source.glob("*.yaml")):
        (target / file.name).write_bytes(file.read_bytes())
    return target


def run_truth(path: Path, mismatch: str | None):
    """How the run's plant differs from the model: ``mismatch`` (a suite member or draw:N),
    else the scenario's ``truth:`` section, as (name, Mismatch); None: the model's own.
    A mismatch the plant cannot take (a hole list of the wrong length, a flow index past
    1) is refused here, before anything is launched."""
    config_dir = ROOT / "config"
    truth = (resolve(mismatch, config_dir, "--mismatch") if mismatch is not None
             else scenario_truth(path, config_dir))
    if truth is not None:
        truth_config(load_scenario_config(path, config_dir)[1], truth[1])
    return truth


def stage_truth(path: Path, run_dir: Path, truth) -> None:
    """Write ``run_dir/scenario.yaml`` (the scenario less its truth, for every node) and
    ``run_dir/truth.json`` (the plant's mismatch, for the plant's side alone)."""
    (run_dir / "scenario.yaml").write_text(yaml.safe_dump(without_truth(path), sort_keys=False))
    write_truth_file(run_dir / TRUTH_FILE, *truth)


def _simulated_s(run_dir: Path, plant_process: str | None, duration_s: float) -> float:
    """The run's simulated time: the plant's last progress marker's end (a multi-stand
    trip's run ends after the trip, drill_core.tripping.run_end), else ``duration_s``."""
    last = progress.last_marker(run_dir / "logs" / f"{plant_process}.log") \
        if plant_process else None
    return last[1] if last is not None else duration_s


def run_scenario(path: Path, realtime: bool = False, runs_dir: Path | None = None,
                 seed: int | None = None, domain_id: int | None = None,
                 timeout_s: float | None = None, quiet: bool = False,
                 controller: str | None = None, layout: str | None = None,
                 here: str | None = None, peers: tuple[str, ...] = (),
                 extras: dict[str, dict] | None = None,
                 pin_cpus: bool = True, mismatch: str | None = None,
                 node_params: dict[str, dict] | None = None,
                 config_source: Path | None = None) -> tuple[int, Path]:
    """Launch a scenario, record it and report; returns (exit code, run directory).
    ``seed`` replaces the scenario's plant seed and ``controller`` its controller (the same
    trip under another controller: ``rig compare``); ``layout`` groups nodes into processes
    (drill_ros.graph.LAYOUTS; None: the mode's default, graph.default_layout). ``here`` (node and group names,
    drill_ros.graph.host_nodes) launches only that share of the graph, reaching the
    others' on ``peers`` (docs/multihost.md); the report is made where the recorder runs.
    ``extras`` adds optional nodes (the gateways), name -> parameters; in a share they run
    on this host. ``pin_cpus`` False leaves the processes on every CPU (several graphs
    running at once: launcher.cpu_sets would put their control chains on one CPU).
    ``mismatch`` (a member of config/mismatch.yaml or ``draw:N``) replaces the scenario's
    ``truth:``: how the plant differs from the model; only the plant's side is given it
    (run_truth, stage_truth). ``node_params``: more parameters of nodes of the graph
    (name -> parameters; the console's host and security directory). ``config_source``: the
    rig configuration's directory the run stages (stage_config; the checkout's config/
    unless given: the benches' variants of the well)."""
    kind = scenario_kind(path)
    if kind == "drilling":
        scenario, own_controller = _drilling_scenario(path, realtime, controller), "none"
    else:
        scenario, _ = load_scenario(path)
        own_controller = scenario.controller
    controller = controller or own_controller
    multi_stand = kind == "tripping" and scenario.trip is not None
    if multi_stand and controller not in MULTI_STAND_CONTROLLERS:
        raise ConfigError(f"--controller {controller}: {path.name} trips stands (trip:), which "
                          f"runs under {', '.join(MULTI_STAND_CONTROLLERS)} only")
    if multi_stand and realtime:
        raise ConfigError(f"--realtime: {path.name} trips stands (trip:), which runs in fast "
                          "mode only")
    if mismatch is not None and kind != "tripping":
        raise ConfigError(f"--mismatch {mismatch}: {path.name} is a {kind} scenario; a "
                          "mismatch changes a tripping run's well (docs/mismatch.md)")
    truth = run_truth(path, mismatch) if kind == "tripping" else None
    layout = layout or graph_decl.default_layout(realtime, here is not None)
    stamp = datetime.now().strftime(RUN_STAMP)
    tags = "".join(f"-{tag}" for tag in (
        controller if controller != own_controller else None,
        f"seed{seed}" if seed is not None else None,
        truth[0].replace(":", "") if truth else None) if tag)
    run_dir = (runs_dir or ROOT / "runs") / f"{scenario.name}{tags}-{stamp}-{os.getpid()}"
    mcap_path = run_dir / f"{scenario.name}.mcap"
    mode = "realtime" if realtime else "fast"
    staged = path if truth is None else run_dir / "scenario.yaml"
    common = {"config_dir": str(run_dir / report.RUN_CONFIG), "scenario": str(staged), "mode": mode}
    nodes = launcher.graph(controller, common, mcap_path, fast=not realtime, layout=layout,
                           kind=kind, extras=extras, node_params=node_params,
                           multi_stand=multi_stand)
    if truth is not None:
        for node in nodes:
            if graph_decl.BY_NAME[node.name].truth_side:
                node.params["truth"] = str(run_dir / TRUTH_FILE)
    if seed is not None:
        nodes[-1].params["seed"] = seed
    names = {n.name for n in nodes}
    if here is not None:
        names = {n.name for n in graph_decl.host_nodes(
            here, [graph_decl.BY_NAME[n.name] for n in nodes])} | set(extras or {})
    own_domain = domain_id is None          # taken here: given back when the graph stops
    domain_id = launcher.default_domain_id() if own_domain else domain_id
    launch = launcher.Launch(nodes, run_dir, domain_id, layout,
                             None if here is None else names, peers, pin_cpus=pin_cpus)
    run_dir.mkdir(parents=True, exist_ok=True)
    stage_config(run_dir, config_source or ROOT / "config")
    if truth is not None:
        stage_truth(path, run_dir, truth)
    say = (lambda *_: None) if quiet else (lambda text: print(text, flush=True))
    say(f"[rig] {scenario.name}: {scenario.description} ({mode} mode, logs in {run_dir / 'logs'})")
    started = time.monotonic()
    launch.start()
    if launch.removed_shm_ports:
        say(f"[rig] removed {len(launch.removed_shm_ports)} dead shared-memory ports of ROS domain "
            f"{domain_id} (left by a process killed in an earlier run; drill_bringup.shm_ports)")
    if realtime:
        say(f"[rig] ROS_DOMAIN_ID {launch.env['ROS_DOMAIN_ID']} (operator CLI: "
            f"python -m drill_hmi.operator_cli --domain {launch.env['ROS_DOMAIN_ID']} watch)")
        if "console" in names:
            say(f"[rig] console: {reported_url(run_dir / 'logs' / 'console.log', 'CONSOLE_URL')}")
    for name, key in (("foxglove_bridge", "FOXGLOVE_URL"), ("opcua_gateway", "OPCUA_URL"),
                      ("wits0_gateway", "WITS0_ADDRESS")):
        if name in (extras or {}) and name in names:
            say(f"[rig] {name}: {reported_url(run_dir / 'logs' / f'{name}.log', key)}")
    limit = timeout_s or (scenario.duration_s * 1.5 + 120 if realtime else 900.0)
    plant_process = next((p.name for p in launch.processes
                          if any(graph_decl.BY_NAME[n.name].plant for n in getattr(p, "nodes", ()))),
                         None)
    display = ProgressDisplay(run_dir / "logs" / f"{plant_process}.log", started,
                              sys.stdout.isatty()) \
        if plant_process and not realtime and not quiet else None
    try:
        ok, message = launch.watch(limit, on_poll=display.poll if display else None)
    except KeyboardInterrupt:
        ok, message = False, "interrupted"
    if display:
        display.close()
    codes = launch.stop()
    if own_domain:
        launcher.release_domain(domain_id)
    wall = time.monotonic() - started
    (run_dir / "launch.json").write_text(json.dumps(
        {"ok": ok, "message": message, "wall_time_s": wall, "exit_codes": codes,
         "scenario": str(path), "mode": mode, "controller": controller, "seed": seed,
         "mismatch": None if truth is None else truth[0],
         "layout": layout, "nodes": sorted(names), "peers": list(peers),
         "removed_shm_ports": launch.removed_shm_ports,
         "parameters": {n.name: n.params for n in nodes if n.name in names}},
        indent=2))
    if not ok:
        print(f"[rig] FAILED: {message}", file=sys.stderr, flush=True)
        return 1, run_dir
    simulated_s = _simulated_s(run_dir, plant_process, scenario.duration_s)
    say(f"[rig] finished in {wall:.1f} s wall for {simulated_s:.0f} s simulated "
        f"(real-time factor {wall / simulated_s:.3f})")
    if "recorder" not in names:
        say(f"[rig] this host's share ({', '.join(sorted(names))}) finished; the recording "
            "and the report are on the host that runs the recorder")
        return 0, run_dir
    summary, plots, table = report.write_report(mcap_path, run_dir, scenario.name)
    say(table)
    say(f"[rig] MCAP: {mcap_path}")
    say(f"[rig] plots: {', '.join(str(p) for p in plots)}")
    say(f"[rig] summary: {run_dir / 'summary.json'}")
    return 0, run_dir


