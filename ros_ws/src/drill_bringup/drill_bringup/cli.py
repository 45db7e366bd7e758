"""``scripts/rig``: run scenarios, replay recordings, report on runs.

  rig demo                         Case 2 trip in fast mode, with summary and plots
  rig run SCENARIO [--realtime]    any scenario (name under config/scenarios or a path)
  rig report RUN_DIR               re-make the summary and plots of a run
  rig replay FILE [options]        republish a recording (see rig replay --help)
  rig reestimate RUN_DIR [--config-dir DIR] [--rate R]
                                   re-run the estimator with other tuning on a recorded run
  rig compare [SCENARIO ...] [--output FILE]
                                   run Cases 1-4 and the baseline; write the results table
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import datetime
from pathlib import Path

from drill_bringup import launcher, report
from drill_core.config import ConfigError
from drill_core.scenario import load_scenario

ROOT = Path(os.environ.get("RIG_ROOT", Path.cwd()))


def scenario_path(name: str) -> Path:
    path = Path(name)
    if path.suffix in (".yaml", ".yml") and path.exists():
        return path.resolve()
    candidate = ROOT / "config" / "scenarios" / f"{name}.yaml"
    if not candidate.exists():
        known = ", ".join(sorted(p.stem for p in (ROOT / "config" / "scenarios").glob("*.yaml")))
        raise SystemExit(f"unknown scenario '{name}'; known: {known}")
    return candidate


def console_url(log_path: Path, timeout_s: float = 10.0) -> str:
    """The console's address, as it prints it once it serves (CONSOLE_URL <url>)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if log_path.exists():
            for line in log_path.read_text(errors="replace").splitlines():
                if "CONSOLE_URL" in line:
                    return line.split("CONSOLE_URL", 1)[1].strip()
        time.sleep(0.2)
    return f"not reported yet (see {log_path})"


def run_scenario(path: Path, realtime: bool = False, runs_dir: Path | None = None,
                 seed: int | None = None, domain_id: int | None = None,
                 timeout_s: float | None = None, quiet: bool = False) -> tuple[int, Path]:
    """Launch a scenario, record it and report; returns (exit code, run directory)."""
    scenario, _ = load_scenario(path)
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir = (runs_dir or ROOT / "runs") / f"{scenario.name}-{stamp}-{os.getpid()}"
    run_dir.mkdir(parents=True, exist_ok=True)
    mcap_path = run_dir / f"{scenario.name}.mcap"
    mode = "realtime" if realtime else "fast"
    common = {"config_dir": str(ROOT / "config"), "scenario": str(path), "mode": mode}
    nodes = launcher.graph(scenario.controller, common, mcap_path, fast=not realtime)
    if seed is not None:
        nodes[-1].params["seed"] = seed
    launch = launcher.Launch(nodes, run_dir, domain_id or launcher.default_domain_id())
    say = (lambda *_: None) if quiet else (lambda text: print(text, flush=True))
    say(f"[rig] {scenario.name}: {scenario.description} ({mode} mode, logs in {run_dir / 'logs'})")
    started = time.monotonic()
    launch.start()
    if realtime:
        say(f"[rig] ROS_DOMAIN_ID {launch.env['ROS_DOMAIN_ID']} (operator CLI: "
            f"python -m drill_bringup.operator_cli --domain {launch.env['ROS_DOMAIN_ID']} watch)")
        say(f"[rig] console: {console_url(run_dir / 'logs' / 'console.log')}")
    limit = timeout_s or (scenario.duration_s * 1.5 + 120 if realtime else 900.0)
    try:
        ok, message = launch.watch(limit)
    except KeyboardInterrupt:
        ok, message = False, "interrupted"
    codes = launch.stop()
    wall = time.monotonic() - started
    (run_dir / "launch.json").write_text(json.dumps(
        {"ok": ok, "message": message, "wall_time_s": wall, "exit_codes": codes,
         "scenario": str(path), "mode": mode}, indent=2))
    if not ok:
        print(f"[rig] FAILED: {message}", file=sys.stderr, flush=True)
        return 1, run_dir
    say(f"[rig] finished in {wall:.1f} s wall for {scenario.duration_s:.0f} s simulated "
        f"(real-time factor {wall / scenario.duration_s:.3f})")
    summary, plots, table = report.write_report(mcap_path, run_dir, scenario.name)
    say(table)
    say(f"[rig] MCAP: {mcap_path}")
    say(f"[rig] plots: {', '.join(str(p) for p in plots)}")
    say(f"[rig] summary: {run_dir / 'summary.json'}")
    return 0, run_dir


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="rig", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="run the Case 2 trip in fast mode")
    run = sub.add_parser("run", help="run a scenario")
    run.add_argument("scenario")
    run.add_argument("--realtime", action="store_true", help="wall-clock pacing")
    run.add_argument("--seed", type=int)
    rep = sub.add_parser("report", help="summary and plots of a run directory")
    rep.add_argument("run_dir", type=Path)
    sub.add_parser("replay", help="republish a recording", add_help=False)
    rest_ = sub.add_parser("reestimate", help="re-run the estimator on a recorded run")
    rest_.add_argument("run_dir", type=Path)
    rest_.add_argument("--config-dir", type=Path, default=ROOT / "config",
                       help="configuration with the new estimator tuning")
    rest_.add_argument("--rate", type=float, default=5.0, help="replay rate factor")
    comp = sub.add_parser("compare", help="run Cases 1-4 and the baseline; tabulate")
    comp.add_argument("scenarios", nargs="*", help="default: case1 case2 case3 case4 baseline")
    comp.add_argument("--output", type=Path, default=ROOT / "docs" / "results.md")
    args, rest = parser.parse_known_args(argv)
    try:
        if args.command == "demo":
            return run_scenario(scenario_path("case2"))[0]
        if args.command == "run":
            return run_scenario(scenario_path(args.scenario), args.realtime, seed=args.seed)[0]
        if args.command == "report":
            mcap = next(args.run_dir.glob("*.mcap"))
            _, plots, table = report.write_report(mcap, args.run_dir, args.run_dir.name)
            print(table)
            return 0
        if args.command == "compare":
            from drill_bringup import compare
            return compare.main(args.scenarios, args.output)
        if args.command == "reestimate":
            from drill_bringup.reestimate import reestimate
            result = reestimate(args.run_dir, args.config_dir, args.rate, launcher.default_domain_id())
            print(f"[rig] BHP estimate RMSE: recorded {result['recorded_bhp_estimate_rmse_pa'] / 1e5:.3f} bar, "
                  f"re-run {result['new_bhp_estimate_rmse_pa'] / 1e5:.3f} bar "
                  f"({result['estimates']} estimates for {result['measurements']} measurements); "
                  f"{result['mcap']}")
            return 0
        from drill_bringup import replay
        return replay.main(rest) or 0
    except ConfigError as err:
        print(f"[rig] configuration error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
