"""The ladder for mismatch (docs/mismatch-ladder.md): Case 2 in process (drill_bringup.
loop_bench, the process protection in the loop) on the model's own plant and on each
member of config/mismatch.yaml, under each controller, with and without what was added
for a plant that is not the model: the estimator's density offset state, the NMPC1
integral's leak and the kick detector's learnt flow baseline (*before*: those switched
off). The NMPC's first rung feeds it the true state (an oracle: friction factors fitted
to the truth, the true density offset), so the row shows what the model's error alone
costs. The page is rendered from the runs' figures, which go to a JSON file beside it.

    python -m drill_studies.mismatch_ladder [--seeds N] [--workers W] [--output FILE]
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

BEFORE = {"estimator": {"estimate_density_offset": False},
          "nmpc": {"integral_leak_time_s": 0.0},
          "protection": {"kick_detection": {"baseline_time_constant_s": 0.0}}}
RUNGS = (   # (label, controller, state source, configuration overrides)
    ("NMPC, oracle state", "nmpc", "truth", {}),
    ("NMPC before", "nmpc", "ukf", BEFORE),
    ("NMPC", "nmpc", "ukf", {}),
    ("automated MPD before", "automated_mpd", "ukf", BEFORE),
    ("automated MPD", "automated_mpd", "ukf", {}),
    ("PI baseline before", "baseline", "ukf", BEFORE),
    ("PI baseline", "baseline", "ukf", {}),
)
MODEL = "model"       # the plant that is the model


def one(job: tuple) -> dict:
    """One in-process run: its figures (SI)."""
    member, rung, seed = job
    label, controller, state, overrides = next(r for r in RUNGS if r[0] == rung)
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


def markdown(rows: list[dict], members: list[str], described: dict[str, str]) -> str:
    seeds = sorted({r["seed"] for r in rows})
    lines = ["# The ladder for a plant that is not the model", "",
             "Made by `python -m drill_studies.mismatch_ladder` on "
             f"{datetime.now():%Y-%m-%d %H:%M} from its runs (figures in "
             "`mismatch-ladder.json`): Case 2 in process "
             "with the process protection in the loop, seeds "
             f"{', '.join(str(s) for s in seeds)}. Each cell: BHP RMSE after the first 30 s "
             "(mean over the seeds), time outside the +-2 bar band after the first 30 s "
             "(mean), the slowest trip leg (*no leg*: a leg not reached), and the kick and "
             "losses alarms raised (none raised where not shown; there is no formation flow "
             "in these runs, so every alarm is false). *before*: the density offset state, "
             "the NMPC1 integral's leak and the detector's learnt baseline switched off "
             "(the choke-dp band follows the rest set-point in both). docs/mismatch.md says "
             "what each part does.", "",
             "| plant | " + " | ".join(r[0] for r in RUNGS) + " |",
             "| --- " * (len(RUNGS) + 1) + "|"]
    for member in members:
        cells = [_cell([r for r in rows if r["member"] == member and r["rung"] == rung[0]])
                 for rung in RUNGS]
        name = member if member == MODEL else f"{member}: {described[member]}"
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1, help="seeds: 2, 1002, ...")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--output", type=Path, default=runs.ROOT / "docs" / "mismatch-ladder.md")
    args = parser.parse_args(argv)
    suite, described, _ = load_suite(runs.ROOT / "config")
    members = [MODEL, *suite]
    jobs = [(m, rung[0], 2 + 1000 * k) for m in members for rung in RUNGS
            for k in range(args.seeds)]
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for row in pool.map(one, jobs):
            rows.append(row)
            print(f"[ladder] {row['member']} / {row['rung']} / seed {row['seed']}: "
                  f"{row['bhp_rmse_settled_pa'] / PA_PER_BAR:.2f} bar settled", flush=True)
    args.output.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    args.output.write_text(markdown(rows, members, described))
    print(f"[ladder] wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
