"""``rig compare``: the paper's cases under every controller, on several seeds, tabulated.

Every run goes through the whole process graph in fast mode (reproducible: same scenario
files and seeds, same numbers). The trip cases (Cases 1-3: one stand out and back in) run
under the case's NMPC, automated MPD and the PI baseline, each on the case's seed and two
more; Case 4 (set-point steps) under its NMPC; the multi-stand trips (trip_out, trip_in: ten
stands through their connections) under the controllers that plan one
(drill_studies.multi_stand_section). The figures come from each run's
summary.json (report.summarise) and go to a Markdown file, in bar at this display edge,
as mean and worst over the seeds, with the paper's Table 7 beside them and the issue's
targets checked per run. One trip per controller is plotted side by side.

With ``--mismatch`` (``suite``: every member of config/mismatch.yaml, or a comma list of
members) the trip cases run on plants that are not the model instead, each member under
every controller; those rows go to the same results and their own section: per member
the mean and worst over the seeds, per controller the mean and worst over the suite, with
the issue's mismatch targets checked per run.
"""
from __future__ import annotations

import json
import math
from datetime import datetime
from pathlib import Path

import numpy as np

from drill_analysis import report
from drill_bringup import runs
from drill_studies import batch, multi_stand_section
from drill_studies.multi_stand_section import MULTI_STAND_CASES
from drill_studies.table_cells import missed_targets, stat as _stat
from drill_core.mismatch import load_suite, resolve
from drill_core.scenario import MULTI_STAND_CONTROLLERS, load_scenario
from drill_core.units import L_PER_M3, PA_PER_BAR

TRIP_CASES = ("case1", "case2", "case3")
STEP_CASES = ("case4",)
# Case 2's trip with something going wrong (docs/design.md section 8), under every controller
FAULT_CASES = ("kick", "losses", "pump_trip", "choke_plug", "sensor_faults")
CONTROLLERS = ("nmpc", "automated_mpd", "baseline")
SEED_OFFSETS = (0, 1000, 2000)      # seeds: the scenario's, and these added to it

# Paper Table 7 and section 6.2: (block mean error m, BHP mean error bar,
# block RMSE m, BHP RMSE bar).
PAPER = {
    "case1": (-0.0459, 0.0822, 11.370, 0.689),
    "case2": (-0.00438, -0.00538, 11.377, 0.464),
    "case3": (-0.03805, 0.212, 11.389, 0.677),
    "case4": (None, None, 0.00881, 0.70039),
}
# The targets a trip controller is held to (SI), checked per run.
TARGETS = {
    "bhp_rmse_pa": 0.7e5,
    "bhp_time_outside_settled_s": 5.0,
    "bhp_worst_excursion_pa": 1.0e5,
    "trip_leg_s": 57.0,
    "fallback_share": 0.01,
    "bhp_estimate_rmse_pa": 0.4e5,
    "solve_median_s": 0.010,
    "solve_p99_s": 0.030,
}


def plan(cases, controllers, seeds: int) -> list[tuple[str, str, int]]:
    """(case, controller, seed) of every run: trip and fault cases under each controller,
    step cases under their own."""
    out = []
    for case in cases:
        scenario, _ = load_scenario(runs.scenario_path(case))
        every = case in TRIP_CASES or case in FAULT_CASES
        chosen = controllers if every else (scenario.controller,)
        if case in MULTI_STAND_CASES:
            chosen = [c for c in controllers if c in MULTI_STAND_CONTROLLERS]
        for offset in SEED_OFFSETS[:seeds]:
            for controller in chosen:
                out.append((case, controller, scenario.seed + offset))
    return out


def plan_mismatch(cases, controllers, seeds: int, members) -> list[tuple]:
    """(case, controller, seed, member) of every run on a mismatched plant: each trip case
    under each controller on each member of the suite."""
    return [(case, controller, seed, member)
            for case, controller, seed in plan(cases, controllers, seeds) for member in members]


def run_all(items, runs_dir: Path | None = None, run=batch.run_one) -> list[dict]:
    """Run each (case, controller, seed[, mismatch]), one after another (drill_studies.batch);
    a row per run with its summary. A failed run stops the comparison, naming it."""
    specs = [batch.RunSpec(case, str(runs.scenario_path(case)), controller, seed,
                           None if runs_dir is None else str(runs_dir),
                           mismatch=rest[0] if rest else None)
             for case, controller, seed, *rest in items]
    rows = []
    commit = runs.source_commit()

    def done(row: dict) -> None:
        plant = f" / {row['mismatch']}" if row.get("mismatch") else ""
        label = f"{row['case']}{plant} / {row['controller']} / seed {row['seed']}"
        if not row["ok"]:
            raise RuntimeError(f"{label} failed: {row['message']}")
        rows.append({k: row.get(k) for k in ("case", "controller", "seed", "mismatch",
                                             "summary", "run_dir", "wall_s")} | {"commit": commit})
        print(f"[compare] {label}: BHP RMSE {row['summary']['bhp_rmse_pa'] / PA_PER_BAR:.3f} "
              f"bar, {row['wall_s']:.1f} s wall", flush=True)
    print(f"[compare] {len(specs)} runs, one at a time", flush=True)
    batch.execute(specs, run, on_done=done)
    return rows


def figures(s: dict) -> dict:
    """The compared figures of one run (SI; legs in s, None where not reached)."""
    legs = [t for _, t in s.get("trip_legs", [])]
    solves = s.get("solves", 0)
    return {"bhp_rmse_pa": s["bhp_rmse_pa"],
            "bhp_rmse_settled_pa": s.get("bhp_rmse_settled_pa"),
            "bhp_time_outside_s": s["bhp_time_outside_s"],
            "bhp_time_outside_settled_s": s["bhp_time_outside_settled_s"],
            "bhp_worst_excursion_pa": s["bhp_worst_excursion_pa"],
            "leg_out_s": legs[0] if len(legs) > 0 else None,
            "leg_in_s": legs[1] if len(legs) > 1 else None,
            "max_string_speed_mps": s["max_string_speed_mps"],
            "trip_overshoot_m": s.get("trip_overshoot_m"),
            "bhp_estimate_rmse_pa": s["bhp_estimate_rmse_pa"],
            "fallback_share": s.get("fallbacks", 0) / solves if solves else None,
            "solve_median_s": s.get("solve_time_median_s"),
            "solve_p99_s": s.get("solve_time_p99_s"),
            "solve_max_s": s.get("solve_time_max_s")}


def misses(f: dict, baseline: dict | None) -> list[str]:
    """The targets one trip run misses (empty: all met)."""
    out = []
    for key in ("bhp_rmse_pa", "bhp_time_outside_settled_s", "bhp_worst_excursion_pa",
                "bhp_estimate_rmse_pa", "fallback_share", "solve_median_s", "solve_p99_s"):
        if f[key] is not None and f[key] > TARGETS[key]:
            out.append(key)
    for key in ("leg_out_s", "leg_in_s"):
        if f[key] is None or f[key] > TARGETS["trip_leg_s"]:
            out.append(key)
    if baseline is not None and f["bhp_rmse_pa"] >= baseline["bhp_rmse_pa"]:
        out.append("bhp_rmse_pa vs baseline")
    return out


def _fallbacks(group, fs) -> str:
    """The fallbacks of a group of runs (n/a for a controller that has none)."""
    return "n/a" if fs[0]["fallback_share"] is None else \
        str(sum(r["summary"].get("fallbacks", 0) for r in group))


def _legs(rows, key) -> str:
    values = [figures(r["summary"])[key] for r in rows]
    if any(v is None for v in values):
        return f"{sum(v is None for v in values)} not reached"
    return _stat(values, 1.0, 1)


def markdown(rows: list[dict], plot_name: str | None, made: str = "") -> str:
    """The comparison document."""
    every = rows
    mismatched = [r for r in rows if r.get("mismatch")]
    rows = [r for r in rows if not r.get("mismatch")]
    by = {}
    for r in rows:
        by.setdefault((r["case"], r["controller"]), []).append(r)
    seeds = sorted({r["seed"] for r in every})        # the mismatch rows' too
    lines = [
        "# Results: the paper's cases under every controller", "",
        f"Made by `scripts/rig compare` on {made or f'{datetime.now():%Y-%m-%d %H:%M}'}: "
        "each run went through "
        "the whole process graph over DDS in fast mode (deterministic: the same scenario "
        "files and seeds give the same numbers), one run at a time per comparison on the "
        "2-core machine (the solve times are the day's and the machine's: comparisons run "
        "side by side share the cores; the NMPC alone is in docs/benchmarks.md). "
        "Errors are truth minus reference; the BHP band is the scenario's +-2 bar control "
        "band (band time *settled*: after the first 30 s); a trip leg is the time from a "
        "block target being set until the string is within 0.5 m of it, *past target* the "
        "furthest the string ran beyond a target, *max string speed* against the trip-speed "
        "limit of 0.5 m/s. Each cell gives the "
        "mean / worst over the seeds of that case. Controllers: `nmpc` the case's NMPC "
        "configuration (docs/nmpc.md), `automated_mpd` a planned trip with a model-based "
        "choke-dp set-point on the choke's pressure loop, `baseline` a fixed-speed block "
        "ramp with a 1 Hz PI choke on the measured BHP.", "",
        "## Trip cases (mean / worst over seeds)", "",
        "| case | controller | BHP RMSE [bar] | outside band [s] | outside, settled [s] | "
        "worst excursion [bar] | leg out [s] | leg in [s] | max string speed [m/s] | "
        "past target [m] | BHP estimate RMSE [bar] | solve median / p99 / max [ms] | "
        "fallbacks | runs missing a target |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case in TRIP_CASES:
        base = {r["seed"]: figures(r["summary"]) for r in by.get((case, "baseline"), [])}
        for controller in CONTROLLERS:
            group = by.get((case, controller))
            if not group:
                continue
            fs = [figures(r["summary"]) for r in group]
            solver = "n/a"
            if fs[0]["solve_median_s"] is not None:
                solver = " / ".join(_stat([f[k] for f in fs], 1e-3, 1).split(" / ")[1]
                                    for k in ("solve_median_s", "solve_p99_s", "solve_max_s"))
            failed = missed_targets(group, fs, lambda r, f: misses(
                f, base.get(r["seed"]) if controller != "baseline" else None))
            lines.append(
                f"| {case} | {controller} | {_stat([f['bhp_rmse_pa'] for f in fs], PA_PER_BAR, 2)} | "
                f"{_stat([f['bhp_time_outside_s'] for f in fs], 1.0, 1)} | "
                f"{_stat([f['bhp_time_outside_settled_s'] for f in fs], 1.0, 1)} | "
                f"{_stat([f['bhp_worst_excursion_pa'] for f in fs], PA_PER_BAR, 2)} | "
                f"{_legs(group, 'leg_out_s')} | {_legs(group, 'leg_in_s')} | "
                f"{_stat([f['max_string_speed_mps'] for f in fs], 1.0, 2)} | "
                f"{_stat([f['trip_overshoot_m'] for f in fs], 1.0, 2)} | "
                f"{_stat([f['bhp_estimate_rmse_pa'] for f in fs], PA_PER_BAR, 2)} | {solver} | "
                f"{_fallbacks(group, fs)} | {failed} |")
    lines += ["", "Targets per run (issue: the controller that beats conventional MPD): BHP RMSE "
              "<= 0.7 bar and below the baseline's on the same seed, <= 5 s outside the band "
              "after the first 30 s, worst excursion <= 1 bar, legs <= 57 s, fallbacks < 1 % "
              "of solves, BHP estimate RMSE <= 0.4 bar, solve time median <= 10 ms and p99 <= "
              "30 ms (the solver column: the worst seed's; on this 2-core machine, shared with "
              "the graph's other processes).", "",
              "## Table 7 form, NMPC (ours, mean over seeds | paper)", "",
              "| case | configuration | block mean error [m] | BHP mean error [bar] | "
              "block RMSE [m] | BHP RMSE [bar] |",
              "| --- | --- | --- | --- | --- | --- |"]
    for case in (*TRIP_CASES, *STEP_CASES):
        group = by.get((case, "nmpc"))
        if not group:
            continue
        s = [r["summary"] for r in group]
        ours = (np.mean([x["block_position_mean_error_m"] for x in s]),
                np.mean([x["bhp_mean_error_pa"] for x in s]) / PA_PER_BAR,
                np.mean([x["block_position_rmse_m"] for x in s]),
                np.mean([x["bhp_rmse_pa"] for x in s]) / PA_PER_BAR)
        paper = PAPER.get(case, (None,) * 4)
        cells = [f"{o:.3f} \\| {'n/a' if p is None else f'{p:.3f}'}" for o, p in zip(ours, paper)]
        scenario, overrides = load_scenario(runs.scenario_path(case))
        configuration = overrides.get("nmpc", {}).get("configuration", "")
        lines.append(f"| {case} | {configuration} | " + " | ".join(cells) + " |")
    for case in STEP_CASES:
        group = by.get((case, "nmpc"))
        if group:
            fs = [figures(r["summary"]) for r in group]
            lines += ["", f"{case} (set-point steps, NMPC): BHP RMSE "
                      f"{_stat([f['bhp_rmse_pa'] for f in fs], PA_PER_BAR, 2)} bar, outside the "
                      f"band {_stat([f['bhp_time_outside_s'] for f in fs], 1.0, 1)} s, worst "
                      f"excursion {_stat([f['bhp_worst_excursion_pa'] for f in fs], PA_PER_BAR, 2)}"
                      " bar (mean / worst over seeds)."]
    lines += fault_section(by)
    lines += multi_stand_section.section(by, CONTROLLERS)
    lines += mismatch_section(mismatched)
    lines += multi_stand_section.mismatch_section(mismatched, CONTROLLERS)
    if plot_name:
        lines += ["", f"![One Case 2 trip per controller]({plot_name})"]
    lines += ["", f"Seeds: {', '.join(str(s) for s in seeds)}. Run directories (MCAP, plots, "
              "logs; not committed): " + ", ".join(f"`{Path(r['run_dir']).name}`" for r in every),
              ""]
    return "\n".join(lines + provenance(every))


def provenance(rows: list[dict]) -> list[str]:
    """Which commit each case's rows were measured with (rows.commit; none recorded:
    measured before rows recorded it), per case and plant."""
    groups: dict[tuple, set] = {}
    for r in rows:
        plant = "on a plant that is not the model" if r.get("mismatch") else "on the model's plant"
        groups.setdefault((r["case"], plant), set()).add(r.get("commit") or "not recorded")
    return ["## Measured with", "", "| case | plant | commit(s) |", "| --- | --- | --- |",
            *(f"| {case} | {plant} | {', '.join(sorted(commits))} |"
              for (case, plant), commits in sorted(groups.items())), ""]


# The targets on a plant that is not the model (SI), checked per run; RMSE after the
# first SETTLE_S, like the band time (the plant starts at its own steady state, off the
# reference by the model's error: no controller can undo that instant).
MISMATCH_TARGETS = {"bhp_rmse_settled_pa": 0.9e5, "bhp_time_outside_settled_s": 10.0,
                    "trip_leg_s": 62.0, "fallback_share": 0.01, "bhp_estimate_rmse_pa": 0.5e5}
MISMATCH_MEAN_RMSE_PA = 0.6e5


ESTIMATE_JUDGED = "(estimate)"      # report.summarise's detection kinds judged on the UKF's
                                    # influx estimate (NMPC2's), not alarms the rig raised


def false_alarms(s: dict, estimate: bool = False) -> int:
    """Kick and losses alarms the protection raised with no formation flow behind them
    (``estimate``: instead, those the UKF's influx estimate gives judged with the
    detector's threshold; no alarm is raised on them)."""
    return sum((d or {}).get("false_alarms", 0) for kind, d in s.get("detection", {}).items()
               if (ESTIMATE_JUDGED in kind) == estimate)


def _alarms(group: list[dict]) -> str:
    """The false alarms of a group of runs, with the influx estimate's beside them."""
    rig = sum(false_alarms(r["summary"]) for r in group)
    judged = sum(false_alarms(r["summary"], estimate=True) for r in group)
    return f"{rig}" + (f" (+{judged} influx estimate)" if judged else "")


def mismatch_misses(f: dict, s: dict, others: list[dict]) -> list[str]:
    """The mismatch targets an NMPC run misses (others: the other controllers' summaries of
    the same case, member and seed)."""
    out = [k for k in ("bhp_rmse_settled_pa", "bhp_time_outside_settled_s",
                       "bhp_estimate_rmse_pa", "fallback_share")
           if f.get(k) is not None and f[k] > MISMATCH_TARGETS[k]]
    out += [k for k in ("leg_out_s", "leg_in_s")
            if f[k] is None or f[k] > MISMATCH_TARGETS["trip_leg_s"]]
    if len(others) < len(CONTROLLERS) - 1:
        out.append("no baseline runs to compare")
    elif any(s.get("bhp_rmse_settled_pa", math.inf) >= o.get("bhp_rmse_settled_pa", math.inf)
             for o in others):
        out.append("RMSE not below both baselines")
    if false_alarms(s):
        out.append("false alarms")
    if false_alarms(s, estimate=True):
        out.append("influx estimate false alarms")
    return out


def mismatch_section(rows: list[dict]) -> list[str]:
    """The trip cases on plants that are not the model: a row per case, member and
    controller (mean / worst over the seeds), then each controller over the suite."""
    if not rows:
        return []
    by = {}
    for r in rows:
        by.setdefault((r["case"], r["mismatch"], r["controller"]), []).append(r)
    lines = ["", "## On a plant that is not the model (mean / worst over seeds)", "",
             "The plant's mud, choke and hole differ from config/well.yaml by a member of "
             "config/mismatch.yaml (docs/mismatch.md); the estimator, the controllers and the "
             "protection read well.yaml as it is. *Settled*: after the first 30 s (the plant "
             "starts at its own steady state, off the reference by the model's error). "
             "Targets per NMPC run: settled BHP RMSE <= 0.9 bar (mean over the suite <= 0.6) "
             "and below both other controllers', <= 10 s outside the band settled, legs <= 62 "
             "s, fallbacks < 1 %, BHP estimate RMSE <= 0.5 bar, no false alarm (the "
             "protection's; *influx estimate*: the UKF's influx estimate, where the case's "
             "estimator has one, judged with the detector's threshold, which raises no alarm "
             "but is a miss too).", "",
             "| case | plant | controller | BHP RMSE [bar] | settled [bar] | outside, settled [s] | "
             "worst excursion [bar] | leg out [s] | leg in [s] | BHP estimate RMSE [bar] | "
             "false alarms | fallbacks | NMPC runs missing a target |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    members = list(dict.fromkeys(r["mismatch"] for r in rows))
    for case in TRIP_CASES:
        for member in members:
            for controller in CONTROLLERS:
                group = by.get((case, member, controller))
                if not group:
                    continue
                fs = [figures(r["summary"]) for r in group]
                failed = "n/a"
                if controller == "nmpc":
                    failing = []
                    for r, f in zip(group, fs):
                        others = [o["summary"] for c in CONTROLLERS if c != "nmpc"
                                  for o in by.get((case, member, c), []) if o["seed"] == r["seed"]]
                        m = mismatch_misses(f, r["summary"], others)
                        if m:
                            failing.append(f"seed {r['seed']}: {', '.join(m)}")
                    failed = "; ".join(failing) or "none"
                lines.append(
                    f"| {case} | {member} | {controller} | "
                    f"{_stat([f['bhp_rmse_pa'] for f in fs], PA_PER_BAR, 2)} | "
                    f"{_stat([f['bhp_rmse_settled_pa'] for f in fs], PA_PER_BAR, 2)} | "
                    f"{_stat([f['bhp_time_outside_settled_s'] for f in fs], 1.0, 1)} | "
                    f"{_stat([f['bhp_worst_excursion_pa'] for f in fs], PA_PER_BAR, 2)} | "
                    f"{_legs(group, 'leg_out_s')} | {_legs(group, 'leg_in_s')} | "
                    f"{_stat([f['bhp_estimate_rmse_pa'] for f in fs], PA_PER_BAR, 2)} | "
                    f"{_alarms(group)} | {_fallbacks(group, fs)} | "
                    f"{failed} |")
    lines += ["", "Over the suite (every member and seed):", "",
              "| case | controller | settled BHP RMSE mean / worst [bar] | outside, settled "
              "mean / worst [s] | legs not reached | false alarms |",
              "| --- | --- | --- | --- | --- | --- |"]
    for case in TRIP_CASES:
        for controller in CONTROLLERS:
            group = [r for m in members for r in by.get((case, m, controller), [])]
            if not group:
                continue
            fs = [figures(r["summary"]) for r in group]
            missing = sum(f[k] is None for f in fs for k in ("leg_out_s", "leg_in_s"))
            lines.append(f"| {case} | {controller} | "
                         f"{_stat([f['bhp_rmse_settled_pa'] for f in fs], PA_PER_BAR, 2)} | "
                         f"{_stat([f['bhp_time_outside_settled_s'] for f in fs], 1.0, 1)} | "
                         f"{missing} of {2 * len(fs)} | {_alarms(group)} |")
    return lines


def _detection(d: dict | None) -> str:
    if not d or d["onset_s"] is None:
        return "no influx" if not d or not d["false_alarms"] else f"{d['false_alarms']} false"
    if d["delay_s"] is None:
        return "not detected"
    return (f"{d['delay_s']:.1f} s, {d['volume_at_detection_m3'] * L_PER_M3:.0f} L"
            + (f", {d['false_alarms']} false" if d["false_alarms"] else ""))


def fault_section(by: dict) -> list[str]:
    """The fault scenarios' table: what happened, what the rig did, the figures."""
    rows = [(case, c, by[(case, c)]) for case in FAULT_CASES for c in CONTROLLERS
            if (case, c) in by]
    if not rows:
        return []
    lines = ["", "## Faults, kicks and losses (Case 2's trip, first seed of each)", "",
             "What each scenario does is in its file (config/scenarios); every event is on "
             "/rig/events in the recording. *Under pore*: time BHP spent under the pore "
             "pressure in force and the worst underbalance; *kick / losses detection*: the "
             "protection's flow-balance alarm after the truth's onset and the volume in (or "
             "lost) by then.", "",
             "| scenario | controller | events | BHP RMSE [bar] | worst excursion [bar] | "
             "under pore [s] / worst [bar] | over fracture [s] | influx / losses [L] | "
             "kick detection | losses detection | legs out / in [s] | fallbacks |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, controller, group in rows:
        s = group[0]["summary"]
        scenario, _ = load_scenario(runs.scenario_path(case))
        events = "; ".join(f"{e.time_s:g} s {e.describe()}" for e in scenario.events)
        legs = " / ".join("not reached" if t is None else f"{t:.0f}"
                          for _, t in s.get("trip_legs", [])) or "none"
        detection = s.get("detection", {})
        lines.append(
            f"| {case} | {controller} | {events} | {s['bhp_rmse_pa'] / PA_PER_BAR:.2f} | "
            f"{s['bhp_worst_excursion_pa'] / PA_PER_BAR:.2f} | "
            f"{s.get('bhp_under_pore_s', 0.0):.1f} / "
            f"{s.get('worst_underbalance_pa', 0.0) / PA_PER_BAR:.2f} | "
            f"{s.get('bhp_over_fracture_s', 0.0):.1f} | "
            f"{s.get('influx_volume_m3', 0.0) * L_PER_M3:.0f} / "
            f"{s.get('loss_volume_m3', 0.0) * L_PER_M3:.0f} | "
            f"{_detection(detection.get('kick'))} | {_detection(detection.get('losses'))} | "
            f"{legs} | {s.get('fallbacks', 'n/a')} |")
    return lines


def plot_trips(rows: list[dict], case: str, out: Path) -> Path | None:
    """BHP error, choke dp and string position of the case's first-seed run per controller."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    chosen = {}
    for r in rows:
        if r["case"] == case and r["controller"] not in chosen:
            chosen[r["controller"]] = r
    if not chosen:
        return None
    fig, axes = plt.subplots(3, len(chosen), figsize=(5 * len(chosen), 8), sharex=True,
                             sharey="row", squeeze=False)
    for col, (controller, r) in enumerate(chosen.items()):
        s = report.load_series(next(Path(r["run_dir"]).glob("*.mcap")))
        t, bhp = s.get("bhp")
        _, pos = s.get("position")
        _, dp = s.get("choke_dp")
        ref, band, target = report.references(s, t)
        ax = axes[:, col]
        ax[0].plot(t, (bhp - ref) / PA_PER_BAR, lw=0.8)
        ax[0].fill_between(t, -band / PA_PER_BAR, band / PA_PER_BAR, color="g", alpha=0.12)
        ax[0].set_title(f"{case}, {controller}, seed {r['seed']}")
        ax[1].plot(t, dp / PA_PER_BAR, lw=0.8)
        ax[2].plot(t, pos, lw=0.8)
        ax[2].plot(t, target, "k--", lw=0.6)
        ax[2].set_xlabel("time [s]")
    axes[0, 0].set_ylabel("BHP - reference [bar]")
    axes[1, 0].set_ylabel("choke dp [bar]")
    axes[2, 0].set_ylabel("string position [m]")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def suite_members(spec: str) -> list[str]:
    """``suite`` (every member of config/mismatch.yaml) or a comma list of members, checked."""
    members = list(load_suite(runs.ROOT / "config")[0])
    asked = members if spec == "suite" else [m.strip() for m in spec.split(",") if m.strip()]
    for name in asked:
        resolve(name, runs.ROOT / "config", "--mismatch")
    return asked


def _picture(output: Path) -> Path:
    """The page's plot of one Case 2 trip per controller, beside it."""
    return output.with_name(output.stem + "-case2.png")


def render(output: Path) -> int:
    """The page again from its JSON table (the runs' figures), running nothing."""
    rows = json.loads(output.with_suffix(".json").read_text())
    picture = _picture(output)
    made = (f"{datetime.now():%Y-%m-%d %H:%M} (`--render`: the page from the runs' JSON "
            "table, the runs as listed at the end)")
    output.write_text(markdown(rows, picture.name if picture.exists() else None, made))
    print(f"[compare] wrote {output} from {output.with_suffix('.json').name}")
    return 0


def _key(row_or_item) -> tuple:
    """(case, controller, seed, mismatch) of a table row or a planned run."""
    if isinstance(row_or_item, dict):
        return (row_or_item["case"], row_or_item["controller"], row_or_item["seed"],
                row_or_item.get("mismatch"))
    case, controller, seed, *rest = row_or_item
    return case, controller, seed, rest[0] if rest else None


def main(cases, output: Path, seeds: int = len(SEED_OFFSETS),
         controllers=CONTROLLERS, mismatch: str | None = None, resume: bool = False) -> int:
    """Run the plan and write the page. ``resume``: a planned run whose row the table
    already holds is not run again (its row is kept)."""
    table = output.with_suffix(".json")
    old = json.loads(table.read_text()) if table.exists() else []
    if mismatch is not None:
        cases = cases or TRIP_CASES
        items = plan_mismatch(cases, controllers, seeds, suite_members(mismatch))
    else:
        cases = cases or (*TRIP_CASES, *STEP_CASES, *FAULT_CASES, *MULTI_STAND_CASES)
        items = plan(cases, controllers, seeds)
    done = {_key(r): r for r in old} if resume else {}
    kept = [done[_key(i)] for i in items if _key(i) in done]
    if kept:
        print(f"[compare] {len(kept)} of the {len(items)} runs are in {table.name}: kept", flush=True)
    fresh = run_all([i for i in items if _key(i) not in done])
    rows = kept + fresh
    output.parent.mkdir(parents=True, exist_ok=True)
    if old:      # keep every row the plan did not run now (other cases, controllers, seeds,
        planned = {_key(i) for i in items}                  # plants)
        rows = [r for r in old if _key(r) not in planned] + rows
    table.write_text(json.dumps([{k: v for k, v in r.items()} for r in rows], indent=1))
    picture = _picture(output)
    if any(r["case"] == "case2" for r in fresh) and mismatch is None:   # from runs made now
        picture = plot_trips([r for r in fresh if not r.get("mismatch")], "case2", picture)
    elif not picture.exists():      # kept rows: their recordings may be gone, their plot stays
        picture = None
    output.write_text(markdown(rows, picture.name if picture else None))
    print(f"[compare] wrote {output}")
    return 0
