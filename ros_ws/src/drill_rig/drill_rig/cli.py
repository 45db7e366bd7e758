"""``scripts/rig``: run scenarios, replay recordings, report on runs.

  rig demo                         Case 2 trip in fast mode, with summary and plots
  rig run SCENARIO [--realtime] [--seed N] [--controller NAME] [--layout LAYOUT]
          [--nodes NAMES --domain N --peers ADDR[,ADDR]] [--runs-dir DIR]
          [--foxglove [PORT]] [--opcua [ENDPOINT]] [--wits0 [HOST:PORT]] [--mismatch NAME]
          [--security DIR] [--console-host HOST]
                                   any scenario (name under config/scenarios or a path),
                                   optionally under another controller than its own, with
                                   nodes grouped into processes (separate, actuators, plant,
                                   two); a drilling scenario (drilling_*) runs the drilling
                                   graph, fast mode only; --nodes: this host's share of a
                                   run split across hosts (docs/multihost.md); --foxglove /
                                   --opcua / --wits0 add the live Foxglove bridge / the OPC-UA
                                   gateway / the WITS0 record 01 stream (docs/gateways.md)
                                   --mismatch NAME: a plant that is not the model
                                   (config/mismatch.yaml, docs/mismatch.md)
                                   --security DIR: the console's token and the OPC-UA
                                   gateway's certificates and users (docs/security.md);
                                   --console-host HOST: serve the console there (beyond
                                   loopback only with --security)
  rig certs DIR [--host HOST ...]  make a security directory: the OPC-UA gateway's and a
                                   client's certificates, the console's token
  rig user DIR NAME --role viewer|operator [--password-stdin]
                                   add a user of the OPC-UA gateway (password hashed)
  rig report RUN_DIR [--units metric|field]
                                   re-make the summary and plots of a run (field: psi,
                                   gpm, bbl)
  rig replay FILE [options]        republish a recording (see rig replay --help)
  rig reestimate RUN_DIR [--config-dir DIR] [--rate R]
                                   re-run the estimator with other tuning on a recorded run
  rig stability SECTION --elements N [--bha] [--mud-viscosity PA_S] [--output DIR]
                                   decoupled axial stability of a drilling-mode string
                                   (Paper IV): crossing frequencies, critical delays, delay
                                   margin, critical speed; with --output the figures like
                                   the paper's Figs. 3, 4 and 7
  rig export RUN_DIR [--format csv|parquet|las|witsml] [--topics T ...] [--wide RATE_HZ] [--output DIR]
                                   the recording as tables, one per topic (or one resampled
                                   at RATE_HZ), SI columns named with units, UTC stamps; or
                                   as a well log (LAS 2.0, WITSML 2.1) in WITS metric units
  rig sweep SCENARIO --seeds N [--first-seed S] [--controller C ...] [--set FILE.KEY=VALUE ...]
            [--workers W] [--cluster ADDRESS] [--output DIR]
                                   the scenario on N seeds through the graph, on a local pool
                                   or a Dask cluster; mean, spread and worst of each figure
                                   per controller (table, plot); the same --output resumes
  rig compare [SCENARIO ...] [--seeds N] [--controller C ...] [--output FILE] [--mismatch SUITE]
              [--resume] [--render]
                                   Cases 1-3 and the fault scenarios under the NMPC, automated
                                   MPD and the PI baseline (--controller: only these), Case 4
                                   under its NMPC, N seeds each; write the results (the rows of
                                   cases and controllers not run are kept);
                                   --mismatch SUITE: Cases 1-3 on plants that are not the model
                                   (suite: every member of config/mismatch.yaml); --resume:
                                   the runs the table holds are not run again; --render:
                                   run nothing, write the page again from its JSON table
  rig compare --fault-matrix [PAIRS] [--with-fault FAULT ...] [--controller C ...] [--resume]
              [--workers W] [--render | --bounds]
                                   each actuator and sensor fault alone and in pairs
                                   (pull-out, rest, run-in) under every controller: time
                                   outside the pore/fracture window per cell
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from drill_analysis import report
from drill_bringup import launcher
from drill_bringup.runs import ROOT, run_scenario, scenario_path
from drill_bringup.split_run import split_options
from drill_core.access import require_security_beyond_loopback
from drill_core.config import ConfigError
from drill_ros.graph import CONTROLLERS, HOST_GROUPS, LAYOUTS, SelectionError
from drill_core.units import DISPLAY_UNITS, PA_PER_BAR, Display


# --foxglove / --opcua / --wits0 without a value: the gateway's own default (not a str: argparse would
# convert one with the option's type)
GATEWAY_DEFAULT = object()


def _stability(args) -> int:
    from drill_string.parameters import SECTIONS
    from drill_string.stability_command import run
    if args.section not in SECTIONS:
        print(f"[rig] unknown section {args.section!r}; one of {', '.join(SECTIONS)}",
              file=sys.stderr)
        return 2
    if args.elements < 1:
        print("[rig] --elements must be at least 1", file=sys.stderr)
        return 2
    if args.mud_viscosity is not None and not args.mud_viscosity > 0.0:
        print("[rig] --mud-viscosity must be positive (Pa s)", file=sys.stderr)
        return 2
    text, paths = run(args.section, args.elements, args.bha, args.mud_viscosity, args.output)
    print(text)
    for path in paths:
        print(f"[rig] plot: {path}")
    return 0


def _gateways(args) -> dict[str, dict]:
    """The gateways ``rig run`` was asked for, name -> the parameter given (none: theirs)."""
    asked = {"foxglove_bridge": ("port", args.foxglove), "opcua_gateway": ("endpoint", args.opcua),
             "wits0_gateway": ("address", args.wits0)}
    return {name: {} if value is GATEWAY_DEFAULT else {parameter: value}
            for name, (parameter, value) in asked.items() if value is not None}


def _node_params(args) -> dict[str, dict]:
    """What ``rig run`` gives nodes of the graph besides the gateways' own options: the
    console's address, and the security directory to the console and the OPC-UA gateway."""
    security = {"security_dir": str(args.security.resolve())} if args.security else {}
    console = {"host": args.console_host} if args.console_host else {}
    return {"console": {**console, **security}, "opcua_gateway": security}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="rig", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="run the Case 2 trip in fast mode")
    run = sub.add_parser("run", help="run a scenario")
    run.add_argument("scenario")
    run.add_argument("--realtime", action="store_true", help="wall-clock pacing")
    run.add_argument("--seed", type=int)
    run.add_argument("--controller", choices=CONTROLLERS,
                     help="run the scenario under this controller instead of its own")
    run.add_argument("--layout", choices=tuple(LAYOUTS),
                     help="process layout: one process per node (separate), or groups of "
                          "nodes in one process each (see docs/architecture.md); default: "
                          "two in fast mode, separate in realtime and for --nodes")
    run.add_argument("--nodes", help="launch only this share of the run's nodes (comma list "
                                     f"of node names and the groups {', '.join(HOST_GROUPS)}); "
                                     "the other hosts launch the rest (docs/multihost.md)")
    run.add_argument("--domain", type=int, help="ROS_DOMAIN_ID, 0-101 (default: a free one of "
                                                "this host's); every host of a split run the same")
    run.add_argument("--peers", help="comma list of the other hosts' IPv4 addresses or names: "
                                     "discovery by unicast to them (ROS_STATIC_PEERS) besides "
                                     "localhost")
    run.add_argument("--runs-dir", type=Path, help="where the run directory goes "
                                                   "(default: runs/)")
    run.add_argument("--foxglove", nargs="?", type=int, const=GATEWAY_DEFAULT, metavar="PORT",
                     help="stream the run's topics to Foxglove on ws://127.0.0.1:PORT (0: a "
                          "free port; without PORT the bridge's default, docs/gateways.md)")
    run.add_argument("--opcua", nargs="?", const=GATEWAY_DEFAULT, metavar="ENDPOINT",
                     help="serve the OPC-UA gateway on ENDPOINT (without it the gateway's "
                          "default, on this machine only; read docs/gateways.md before "
                          "binding elsewhere)")
    run.add_argument("--wits0", nargs="?", const=GATEWAY_DEFAULT, metavar="HOST:PORT",
                     help="stream WITS0 record 01 once a second to TCP clients of HOST:PORT "
                          "(without it 127.0.0.1:11000; port 0: a free one; docs/gateways.md)")
    run.add_argument("--mismatch", metavar="NAME",
                     help="the plant differs from the model: a member of config/mismatch.yaml "
                          "or draw:N (replaces the scenario's truth:, docs/mismatch.md)")
    run.add_argument("--security", type=Path, metavar="DIR",
                     help="a security directory (rig certs DIR): the console takes actions "
                          "with its token, the OPC-UA gateway speaks Basic256Sha256 to its "
                          "users (docs/security.md)")
    run.add_argument("--console-host", metavar="HOST",
                     help="the console's address (default 127.0.0.1; another needs --security)")
    sub.add_parser("certs", help="make a security directory", add_help=False)
    sub.add_parser("user", help="add a user to a security directory", add_help=False)
    rep = sub.add_parser("report", help="summary and plots of a run directory")
    rep.add_argument("run_dir", type=Path)
    rep.add_argument("--units", choices=tuple(DISPLAY_UNITS), default="metric",
                     help="display units of the printed table and the plots: metric (bar, "
                          "L/min, L) or field (psi, gpm, bbl); summary.json stays SI")
    sub.add_parser("replay", help="republish a recording", add_help=False)
    rest_ = sub.add_parser("reestimate", help="re-run the estimator on a recorded run")
    rest_.add_argument("run_dir", type=Path)
    rest_.add_argument("--config-dir", type=Path, default=ROOT / "config",
                       help="configuration with the new estimator tuning")
    rest_.add_argument("--rate", type=float, default=5.0, help="replay rate factor")
    stab = sub.add_parser("stability", help="decoupled axial stability of a drilling string")
    stab.add_argument("section", help="Paper IV Table 1 section: 36in, 26in, 17.5in, 12.25in, "
                                      "8.5in or 6in")
    stab.add_argument("--elements", type=int, required=True, help="number of lumped blocks n")
    stab.add_argument("--bha", action="store_true", help="the lowest block(s) are collars")
    stab.add_argument("--mud-viscosity", type=float, help="Pa s (default: the section's)")
    stab.add_argument("--output", type=Path, help="write the Fig. 3, 4 and 7 like plots here")
    from drill_bag import export
    export.add_arguments(sub.add_parser("export", help="a run's recording as CSV or Parquet tables, or a LAS or WITSML well log"))
    from drill_studies import sweep
    sweep.add_arguments(sub.add_parser("sweep", help="a scenario on many seeds, aggregated"))
    comp = sub.add_parser("compare", help="run Cases 1-4 under every controller; tabulate")
    comp.add_argument("scenarios", nargs="*", help="default: case1..case4 and the fault "
                                                   "scenarios (kick, losses, pump_trip, "
                                                   "choke_plug, sensor_faults)")
    comp.add_argument("--seeds", type=int, default=3, choices=(1, 2, 3),
                      help="seeds per case (the scenario's, and +1000, +2000)")
    comp.add_argument("--output", type=Path,
                      help="default docs/results.md (docs/fault-matrix.md with --fault-matrix)")
    comp.add_argument("--mismatch", metavar="SUITE",
                      help="the trip cases on plants that are not the model: suite (every "
                           "member of config/mismatch.yaml) or a comma list of members")
    comp.add_argument("--resume", action="store_true",
                      help="do not run again a planned run whose row the table already holds")
    from drill_studies.fault_matrix import CONTROLLERS as MATRIX_CONTROLLERS, PAIRS
    comp.add_argument("--fault-matrix", nargs="?", const="actuators", choices=PAIRS,
                      help="each actuator and sensor fault alone and in pairs in the "
                           "pull-out, at rest and in the run-in (actuators, the default: "
                           "every pair of actuator faults; all: every pair), under every "
                           "controller (docs/fault-matrix.md)")
    comp.add_argument("--workers", type=int, default=1,
                      help="with --fault-matrix: runs at a time (a local process pool)")
    comp.add_argument("--with-fault", metavar="FAULT", action="append", default=[],
                      help="with --fault-matrix: run only the cells with this fault (e.g. "
                           "'mud pump trip'; repeatable: the cells with each), the table's "
                           "other rows kept")
    comp.add_argument("--controller", action="append", choices=MATRIX_CONTROLLERS,
                      help="only under this controller (repeatable; the other controllers' "
                           "rows kept); with --fault-matrix, with --with-fault")
    comp.add_argument("--render", action="store_true",
                      help="run nothing: write the page again from its JSON table")
    comp.add_argument("--bounds", action="store_true",
                      help="with --fault-matrix: the machines' fastest answer, in process, "
                           "for each run that left the window, after its controller "
                           "(drill_studies.fault_bound)")
    args, rest = parser.parse_known_args(argv)
    try:
        if args.command == "demo":
            return run_scenario(scenario_path("case2"))[0]
        if args.command == "run":
            peers = split_options(args.nodes, args.domain, args.peers)
            if args.console_host:
                require_security_beyond_loopback(args.console_host, args.security, "the console")
            return run_scenario(scenario_path(args.scenario), args.realtime, args.runs_dir,
                                seed=args.seed, domain_id=args.domain,
                                controller=args.controller, layout=args.layout,
                                here=args.nodes, peers=peers, extras=_gateways(args),
                                mismatch=args.mismatch, node_params=_node_params(args))[0]
        if args.command in ("certs", "user"):   # the gateway's package (it has asyncua)
            return subprocess.call([sys.executable, "-m", "drill_gateway.certificates",
                                    args.command, *rest])
        if args.command == "report":
            mcap = next(args.run_dir.glob("*.mcap"))
            _, plots, table = report.write_report(mcap, args.run_dir, args.run_dir.name,
                                                  units=Display(args.units))
            print(table)
            return 0
        if args.command == "export":
            return export.main(args)
        if args.command == "sweep":
            return sweep.main(args)
        if args.command == "stability":
            return _stability(args)
        if args.command == "compare":
            if args.fault_matrix is not None:
                from drill_studies import fault_matrix
                output = args.output or ROOT / "docs" / "fault-matrix.md"
                if args.render:
                    return fault_matrix.render(output)
                if args.bounds:
                    from drill_studies import fault_bound
                    return fault_bound.main(output)
                return fault_matrix.main(output, args.fault_matrix, args.with_fault,
                                         args.controller or fault_matrix.CONTROLLERS,
                                         resume=args.resume, workers=args.workers)
            from drill_studies import compare
            output = args.output or ROOT / "docs" / "results.md"
            if args.render:
                return compare.render(output)
            return compare.main(args.scenarios, output, args.seeds,
                                tuple(args.controller or compare.CONTROLLERS),
                                mismatch=args.mismatch, resume=args.resume)
        if args.command == "reestimate":
            from drill_studies.reestimate import reestimate
            result = reestimate(args.run_dir, args.config_dir, args.rate, launcher.default_domain_id())
            recorded = result["recorded_bhp_estimate_rmse_pa"] / PA_PER_BAR
            print(f"[rig] BHP estimate RMSE: recorded {recorded:.3f} bar, "
                  f"re-run {result['new_bhp_estimate_rmse_pa'] / PA_PER_BAR:.3f} bar "
                  f"({result['estimates']} estimates for {result['measurements']} measurements); "
                  f"{result['mcap']}")
            return 0
        from drill_bag import replay
        return replay.main(["rig replay", *rest]) or 0     # its argv: the program's name first
    except ConfigError as err:
        print(f"[rig] configuration error: {err}", file=sys.stderr)
        return 2
    except SelectionError as err:
        print(f"[rig] {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
