"""``rig compare``: run the paper's cases and the baseline, and tabulate them.

Every scenario runs through the whole process graph in fast mode (so the table is
reproducible: same scenarios and seeds, same numbers); the figures come from each run's
summary.json (report.summarise) and go to a Markdown file, in bar at this display edge.
The paper's Table 7 and Case 4 figures (DESIGN section 8; its plant, not ours) are
shown beside ours for scale.
"""
from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path

from drill_bringup import cli, report
from drill_core.scenario import load_scenario

PA_PER_BAR = 1e5
DEFAULT_SCENARIOS = ("case1", "case2", "case3", "case4", "baseline")
TRIP_CASES = ("case1", "case2", "case3")

# Paper Table 7 and section 6.2: (block mean error m, BHP mean error bar,
# block RMSE m, BHP RMSE bar); None where the paper gives no figure.
PAPER = {
    "case1": (-0.0459, 0.0822, 11.370, 0.689),
    "case2": (-0.00438, -0.00538, 11.377, 0.464),
    "case3": (-0.03805, 0.212, 11.389, 0.677),
    "case4": (None, None, 0.00881, 0.70039),
}


def run_all(names, runs_dir: Path | None = None, domain_id: int | None = None) -> dict:
    """Run each scenario; returns {name: {"summary": dict, "run_dir": str, "wall_s": float}}."""
    results = {}
    for name in names:
        print(f"[compare] running {name} ...", flush=True)
        code, run_dir = cli.run_scenario(cli.scenario_path(name), runs_dir=runs_dir,
                                         domain_id=domain_id, quiet=True)
        launch = json.loads((run_dir / "launch.json").read_text())
        if code != 0:
            raise RuntimeError(f"{name} failed: {launch['message']}")
        summary = json.loads((run_dir / "summary.json").read_text())
        results[name] = {"summary": summary, "run_dir": str(run_dir),
                         "wall_s": launch["wall_time_s"]}
        print(f"[compare] {name}: BHP RMSE {summary['bhp_rmse_pa'] / PA_PER_BAR:.3f} bar, "
              f"{launch['wall_time_s']:.1f} s wall", flush=True)
    return results


def _num(value, scale: float = 1.0, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value / scale:.{digits}f}"


def markdown(results: dict) -> str:
    """The comparison document: Table 7 form, control band and surge/swab, solver time."""
    lines = ["# Results: the paper's cases and the conventional baseline", "",
             f"Made by `scripts/rig compare` on {datetime.now():%Y-%m-%d %H:%M}: each scenario ran "
             "through the whole process graph over DDS in fast mode (deterministic: the same "
             "scenario files and seeds give the same numbers). Errors are truth minus "
             "reference; the BHP band is the scenario's +-2 bar control band; a trip leg is the "
             "time from a block target being set until the string is within 0.5 m of it.", "",
             "## Table 7 form (ours | paper)", "",
             "| scenario | controller | block mean error [m] | BHP mean error [bar] | "
             "block RMSE [m] | BHP RMSE [bar] |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, result in results.items():
        s = result["summary"]
        scenario, _ = load_scenario(cli.scenario_path(name))
        paper = PAPER.get(name, (None,) * 4)
        ours = (s["block_position_mean_error_m"], s["bhp_mean_error_pa"] / PA_PER_BAR,
                s["block_position_rmse_m"], s["bhp_rmse_pa"] / PA_PER_BAR)
        cells = [f"{_num(o)} \\| {_num(p)}" for o, p in zip(ours, paper)]
        lines.append(f"| {name} | {scenario.controller} | " + " | ".join(cells) + " |")
    lines += ["", "## Control band, surge and swab, solver", "",
              "| scenario | time outside band [s] | worst excursion [bar] | violations | "
              "peak surge [bar] | peak swab [bar] | max string speed [m/s] | trip legs | "
              "BHP estimate RMSE [bar] | NMPC solve median / max [ms] | fallbacks | wall [s] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, result in results.items():
        s = result["summary"]
        solver = "n/a"
        if s.get("solves"):
            solver = f"{s['solve_time_median_s'] * 1e3:.1f} / {s['solve_time_max_s'] * 1e3:.1f}"
        lines.append(
            f"| {name} | {s['bhp_time_outside_s']:.1f} | "
            f"{_num(s['bhp_worst_excursion_pa'], PA_PER_BAR, 2)} | {s['bhp_window_violations']} | "
            f"{_num(s['peak_surge_pa'], PA_PER_BAR, 2)} | {_num(s['peak_swab_pa'], PA_PER_BAR, 2)} | "
            f"{s['max_string_speed_mps']:.3f} | {report.format_legs(s.get('trip_legs', []))} | "
            f"{_num(s['bhp_estimate_rmse_pa'], PA_PER_BAR)} | "
            f"{solver} | {s.get('fallbacks', 0)} | {result['wall_s']:.1f} |")
    base = results.get("baseline")
    trips = [n for n in TRIP_CASES if n in results]
    if base and trips:
        b = base["summary"]
        lines += ["", "## Against the baseline (fixed-speed block, PI choke)", "",
                  "| scenario | BHP RMSE vs baseline | time outside band vs baseline | "
                  "peak surge vs baseline | peak swab vs baseline |",
                  "| --- | --- | --- | --- | --- |"]
        for name in trips:
            s = results[name]["summary"]
            lines.append(
                f"| {name} | {s['bhp_rmse_pa'] / b['bhp_rmse_pa']:.2f} x | "
                f"{s['bhp_time_outside_s']:.0f} s vs {b['bhp_time_outside_s']:.0f} s | "
                f"{_num(s['peak_surge_pa'], PA_PER_BAR, 1)} vs {_num(b['peak_surge_pa'], PA_PER_BAR, 1)} bar | "
                f"{_num(s['peak_swab_pa'], PA_PER_BAR, 1)} vs {_num(b['peak_swab_pa'], PA_PER_BAR, 1)} bar |")
    lines += ["", "Run directories (MCAP, plots, logs; not committed): "
              + ", ".join(f"`{Path(r['run_dir']).name}`" for r in results.values()), ""]
    return "\n".join(lines)


def main(names, output: Path) -> int:
    results = run_all(names or DEFAULT_SCENARIOS)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(markdown(results))
    print(f"[compare] wrote {output}")
    return 0
