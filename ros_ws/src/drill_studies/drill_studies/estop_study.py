"""The emergency stop, measured (docs/emergency-stop.md): the three emergency-stop
scenarios (config/scenarios/estop_*.yaml: at rest, at the trip's speed pulling out and
running in, during a mud-pump trip, during a kick answer) through the graph in fast mode,
and for every press what the stop did over the 60 s it was kept: the block's speed at the
press, when it was at rest against the brake's time, how far it went and whether it moved
after, how far the string went, and the BHP against the hold's target in force (the
command's ``emergency_bhp_pa``) and the pore/fracture window. The same figures are the DDS test's
(test/test_estop.py). The page is rendered from the runs, the figures go to a JSON file
beside it.

    python -m drill_studies.estop_study [--output FILE]
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
from dataclasses import asdict, dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from drill_bag import mcap_io

from drill_analysis import report
from drill_bringup import runs
from drill_core.config import RigConfig, load_rig
from drill_ros import topics
from drill_core.units import PA_PER_BAR

SCENARIOS = ("estop_trip", "estop_pump_trip", "estop_kick")
HOLD_S = 60.0                 # each press is judged over this long (the 60 s)
TARGETS = {"travel_m": 0.3, "string_settled_m": 0.3, "bhp_worst_pa": 2.0e5}
RESTING_MPS = 0.1             # a block slower than this at the press was at rest (a trip: 0.3-0.6)
MOVE_SETTLE_S = 5.0           # the BHP is judged from this long after each move of the target
                              # (the BHP loop's answer to a step: docs/faults.md)


@dataclass(frozen=True)
class StopFigures:
    """What one press of the emergency stop did over HOLD_S (SI)."""
    scenario: str
    press_s: float            # scenario time of the press [s]
    state: str                # at rest, pulling out, running in (the block at the press)
    speed_mps: float          # block speed at the press [m/s]
    brake_s: float            # speed / the brake's deceleration [s]
    rest_s: float             # time from the press to the block at rest [s] (inf: never)
    travel_m: float           # the block's largest distance from where it was at the press [m]
    moved_after_rest_m: float  # the block's spread once at rest [m]
    string_m: float           # the string's largest distance from where it was [m]
    string_settled_m: float   # the string's distance over the last 10 s [m]
    target_bhp_pa: float      # the BHP the choke held from the press (the command's
                              # emergency_bhp_pa) [Pa]
    target_moves: int         # how often the target moved with the window in force (a kick
                              # or loss answer's steps)
    bhp_worst_pa: float       # the true BHP's largest distance from the target in force,
                              # the MOVE_SETTLE_S after each of its moves left out [Pa]
    bhp_outside_s: float      # time more than 2 bar from it [s]
    bhp_last_outside_s: float  # last time after the press it was (0: never) [s]
    outside_window_s: float   # time under the pore or over the fracture pressure [s]


def machine_commands(path: Path) -> dict[float, object]:
    """/rig/command by stamp [s] (rounded to the ms)."""
    return {round(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, 3): m
            for _, m in mcap_io.decoded_messages(path, [topics.MACHINE_COMMAND])}


def presses(series: report.Series) -> list[float]:
    """Stamps [s] of the emergency stop's engagements on /protection/events."""
    return [e.t_s for e in series.events if e.source == "protection" and e.code == "estop_engaged"]


def stop_figures(scenario: str, series: report.Series, commands: dict, press_s: float,
                 config: RigConfig) -> StopFigures:
    """The figures of the press at ``press_s``, the BHP judged against the target of the
    command in force at each sample; the commands over the hold must say the stop is in
    force, its BHP target moving only with the window in force (else ValueError)."""
    stamps = [k for k in sorted(commands) if press_s <= k < press_s + HOLD_S]
    held = [commands[k] for k in stamps]
    if not held or not all(c.emergency_stop for c in held):
        raise ValueError(f"{scenario}: the emergency stop is not in force over the "
                         f"{HOLD_S:g} s from {press_s:g} s")
    edges = [(c.bhp_window_low_pa, c.bhp_window_high_pa) for c in held]
    moves = [i for i in range(1, len(held))
             if held[i].emergency_bhp_pa != held[i - 1].emergency_bhp_pa]
    if any(edges[i] == edges[i - 1] for i in moves):
        raise ValueError(f"{scenario}: the hold's BHP target moved after {press_s:g} s "
                         "with the window in force as it was")
    t, block = series.get("block")
    _, string = series.get("position")
    _, bhp = series.get("bhp")
    at = int(np.searchsorted(t, press_s))
    window = (t >= press_s) & (t <= press_s + HOLD_S)
    rates = np.diff(block) / np.diff(t)
    speed = float(rates[at - 2])
    still = np.flatnonzero((rates == 0.0) & window[1:])
    rest = float(t[still[0] + 1]) if still.size else math.inf
    frame = config.plant.sensor_period_s
    in_force = np.maximum(np.searchsorted(np.array(stamps), t[window] + 1e-9) - 1, 0)
    dev = bhp[window] - np.array([c.emergency_bhp_pa for c in held])[in_force]
    for i in moves:
        dev[(t[window] >= stamps[i]) & (t[window] < stamps[i] + MOVE_SETTLE_S)] = 0.0
    outside = np.abs(dev) > TARGETS["bhp_worst_pa"]
    f = config.well.formation
    beyond = (bhp[window] < f.pore_pressure_pa) | (bhp[window] > f.fracture_pressure_pa)
    state = "at rest" if abs(speed) < RESTING_MPS else ("pulling out" if speed > 0 else "running in")
    return StopFigures(
        scenario, float(press_s), state, abs(speed),
        abs(speed) / config.actuators.brake_deceleration_mps2, rest - press_s,
        float(np.abs(block[window] - block[at]).max()),
        float(np.ptp(block[window & (t >= rest)])) if math.isfinite(rest) else math.inf,
        float(np.abs(string[window] - string[at]).max()),
        float(abs(np.mean(string[window & (t > press_s + HOLD_S - 10.0)]) - string[at])),
        float(held[0].emergency_bhp_pa), len(moves), float(np.abs(dev).max()), float(outside.sum() * frame),
        float(t[window][outside].max() - press_s) if outside.any() else 0.0,
        float(beyond.sum() * frame))


def measure(runs_dir: Path, config: RigConfig) -> list[StopFigures]:
    """Run each scenario through the graph (fast mode) and measure every press."""
    out = []
    for name in SCENARIOS:
        code, run_dir = runs.run_scenario(runs.scenario_path(name), runs_dir=runs_dir,
                                          quiet=True)
        if code != 0:
            raise RuntimeError(f"{name}: the run failed ({run_dir})")
        path = next(run_dir.glob("*.mcap"))
        series, commands = report.load_series(path), machine_commands(path)
        out += [stop_figures(name, series, commands, p, config) for p in presses(series)]
    return out


def render(figures: list[StopFigures], config: RigConfig) -> str:
    """The page (bar at this display edge)."""
    bar = PA_PER_BAR
    lines = [
        "# The emergency stop, measured",
        "",
        f"Made by `python -m drill_studies.estop_study` on {datetime.now():%Y-%m-%d %H:%M} "
        "(the graph in fast mode, the scenarios' seeds). What the stop does: "
        "`docs/faults.md`, *The emergency stop*. Each press is judged over the "
        f"{HOLD_S:g} s it is kept; targets: the block at rest within its brake time "
        f"(speed / {config.actuators.brake_deceleration_mps2:g} "
        f"m/s^2) and within {TARGETS['travel_m']:g} m of where it was, the string settled "
        f"within {TARGETS['string_settled_m']:g} m, the BHP within "
        f"{TARGETS['bhp_worst_pa'] / bar:g} bar of the stop's target in force for the "
        f"{HOLD_S:g} s (the first {MOVE_SETTLE_S:g} s after each move of the target left "
        "out: a kick answer's steps go on during the stop).",
        "",
        "| scenario | press | block at the press | at rest after (brake time) | block travel, "
        "after rest | string: furthest, settled | BHP held (moves) | BHP furthest from it | "
        "more than 2 bar off (last) | outside pore/fracture |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for f in figures:
        lines.append(
            f"| `{f.scenario}` | {f.press_s:g} s | {f.state}, {f.speed_mps:.2f} m/s | "
            f"{f.rest_s:.1f} s ({f.brake_s:.1f} s) | {f.travel_m:.3f} m, "
            f"{f.moved_after_rest_m:.3f} m | {f.string_m:.2f} m, {f.string_settled_m:.2f} m | "
            f"{f.target_bhp_pa / bar:.1f} bar ({f.target_moves}) | {f.bhp_worst_pa / bar:.2f} bar | "
            f"{f.bhp_outside_s:.1f} s ({f.bhp_last_outside_s:.1f} s) | "
            f"{f.outside_window_s:.1f} s |")
    missed = [f for f in figures if f.bhp_worst_pa > TARGETS["bhp_worst_pa"]]
    lines += ["", f"BHP target met at {len(figures) - len(missed)} of {len(figures)} presses."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=runs.ROOT / "docs" / "emergency-stop.md")
    args = parser.parse_args(argv)
    config = load_rig(runs.ROOT / "config")
    with tempfile.TemporaryDirectory(prefix="estop-") as tmp:
        figures = measure(Path(tmp), config)
    args.output.write_text(render(figures, config))
    args.output.with_suffix(".json").write_text(
        json.dumps([asdict(f) for f in figures], indent=1))
    print(f"[estop_study] {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
