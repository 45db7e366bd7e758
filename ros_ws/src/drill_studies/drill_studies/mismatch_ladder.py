"""The ladder for mismatch (docs/mismatch-ladder.md): Case 2 in process (drill_bringup.
loop_bench, the process protection in the loop) on the model's own plant and on each
member of config/mismatch.yaml, under each controller, with all that was added for a plant
that is not the model (``PARTS``), with all of it switched back to what the rig did before
(*before*), and with each part alone switched back: the part whose absence costs a row the
most is what recovered it. The NMPC's first rung feeds it the true state (an oracle:
friction factors fitted to the truth, the true density offset), so the row shows what the
model's error alone costs. The page is rendered from the runs' figures, which go to a
JSON file beside it.

    python -m drill_studies.mismatch_ladder [--seeds N] [--workers W] [--rungs LABEL ...]
                                            [--output FILE]
"""
from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from datetime import datetime
from pathlib import Path

import numpy as np

from drill_bringup import runs
from drill_studies import loop_bench
from drill_core.mismatch import load_suite
from drill_core.units import PA_PER_BAR
from drill_core.yaml_files import dotted_items, merge

CONTROLLERS = (("NMPC", "nmpc"), ("automated MPD", "automated_mpd"), ("PI baseline", "baseline"))
PARTS = (   # (what was added, its overrides back to before)
    ("the density offset state", {"estimator": {"estimate_density_offset": False}}),
    ("the estimator's sharp yield jump", {"estimator": {"annular_friction_smoothing_mps": 0.05}}),
    ("the prediction's sharp yield jump",
     {"nmpc": {"prediction_friction_smoothing_mps": 0.05,
               "pump_off_friction_smoothing_mps": 0.05, "substeps": 4}}),
    ("the integral's leak", {"nmpc": {"integral_leak_time_s": 0.0}}),
    ("the learnt flow baseline",
     {"protection": {"kick_detection": {"baseline_time_constant_s": 0.0}}}),
)
ABLATED = ("nmpc",)   # the controllers whose rows say which part recovered them
BEFORE: dict = {}
for _, _overrides in PARTS:
    BEFORE = merge(BEFORE, _overrides)


def _rungs() -> tuple:
    """(label, controller, state source, overrides, part switched off or None) per rung."""
    out = [("NMPC, oracle state", "nmpc", "truth", {}, None)]
    for name, controller in CONTROLLERS:
        out += [(f"{name} before", controller, "ukf", BEFORE, None),
                (name, controller, "ukf", {}, None)]
        if controller in ABLATED:
            out += [(f"{name} without {part}", controller, "ukf", overrides, part)
                    for part, overrides in PARTS]
    return tuple(out)


RUNGS = _rungs()
MODEL = "model"       # the plant that is the model
SIGNIFICANT_BAR = 0.05    # a part that changes a row's settled RMSE less is not named


def one(job: tuple) -> dict:
    """One in-process run: its figures (SI)."""
    member, rung, seed = job
    label, controller, state, overrides, _ = next(r for r in RUNGS if r[0] == rung)
    mismatch = None if member == MODEL else load_suite(runs.ROOT / "config")[0][member]
    r = loop_bench.run("case2", controller, state, seed, overrides, protection=True,
                       mismatch=mismatch)
    return {"member": member, "rung": rung, "seed": seed,
            "bhp_rmse_pa": r["bhp_rmse_pa"],
            "bhp_rmse_settled_pa": r["bhp_rmse_settled_pa"],
            "bhp_time_outside_settled_s": r["bhp_time_outside_settled_s"],
            "legs_s": [t for _, t in r["trip_legs"]],
            "bhp_estimate_rmse_pa": r["bhp_estimate_rmse_pa"],
            "fallbacks": r.get("fallbacks"),
            "alarms": len(r["raised"])}


def _cell(rows: list[dict]) -> str:
    if not rows:
        return ""
    rmse = np.mean([r["bhp_rmse_settled_pa"] for r in rows]) / PA_PER_BAR
    outside = np.mean([r["bhp_time_outside_settled_s"] for r in rows])
    legs = [t for r in rows for t in r["legs_s"]]
    leg = "no leg" if not legs or any(t is None for t in legs) or len(legs) < 2 * len(rows) \
        else f"{max(legs):.0f} s"
    alarms = sum(r["alarms"] for r in rows)
    return f"{rmse:.2f} bar, {outside:.0f} s, {leg}" + (f", {alarms} alarms" if alarms else "")


def _settled(rows: list[dict]) -> float:
    return float(np.mean([r["bhp_rmse_settled_pa"] for r in rows])) / PA_PER_BAR


def _needed_most(rows: list[dict], member: str, name: str) -> str:
    """The part whose absence alone raises the row's settled RMSE the most, and by how much."""
    def of(rung):
        return [r for r in rows if r["member"] == member and r["rung"] == rung]
    full = of(name)
    costs = [(_settled(of(rung[0])) - _settled(full), rung[4]) for rung in RUNGS
             if rung[4] is not None and rung[0].startswith(f"{name} without") and of(rung[0])]
    if not full or not costs:
        return ""
    cost, part = max(costs)
    return f"{part} (+{cost:.2f} bar)" if cost >= SIGNIFICANT_BAR else \
        f"none alone (each within {SIGNIFICANT_BAR:.2f} bar)"


def markdown(rows: list[dict], members: list[str], described: dict[str, str]) -> str:
    seeds = sorted({r["seed"] for r in rows})
    parts = "; ".join(f"{part} ({', '.join(f'{k}: {v}' for k, v in dotted_items(o))})"
                      for part, o in PARTS)
    lines = ["# The ladder for a plant that is not the model", "",
             "Made by `python -m drill_studies.mismatch_ladder` on "
             f"{datetime.now():%Y-%m-%d %H:%M} from its runs (figures in "
             "`mismatch-ladder.json`): Case 2 in process "
             "with the process protection in the loop, seeds "
             f"{', '.join(str(s) for s in seeds)}. Each cell: BHP RMSE after the first 30 s "
             "(mean over the seeds), time outside the +-2 bar band after the first 30 s "
             "(mean), the slowest trip leg (*no leg*: a leg not reached), and the kick and "
             "losses alarms raised (none raised where not shown; there is no formation flow "
             "in these runs, so every alarm is false). What was added for a plant that is not "
             f"the model, each with the setting it had before: {parts}. *before*: all of them "
             "switched back; *without*: that one alone. docs/mismatch.md says what each part "
             "does.", ""]
    main = [r for r in RUNGS if r[4] is None]
    lines += ["| plant | " + " | ".join(r[0] for r in main) + " |",
              "| --- " * (len(main) + 1) + "|"]
    for member in members:
        cells = [_cell([r for r in rows if r["member"] == member and r["rung"] == rung[0]])
                 for rung in main]
        name = member if member == MODEL else f"{member}: {described[member]}"
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    for name, _ in CONTROLLERS:
        ablations = [r for r in RUNGS if r[4] is not None and r[0].startswith(f"{name} without")]
        if not ablations:
            continue
        lines += ["", f"## What recovered each row: {name}", "",
                  f"Each part alone switched back (*{name}*: all of them in place); the last "
                  f"column, the part whose absence alone costs the row the most settled RMSE "
                  f"(a part within {SIGNIFICANT_BAR:.2f} bar is not named).", "",
                  "| plant | " + " | ".join(f"without {r[4]}" for r in ablations)
                  + " | needed most |",
                  "| --- " * (len(ablations) + 2) + "|"]
        for member in members:
            cells = [_cell([r for r in rows if r["member"] == member and r["rung"] == rung[0]])
                     for rung in ablations]
            lines.append(f"| {member} | " + " | ".join(cells) + " | "
                         + _needed_most(rows, member, name) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1, help="seeds: 2, 1002, ...")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--rungs", nargs="*", metavar="LABEL",
                        help="run only the rungs whose label starts with one of these (e.g. "
                             "'NMPC without'); the JSON's other rows are kept")
    parser.add_argument("--output", type=Path, default=runs.ROOT / "docs" / "mismatch-ladder.md")
    args = parser.parse_args(argv)
    suite, described, _ = load_suite(runs.ROOT / "config")
    members = [MODEL, *suite]
    chosen = [r[0] for r in RUNGS if not args.rungs or r[0].startswith(tuple(args.rungs))]
    jobs = [(m, rung, 2 + 1000 * k) for m in members for rung in chosen
            for k in range(args.seeds)]
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for row in pool.map(one, jobs):
            rows.append(row)
            print(f"[ladder] {row['member']} / {row['rung']} / seed {row['seed']}: "
                  f"{row['bhp_rmse_settled_pa'] / PA_PER_BAR:.2f} bar settled", flush=True)
    table = args.output.with_suffix(".json")
    if args.rungs and table.exists():    # read now: another share of the rungs may have written
        rows = [r for r in json.loads(table.read_text()) if r["rung"] not in chosen
                and r["rung"] in {rung[0] for rung in RUNGS}] + rows
    table.write_text(json.dumps(rows, indent=1))
    args.output.write_text(markdown(rows, members, described))
    print(f"[ladder] wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
