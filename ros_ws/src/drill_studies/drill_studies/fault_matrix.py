"""``rig compare --fault-matrix``: each actuator and sensor fault, alone and in pairs, in
the pull-out, at rest and in the run-in of Case 2's trip, under every controller, through
the whole graph in fast mode; per cell the time BHP spent under the pore pressure and over
the fracture pressure (docs/fault-matrix.md, rendered from its JSON table, which is written
after every run so that an interrupted matrix resumes where it stopped).

A cell is a short scenario made from Case 2 (its well, mud, setpoints and seed): the
phase's schedule and the fault's events at the phase's fault time (both faults of a pair
at once). The cells' scenario files go to runs/fault-matrix/, so each run can be re-run by
hand (``rig run FILE --controller C``).
"""
from __future__ import annotations

import itertools
import json
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import yaml

from drill_bringup import runs
from drill_studies import batch
from drill_studies.compare import CONTROLLERS, false_alarms
from drill_core.config import load_rig
from drill_core.events import EVENT_KINDS
from drill_core.units import L_PER_M3, PA_PER_BAR

BASE_SCENARIO = "case2"
SPAN_S = 20.0                     # how long a sensor fault or a stuck pump / choke lasts
BRAKE_S = 5.0                     # a drawworks stuck with its brake set
# name -> the fault's events, times from the fault's start
FAULTS = {
    "choke stuck": ({"kind": "stuck", "target": "choke", "duration_s": SPAN_S},),
    "drawworks stuck": ({"kind": "stuck", "target": "drawworks", "duration_s": BRAKE_S},),
    "BPP stuck": ({"kind": "stuck", "target": "bpp", "duration_s": SPAN_S},),
    "mud pump stuck": ({"kind": "stuck", "target": "mud_pump", "duration_s": SPAN_S},),
    "BPP trip": ({"kind": "trip", "target": "bpp"},),
    "mud pump trip": ({"kind": "trip", "target": "mud_pump"},),
    "BHP dropout": ({"kind": "dropout", "target": "bhp_pa", "duration_s": SPAN_S},),
    "BHP frozen": ({"kind": "frozen", "target": "bhp_pa", "duration_s": SPAN_S},),
    "BHP bias +3 bar": ({"kind": "bias", "target": "bhp_pa", "value": 3.0e5, "duration_s": SPAN_S},),
    "choke dp frozen": ({"kind": "frozen", "target": "choke_dp_pa", "duration_s": SPAN_S},),
    "return flow frozen": ({"kind": "frozen", "target": "return_flow_m3s", "duration_s": SPAN_S},),
    "block position dropout": ({"kind": "dropout", "target": "block_position_m", "duration_s": BRAKE_S},),
}
ACTUATOR_FAULTS = tuple(name for name, events in FAULTS.items()
                        if EVENT_KINDS[events[0]["kind"]].owner == "actuator")


@dataclass(frozen=True)
class Phase:
    """A trip phase: the block targets from the Case 2 start (time s, target m), when the
    fault comes and when the cell ends."""
    targets: tuple[tuple[float, float], ...]
    fault_time_s: float
    duration_s: float


PHASES = {
    "pull-out": Phase(((5.0, 28.0),), 20.0, 120.0),            # at speed from ~10 s
    "rest": Phase((), 20.0, 90.0),
    "run-in": Phase(((5.0, 28.0), (70.0, 0.0)), 85.0, 170.0),  # out by ~65 s, in at speed from ~75 s
}


PAIRS = ("none", "actuators", "all")      # which pairs run in every phase
BOUND = "bound"       # the controller of drill_studies.fault_bound's rows (in process)


def cells(pairs: str = "actuators") -> list[tuple[str, tuple[str, ...]]]:
    """(phase, faults) of every cell: each fault alone in each phase, then pairs in each
    phase: ``actuators`` (every pair of actuator faults), ``all`` (every pair; the pairs of
    actuator faults first) or ``none``."""
    if pairs not in PAIRS:
        raise ValueError(f"pairs {pairs!r}: expected one of {', '.join(PAIRS)}")
    def of_actuators(pair: tuple[str, ...]) -> bool:
        return set(pair) <= set(ACTUATOR_FAULTS)
    alone = [(phase, (fault,)) for phase in PHASES for fault in FAULTS]
    both = [(phase, pair) for phase in PHASES for pair in itertools.combinations(FAULTS, 2)
            if pairs == "all" or (pairs == "actuators" and of_actuators(pair))]
    return alone + sorted(both, key=lambda cell: not of_actuators(cell[1]))


def cell_name(phase: str, faults: tuple[str, ...]) -> str:
    words = [phase, *faults]
    return "fm-" + "+".join(w.replace(" ", "_").replace("+", "p") for w in words).lower()


def cell_scenario(base: dict, phase: str, faults: tuple[str, ...]) -> dict:
    """The scenario of one cell: Case 2's well and start, the phase's schedule, the faults."""
    p = PHASES[phase]
    events = [{"time_s": p.fault_time_s, **event} for fault in faults for event in FAULTS[fault]]
    schedule = [dict(base["schedule"][0])] + [
        {"time_s": t, "block_position_target_m": target} for t, target in p.targets]
    return {**{k: v for k, v in base.items() if k not in ("schedule", "events")},
            "name": cell_name(phase, faults),
            "description": f"{' and '.join(faults)} in the {phase} of Case 2's trip (fault matrix)",
            "duration_s": p.duration_s, "schedule": schedule, "events": events}


def base_scenario() -> dict:
    """Case 2's scenario file as a dict: what every cell is made from."""
    return yaml.safe_load(runs.scenario_path(BASE_SCENARIO).read_text())


def planned_cells(pairs: str = "actuators", with_fault: Sequence[str] = ()
                  ) -> list[tuple[str, tuple[str, ...]]]:
    """The cells of ``pairs`` (``with_fault``: only those with each of these faults)."""
    return [(phase, faults) for phase, faults in cells(pairs)
            if all(fault in faults for fault in with_fault)]


def write_cells(directory: Path, planned: list[tuple[str, tuple[str, ...]]], base: dict
                ) -> list[tuple[str, tuple[str, ...], Path]]:
    """Each planned cell's scenario file in ``directory``: (phase, faults, its path)."""
    directory.mkdir(parents=True, exist_ok=True)
    out = []
    for phase, faults in planned:
        scenario = cell_scenario(base, phase, faults)
        path = directory / f"{scenario['name']}.yaml"
        path.write_text(yaml.safe_dump(scenario, sort_keys=False))
        out.append((phase, faults, path))
    return out


def cell_figures(summary: dict) -> dict:
    """What the page shows of a cell's run (SI)."""
    alarms = [e for e in summary.get("events", []) if e["source"] == "protection"]
    return {key: summary.get(key) for key in (
        "bhp_under_pore_s", "bhp_over_fracture_s", "worst_underbalance_pa",
        "worst_overbalance_over_fracture_pa", "bhp_worst_excursion_pa", "influx_volume_m3",
        "loss_volume_m3")} | {"protection_events": len(alarms),
                              "false_alarms": false_alarms(summary)}


def row_key(row: dict) -> tuple[str, tuple[str, ...], str]:
    """A row's cell and controller: (phase, faults, controller)."""
    return row["phase"], tuple(row["faults"]), row["controller"]


def run_of(row: dict) -> tuple[str, tuple[str, ...], str]:
    """The run a row belongs to, (phase, faults, controller): its own, or for a bound row
    (drill_studies.fault_bound) the run it was made after, which it goes with."""
    phase, faults, controller = row_key(row)
    return phase, faults, row["prefix"] if controller == BOUND else controller


def run_matrix(pairs: str = "actuators", controllers=CONTROLLERS, run=batch.run_one,
               with_fault: Sequence[str] = (), skip=frozenset(), workers: int = 1,
               on_row=None) -> list[dict]:
    """Run every cell (``with_fault``: every cell with these faults) under every controller,
    but those whose (phase, faults, controller) is in ``skip``; the table's rows.
    ``on_row`` sees each row as its run finishes."""
    base = base_scenario()
    scenarios = write_cells(runs.ROOT / "runs" / "fault-matrix", planned_cells(pairs, with_fault),
                            base)
    seed = base["seed"]
    commit = runs.source_commit()
    specs = {(path.stem, controller): (phase, faults, batch.RunSpec(path.stem, str(path), controller, seed))
             for phase, faults, path in scenarios for controller in controllers
             if (phase, faults, controller) not in skip}
    rows = []

    def done(row: dict) -> None:
        phase, faults, spec = specs[(row["case"], row["controller"])]
        if not row["ok"]:
            raise RuntimeError(f"{spec.label} failed: {row['message']}")
        figures = cell_figures(row["summary"])
        rows.append({"phase": phase, "faults": list(faults), "controller": row["controller"],
                     "seed": row["seed"], "run_dir": Path(row["run_dir"]).name,   # under runs/
                     "wall_s": row["wall_s"], "commit": commit,
                     **figures})
        if on_row is not None:
            on_row(rows[-1])
        print(f"[fault matrix] {len(rows)}/{len(specs)} {phase} / {' + '.join(faults)} / "
              f"{row['controller']}: under pore {figures['bhp_under_pore_s']:.1f} s, over "
              f"fracture {figures['bhp_over_fracture_s']:.1f} s", flush=True)
    print(f"[fault matrix] {len(specs)} runs"
          + (f", {len(skip)} kept from the table" if skip else "")
          + (f", {workers} at a time" if workers > 1 else ", one at a time"), flush=True)
    batch.execute([s for _, _, s in specs.values()], run, workers=workers, on_done=done)
    return rows


FLOW_SHOWN_M3 = 0.5e-3             # influx or losses shown in a cell from 0.5 L


def _into(phase: Phase) -> float:
    """How long after its last block target the phase's fault comes [s]."""
    return phase.fault_time_s - phase.targets[-1][0]


def _cell(row: dict | None) -> str:
    if row is None:
        return "not run"
    under, over = row["bhp_under_pore_s"], row["bhp_over_fracture_s"]
    parts = []
    if under > 0.0:
        parts.append(f"{under:.1f} s under ({row['worst_underbalance_pa'] / PA_PER_BAR:.1f} bar)")
    if over > 0.0:
        parts.append(f"{over:.1f} s over ({row['worst_overbalance_over_fracture_pa'] / PA_PER_BAR:.1f} bar)")
    text = "**" + ", ".join(parts) + "**" if parts else "0"
    notes = [f"{row[key] * L_PER_M3:.0f} L {word}" for key, word in
             (("influx_volume_m3", "in"), ("loss_volume_m3", "lost")) if row[key] >= FLOW_SHOWN_M3]
    if row["false_alarms"]:
        notes.append(f"{row['false_alarms']} false alarm(s)")
    return text + (f" ({', '.join(notes)})" if notes else "")


def cell_speed_mps() -> float:
    """The cells' trip speed: Case 2's trip-speed limit [m/s]."""
    return float(base_scenario()["schedule"][0]["trip_speed_limit_mps"])


def _bound_key(r: dict) -> tuple:
    return r["phase"], tuple(r["faults"]), r["prefix"]


def _envelope(bounds: list[dict]) -> list[str]:
    """The bound at each trip speed, per cell and controller bounded."""
    lines = []
    for phase, faults, prefix in sorted({_bound_key(r) for r in bounds}):
        lines += ["", f"*{phase}, {' + '.join(faults)}, after {prefix}*: the fastest answer "
                      "from each trip speed", "", "| trip speed | the fastest answer |",
                  "| --- | --- |"]
        for r in sorted((r for r in bounds if _bound_key(r) == (phase, faults, prefix)),
                        key=lambda r: -r["speed_mps"]):
            lines.append(f"| {r['speed_mps']:g} m/s | {_cell(r)} |")
    return lines


def _bound_cell(bounds: list[dict]) -> str:
    """The bound column of one cell: each bounded controller's fastest answer (which, and
    from when)."""
    if not bounds:
        return "–"
    return "; ".join(f"after {r['prefix']} ({r['answer']} from {r['start_s']:g} s): {_cell(r)}"
                     for r in sorted(bounds, key=lambda r: CONTROLLERS.index(r["prefix"])))


def outside_s(row: dict) -> float:
    """A run's (or bound's) time under the pore pressure and over the fracture pressure [s]."""
    return row["bhp_under_pore_s"] + row["bhp_over_fracture_s"]


def past_bound(rows: list[dict], bounds: list[dict]) -> list[dict]:
    """The runs that left the window for longer than their bound at the cells' speed (a
    run without a bound row counts)."""
    speed = cell_speed_mps()
    at_speed = {(r["phase"], tuple(r["faults"]), r["prefix"]): r for r in bounds
                if r["speed_mps"] == speed}
    left = []
    for r in rows:
        bound = at_speed.get((r["phase"], tuple(r["faults"]), r["controller"]))
        if outside_s(r) > 0.0 and (bound is None or outside_s(r) > outside_s(bound) + 1e-9):
            left.append(r)
    return left


def _provenance(rows: list[dict]) -> str:
    """The commits the rows ran at, with how many each."""
    counts = Counter(r.get("commit") for r in rows)
    ran = ", ".join(f"{commit} ({n})" for commit, n in sorted(
        ((c, n) for c, n in counts.items() if c), key=lambda item: -item[1]))
    unknown = counts.get(None, 0)
    return ("The runs' source commits (runs): " + (ran or "none recorded")
            + (f"; {unknown} from before rows recorded theirs (their history: "
               "`docs/faults.md`)" if unknown else "") + ".")


def markdown(rows: list[dict], made: str, window_pa: tuple[float, float]) -> str:
    """The page; ``window_pa``: the pore and fracture pressures the cells ran in. Rows of
    the controller ``bound`` (drill_studies.fault_bound) make the machines' column and the
    speed envelopes."""
    bounds = [r for r in rows if r["controller"] == BOUND]
    rows = [r for r in rows if r["controller"] != BOUND]
    by = {(r["phase"], tuple(r["faults"]), r["controller"]): r for r in rows}
    speed = cell_speed_mps()
    bounded: dict[tuple, list[dict]] = {}
    for r in bounds:
        if r["speed_mps"] == speed:
            bounded.setdefault((r["phase"], tuple(r["faults"])), []).append(r)
    keys = sorted({(r["phase"], tuple(r["faults"])) for r in rows},
                  key=lambda k: (len(k[1]), list(PHASES).index(k[0]), [list(FAULTS).index(f) for f in k[1]]))
    controllers = [c for c in CONTROLLERS if any(r["controller"] == c for r in rows)]
    columns = controllers + ([BOUND] if bounds else [])
    outside = [r for r in rows if outside_s(r) > 0.0]
    lines = [
        "# Fault matrix: the pore/fracture window under actuator and sensor faults", "",
        f"Generated by `rig compare --fault-matrix` ({made}); the table below is rendered "
        "from `docs/fault-matrix.json`, the runs' figures. Each cell is one run of the whole "
        "graph in fast mode: Case 2's well, mud and seed, the phase's trip (pull-out: the "
        f"fault {_into(PHASES['pull-out']):g} s into the pull-out, at speed; rest: the string "
        f"at rest, circulating; run-in: the fault {_into(PHASES['run-in']):g} s into the "
        "run-in), the fault (both of a pair at once) and "
        f"{SPAN_S:.0f} s of it ({BRAKE_S:.0f} s for a stuck drawworks or a position dropout; "
        "a trip lasts to the end). A cell shows the time BHP spent under the pore pressure "
        f"and over the fracture pressure ({window_pa[0] / PA_PER_BAR:g} and "
        f"{window_pa[1] / PA_PER_BAR:g} bar) and the worst excursion beyond it "
        "(0: inside the window throughout), the formation's influx or the mud lost to it "
        "from 0.5 L, and the kick or losses alarms raised with no formation flow behind "
        "them. The controllers are not told of a fault; the process protection sees what "
        "the sensors show.", "",
        f"**{len(outside)} of {len(rows)} runs left the window.**", "",
        _provenance(rows), ""]
    if bounds:
        over = past_bound(rows, bounds)
        lines += [
            f"**{len(over)} of them left it for longer than their bound**" + (
                ": " + "; ".join(f"{r['phase']}, {' + '.join(r['faults'])}, {r['controller']}"
                                 for r in over) if over else "") + ".", "",
            "Where a controller left the window, the column *bound* gives the machines' "
            "fastest answers from the first command after the fault (the first a sensor's "
            "reading of it can reach), in process (`python -m drill_studies.fault_bound`), "
            "whatever a controller would know, the one that leaves BHP less time outside: "
            "*brake* (the drawworks brake set, the back-pressure pump commanded to its "
            "maximum, the choke on its own BHP loop at the window's middle) or *shut* (the "
            "same, but while the BHP is under the window's middle the choke shut, the "
            "back-pressure pump at its maximum and the block held where the string was). "
            "Before that command the trip runs under that controller and the protection "
            "(*after* it: how open a choke sticks and how fast the string moves when the "
            "fault comes are its). Not a proven optimum: what is left when every machine does "
            "at once the most it can (– : not taken).", ""]
    lines += ["| phase | faults | " + " | ".join(columns) + " |",
              "| --- | --- | " + " | ".join("---" for _ in columns) + " |"]
    for phase, faults in keys:
        lines.append(f"| {phase} | {' + '.join(faults)} | " + " | ".join(
            _cell(by.get((phase, faults, c))) if c != BOUND
            else _bound_cell(bounded.get((phase, faults), [])) for c in columns) + " |")
    lines += _envelope(bounds)
    missing = [(p, f) for p, f in itertools.product(PHASES, itertools.combinations(FAULTS, 2))
               if (p, f) not in keys]
    started = sorted(t for r in rows if (t := runs.run_started(r.get("run_dir") or "")))
    if started:
        lines += ["", f"The runs were made from {started[0]:%Y-%m-%d %H:%M} to "
                      f"{started[-1]:%Y-%m-%d %H:%M} (their run directories' stamps; a "
                      "run of the matrix or of a part of it (`--with-fault`, `--controller`) "
                      "replaces the rows of the cells it runs)."]
    lines += ["", f"Pairs not run: {len(missing)} of the "
              f"{len(PHASES) * len(list(itertools.combinations(FAULTS, 2)))} (phase, pair) cells "
              "(`--fault-matrix` runs the pairs of actuator faults in every phase, "
              "`--fault-matrix all` every pair; `--resume` runs only the cells the table "
              "lacks).", "",
              "Protection events per run (alarms, clamps, answers) and each run's directory "
              "are in the JSON table."]
    return "\n".join(lines) + "\n"


def write(rows: list[dict], output: Path, made: str | None = None) -> None:
    output.parent.mkdir(parents=True, exist_ok=True)
    output.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    formation = load_rig(runs.ROOT / "config").well.formation
    output.write_text(markdown(rows, made or f"{datetime.now():%Y-%m-%d %H:%M}",
                               (formation.pore_pressure_pa, formation.fracture_pressure_pa)))
    print(f"[fault matrix] wrote {output}")


def main(output: Path, pairs: str = "actuators", with_fault: Sequence[str] = (),
         controllers=CONTROLLERS, run=batch.run_one, resume: bool = False,
         workers: int = 1) -> int:
    """Run the matrix under ``controllers`` (with ``with_fault``: only the cells with each
    of these faults) and write its page. The table keeps the rows of the cells not run now, and is
    written after every run; ``resume``: a cell whose row the table holds is not run
    again."""
    for fault in with_fault:
        if fault not in FAULTS:
            raise ValueError(f"fault {fault!r}: expected one of {', '.join(FAULTS)}")
    table = output.with_suffix(".json")
    old = json.loads(table.read_text()) if table.exists() else []
    plan = {(phase, faults, c) for phase, faults in planned_cells(pairs, with_fault)
            for c in controllers}
    skip = plan & {row_key(r) for r in old} if resume else set()
    planned = plan - skip
    kept = [r for r in old if run_of(r) not in planned]
    fresh: list[dict] = []

    def checkpoint(row: dict) -> None:      # whole or not at all: a killed matrix resumes
        fresh.append(row)
        output.parent.mkdir(parents=True, exist_ok=True)
        part = table.with_name(table.name + ".part")
        part.write_text(json.dumps(kept + fresh, indent=1))
        part.replace(table)
    run_matrix(pairs, controllers, run, with_fault, skip, workers, checkpoint)
    write(kept + fresh, output)
    return 0


def render(output: Path) -> int:
    rows = json.loads(output.with_suffix(".json").read_text())
    write(rows, output, f"{datetime.now():%Y-%m-%d %H:%M} (`--render`: the page from its JSON table)")
    return 0
