"""``rig sweep``: one scenario through the whole graph on many seeds (under one or more
controllers, with configuration overrides), the runs spread over a local process pool or
a Dask cluster (drill_studies.batch), their report figures aggregated over the seeds
(mean, standard deviation, worst) into a Markdown table and a plot.

The output directory holds ``scenario.yaml`` (the scenario run: the file asked for with the
``--set`` overrides merged into its ``overrides``, which every node of a run loads), one
folder per run (``<controller>-seed<N>/``, the run directory inside), ``sweep.json`` (the
index: settings and a row per run), ``sweep.md`` and ``sweep.png``. Running the same command
again with the same ``--output`` skips every run whose summary.json exists (resume); other
settings (scenario or overrides) in that directory are refused. The figures are
``rig compare``'s (compare.figures), SI in the index, bar and L/min in the table. With
``--mismatch-draws N`` every (controller, seed) runs on N plants that are not the model,
draws 0..N-1 of config/mismatch.yaml's distributions (drill_core.mismatch.draw: the same
draw on every machine; folders ``<controller>-seed<N>-draw<i>/``), aggregated with the seeds.
"""
from __future__ import annotations

import json
import math
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
import yaml

from drill_bringup import runs
from drill_studies import batch, compare
from drill_studies.batch import RunSpec
from drill_core.config import ConfigError, parse_settings
from drill_ros.graph import CONTROLLERS
from drill_core.scenario import load_scenario_config, scenario_kind
from drill_core.units import LPM_PER_M3S, PA_PER_BAR
from drill_core.yaml_files import dotted_items, load_yaml, merge

SCENARIO_FILE = "scenario.yaml"
INDEX_FILE = "sweep.json"
TABLE_FILE = "sweep.md"
PLOT_FILE = "sweep.png"
# Display edge: a figure's SI key suffix -> (unit shown, factor from SI); solve times in ms.
SUFFIXES = (("_pa", "bar", 1.0 / PA_PER_BAR), ("_m3s", "L/min", LPM_PER_M3S),
            ("_share", "%", 100.0), ("_mps", "m/s", 1.0), ("_s", "s", 1.0), ("_m", "m", 1.0))
LABELS = {"bhp_rmse_pa": "BHP RMSE", "bhp_rmse_settled_pa": "BHP RMSE, settled",
          "bhp_time_outside_s": "outside band",
          "bhp_time_outside_settled_s": "outside band, settled",
          "bhp_worst_excursion_pa": "worst excursion", "leg_out_s": "leg out",
          "leg_in_s": "leg in", "max_string_speed_mps": "max string speed",
          "trip_overshoot_m": "past target", "bhp_estimate_rmse_pa": "BHP estimate RMSE",
          "fallback_share": "fallbacks / solves", "fallbacks": "fallbacks",
          "solve_median_s": "solve median", "solve_p99_s": "solve p99",
          "solve_max_s": "solve max", "false_alarms": "false alarms"}


def display(key: str) -> tuple[str, float]:
    """(unit shown, factor from SI) of a figure, from its key's unit suffix."""
    if key.startswith("solve_"):
        return "ms", 1.0e3
    for suffix, unit, factor in SUFFIXES:
        if key.endswith(suffix):
            return unit, factor
    return "1", 1.0


def run_figures(summary: dict) -> dict:
    """The figures a sweep aggregates: compare's, the fallback count and the protection's
    false alarms (every alarm of a run without formation flow)."""
    return {**compare.figures(summary), "fallbacks": summary.get("fallbacks"),
            "false_alarms": compare.false_alarms(summary)}


def command(index: dict) -> str:
    """The command that makes (and, run again, re-renders) this sweep."""
    parts = ["scripts/rig sweep", Path(index["scenario_file"]).stem,
             f"--seeds {len(index['seeds'])}", f"--first-seed {index['seeds'][0]}",
             "--controller " + " ".join(index["controllers"])]
    if index.get("mismatch_draws"):
        parts.append(f"--mismatch-draws {index['mismatch_draws']}")
    parts += [f"--set {key}={value}" for key, value in dotted_items(index["overrides"])]
    return " ".join(parts)


def sweep_scenario(source: Path, sets, output: Path) -> Path:
    """Write the scenario to run into ``output`` (``--set`` overrides merged into its
    ``overrides``), checked like any scenario; refuse other settings in a used directory."""
    if scenario_kind(source) != "tripping":
        raise ConfigError(f"{source}: a sweep runs tripping scenarios (this one is drilling)")
    data = load_yaml(source)
    overrides = parse_settings(sets)
    if overrides:
        data = {**data, "overrides": merge(data.get("overrides") or {}, overrides)}
    text = yaml.safe_dump(data, sort_keys=False)
    path = output / SCENARIO_FILE
    if path.exists() and path.read_text() != text:
        raise ConfigError(f"{output} holds a sweep of other settings ({path} differs from "
                          f"{source} with these --set overrides); use another --output")
    created = not output.exists()
    output.mkdir(parents=True, exist_ok=True)
    staged = output / f".{SCENARIO_FILE}"
    staged.write_text(text)
    try:
        load_scenario_config(staged, runs.ROOT / "config")
    except ConfigError as err:
        staged.unlink()
        if created:
            output.rmdir()
        raise ConfigError(f"--set {' '.join(sets)}: "
                          + str(err).replace(str(staged), f"{source} with --set")) from None
    staged.replace(path)
    return path


def plan(case: str, scenario: Path, controllers, seeds: int, first_seed: int,
         output: Path, mismatch_draws: int = 0) -> list[RunSpec]:
    """Every (controller, seed) run of the sweep, seeds first_seed .. first_seed+seeds-1;
    with ``mismatch_draws`` N, each on the plants of draws 0..N-1."""
    if seeds < 1:
        raise ConfigError(f"--seeds: value {seeds} must be at least 1")
    if mismatch_draws < 0:
        raise ConfigError(f"--mismatch-draws: value {mismatch_draws} must be at least 0")
    plants = [(f"draw:{i}", f"-draw{i}") for i in range(mismatch_draws)] or [(None, "")]
    return [RunSpec(case, str(scenario), controller, seed,
                    str(output / f"{controller}-seed{seed}{tag}"), mismatch=mismatch)
            for controller in controllers for seed in range(first_seed, first_seed + seeds)
            for mismatch, tag in plants]


def finished(spec: RunSpec) -> Path | None:
    """The newest run directory of a spec with a summary.json (None: not yet run)."""
    done = sorted(Path(spec.runs_dir).glob("*/summary.json"), key=lambda p: p.parent.name)
    return done[-1].parent if done else None


def aggregate(rows: list[dict]) -> dict[str, dict[str, dict]]:
    """Per controller, per figure: mean, standard deviation (over the seeds), worst
    (largest: every figure is a loss) and how many runs had none (a leg not reached)."""
    by: dict[str, list[dict]] = {}
    for row in rows:
        if row["ok"]:
            by.setdefault(row["controller"], []).append(run_figures(row["summary"]))
    out = {}
    for controller, figs in by.items():
        stats = {}
        for key in figs[0]:
            values = [f[key] for f in figs if f[key] is not None]
            stats[key] = {"mean": float(np.mean(values)) if values else None,
                          "std": float(np.std(values)) if values else None,
                          "worst": float(max(values)) if values else None,
                          "runs": len(values), "missing": len(figs) - len(values)}
        out[controller] = stats
    return out


def first_line(text: str) -> str:
    return (text or "no message").splitlines()[0]


def _cell(stat: dict, factor: float) -> str:
    if stat["mean"] is None:
        return f"n/a ({stat['missing']} none)"
    digits = 3 if max(abs(stat["mean"]), abs(stat["worst"])) * factor < 10 else 1
    text = (f"{stat['mean'] * factor:.{digits}f} ± {stat['std'] * factor:.{digits}f} "
            f"(worst {stat['worst'] * factor:.{digits}f})")
    return text + (f", {stat['missing']} none" if stat["missing"] else "")


def markdown(index: dict, stats: dict, workers: int = 1, picture: str | None = None) -> str:
    """The sweep's page: a row per figure, a column per controller, the plot and the
    command that made it."""
    controllers = list(stats)
    rows = index["runs"]
    failed = [r for r in rows if not r["ok"]]
    lines = [f"# Sweep: {index['scenario']}", "",
             f"Made by `rig sweep` on {datetime.now():%Y-%m-%d %H:%M}: seeds "
             f"{', '.join(str(s) for s in index['seeds'])}"
             + (f", each on mismatch draws 0..{index['mismatch_draws'] - 1} of "
                "config/mismatch.yaml (a plant that is not the model)"
                if index.get("mismatch_draws") else "") + ", overrides "
             f"{json.dumps(index['overrides']) if index['overrides'] else 'none'}; "
             f"{len(rows) - len(failed)} of {len(rows)} runs finished. Each cell: mean ± "
             "standard deviation over the seeds (worst); *none*: runs without the figure "
             "(a trip leg not reached). "
             + (f"{workers} runs at a time shared the cores: the solve times are inflated."
                if workers > 1 else "One run at a time: the solve times are this machine's."),
             "",
             "| figure | " + " | ".join(controllers) + " |",
             "| --- |" + " --- |" * len(controllers)]
    keys = list(next(iter(stats.values()))) if stats else []
    for key in keys:
        unit, factor = display(key)
        lines.append(f"| {LABELS.get(key, key)} [{unit}] | "
                     + " | ".join(_cell(stats[c][key], factor) for c in controllers) + " |")
    if failed:
        lines += ["", "Failed runs:", ""] + [f"- {r['controller']} seed {r['seed']}"
                                            f"{' ' + r['mismatch'] if r.get('mismatch') else ''}: "
                                            f"{first_line(r['message'])}" for r in failed]
    if picture:
        lines += ["", f"![Each figure per controller: box over the runs, one dot per run]"
                      f"({picture})"]
    lines += ["", f"Command: `{command(index)}`"]
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> Path | None:
    """A strip of the seeds' values with their box, per figure, per controller."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ok = [r for r in rows if r["ok"]]
    if not ok:
        return None
    controllers = list(dict.fromkeys(r["controller"] for r in ok))
    keys = [k for k in run_figures(ok[0]["summary"])
            if any(run_figures(r["summary"])[k] is not None for r in ok)]
    cols = 4
    fig, axes = plt.subplots(math.ceil(len(keys) / cols), cols, squeeze=False,
                             figsize=(4 * cols, 3 * math.ceil(len(keys) / cols)))
    for ax, key in zip(axes.flat, keys):
        unit, factor = display(key)
        data = [[run_figures(r["summary"])[key] * factor for r in ok
                 if r["controller"] == c and run_figures(r["summary"])[key] is not None]
                for c in controllers]
        ax.boxplot([d or [math.nan] for d in data], tick_labels=controllers, widths=0.5)
        for i, values in enumerate(data, start=1):
            ax.plot([i] * len(values), values, "o", ms=4, alpha=0.6)
        ax.set_title(f"{LABELS.get(key, key)} [{unit}]", fontsize=9)
        ax.tick_params(labelsize=8)
    for ax in list(axes.flat)[len(keys):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def write_index(output: Path, settings: dict, rows: list[dict]) -> dict:
    index = {**settings, "runs": rows}
    (output / INDEX_FILE).write_text(json.dumps(index, indent=1))
    return index


def sweep(case: str, seeds: int, first_seed: int | None = None, controllers=(), sets=(),
          workers: int = 1, cluster: str | None = None, output: Path | None = None,
          run=batch.run_one, say=print, mismatch_draws: int = 0) -> int:
    """Plan, run what is not done yet, aggregate; 0 when every run finished."""
    source = runs.scenario_path(case)
    scenario, _ = load_scenario_config(source, runs.ROOT / "config")
    output = (output or runs.ROOT / "runs" /
              f"sweep-{scenario.name}-{datetime.now():%Y%m%d-%H%M%S}").resolve()
    controllers = list(dict.fromkeys(controllers or [scenario.controller]))
    first = scenario.seed if first_seed is None else first_seed
    specs = plan(case, output / SCENARIO_FILE, controllers, seeds, first, output, mismatch_draws)
    sweep_scenario(source, sets, output)
    settings = {"scenario": scenario.name, "scenario_file": str(source),
                "overrides": parse_settings(sets), "controllers": controllers,
                "seeds": list(range(first, first + seeds)), "mismatch_draws": mismatch_draws}
    rows = {spec: batch.result_row(spec, finished(spec)) for spec in specs if finished(spec)}
    todo = [spec for spec in specs if spec not in rows]
    say(f"[sweep] {scenario.name}: {len(specs)} runs, {len(rows)} done before, {len(todo)} to "
        f"run ({f'cluster {cluster}' if cluster else f'{workers} worker(s)'}); {output}")

    def done(row: dict) -> None:
        spec = next(s for s in todo if (s.controller, s.seed, s.mismatch)
                    == (row["controller"], row["seed"], row.get("mismatch")))
        rows[spec] = row
        write_index(output, settings, [rows[s] for s in specs if s in rows])
        outcome = (f"BHP RMSE {row['summary']['bhp_rmse_pa'] / PA_PER_BAR:.3f} bar" if row["ok"]
                   else f"FAILED: {first_line(row['message'])}")
        plant = f" {row['mismatch']}" if row.get("mismatch") else ""
        say(f"[sweep] {row['controller']} seed {row['seed']}{plant}: {outcome} "
            f"({len(rows)}/{len(specs)})")

    batch.execute(todo, run, workers, cluster, done)
    ordered = [rows[s] for s in specs]
    index = write_index(output, settings, ordered)
    stats = aggregate(ordered)
    picture = plot(ordered, output / PLOT_FILE)
    page = markdown(index, stats, workers, picture.name if picture else None)
    (output / TABLE_FILE).write_text(page)
    say(page)
    say(f"[sweep] wrote {output / TABLE_FILE}" + (f", {picture}" if picture else ""))
    return 0 if all(r["ok"] for r in ordered) else 1


def add_arguments(parser) -> None:
    """``rig sweep``'s options."""
    parser.add_argument("scenario", help="name under config/scenarios or a path")
    parser.add_argument("--seeds", type=int, required=True, help="number of seeds")
    parser.add_argument("--first-seed", type=int, help="default: the scenario's seed")
    parser.add_argument("--controller", nargs="+", choices=CONTROLLERS,
                        help="default: the scenario's own")
    parser.add_argument("--set", action="append", default=[], metavar="FILE.KEY=VALUE",
                        help="configuration override, e.g. nmpc.bhp_bias_gain=0 (repeatable)")
    parser.add_argument("--mismatch-draws", type=int, default=0, metavar="N",
                        help="every run on N plants that are not the model: draws 0..N-1 of "
                             "config/mismatch.yaml (docs/mismatch.md)")
    parser.add_argument("--workers", type=int, default=1,
                        help="graphs at once in a local process pool (default 1)")
    parser.add_argument("--cluster", metavar="ADDRESS",
                        help="a Dask scheduler, tcp://host:port: run there instead")
    parser.add_argument("--output", type=Path,
                        help="results directory (default runs/sweep-<scenario>-<stamp>); "
                             "the same one again resumes")


def main(args) -> int:
    if args.workers < 1:
        print(f"[rig] sweep: --workers: value {args.workers} must be at least 1", file=sys.stderr)
        return 2
    return sweep(args.scenario, args.seeds, args.first_seed, args.controller or (), args.set,
                 args.workers, args.cluster, args.output, mismatch_draws=args.mismatch_draws)
