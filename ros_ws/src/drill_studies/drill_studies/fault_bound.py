"""The machines' bound of a fault-matrix cell: what the rig's fastest answers to the fault
give, for each run of the fault matrix that left the window (docs/fault-matrix.md).

From the first command after the fault on (the first a sensor's reading of it can reach:
commands go every ``command_period_s``), an oracle replaces the protection's machine
command with one of two fastest answers the machines have, whatever a controller would
know, and the bound is the one that leaves BHP less time outside the window:

* *brake*: the drawworks brake set (the block stops at the brake's deceleration and is
  held), the back-pressure pump commanded to its maximum, the choke on its own BHP loop
  aimed at the window's middle;
* *shut*: the *brake* answer, but once the BHP is under the window's middle the choke
  shut, the back-pressure pump at its maximum and the block reference held where the
  string was, until the BHP is back at the middle (the quickest build of back-pressure a
  choke that comes free gives).

Before that command the cell's trip runs under the controller that left the window (its
*prefix*) with the protection: where the machines stand when the fault comes (how open a
choke sticks, how fast the string moves) is that controller's. It is a bound of those
answers, not a proven optimum: it says how much of a cell's time outside the window is
left when every machine does at once the most it can.

The same bound at lower trip speeds (the operator's trip-speed limit of the cell's
scenario), in the phases where the string moves, gives the speed envelope: the fastest
trip from which the fastest answer still keeps BHP inside the window.

In process (drill_studies.loop_bench: the nodes' own tick classes, the estimator on the
noisy measurements); its rows go into the fault matrix's JSON table with the controller
``bound``.

    python -m drill_studies.fault_bound            # bounds for docs/fault-matrix.json
    python -m drill_studies.fault_bound --speeds   # at the cells' own trip speed only
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import tempfile
from pathlib import Path

import yaml

from drill_bringup import runs
from drill_core.config import load_rig
from drill_studies import fault_matrix, loop_bench

SLOWER_SPEEDS_MPS = (0.4, 0.3, 0.2, 0.1)         # the envelope's speeds below the cells' own


def brake_answer(start_s: float, bpp_max_m3s: float, bhp_target_pa: float):
    """The *brake* answer's machine command from ``start_s`` on: the brake, the
    back-pressure pump at ``bpp_max_m3s``, the choke's BHP loop at ``bhp_target_pa`` (from
    the measured choke dp); before it the command as it is."""
    def machines(time_s: float, m, command):
        if time_s < start_s:
            return command
        dp = m.choke_dp_pa if math.isfinite(m.choke_dp_pa) else command.choke_dp_ref_pa
        return dataclasses.replace(command, emergency_stop=True, emergency_bhp_pa=bhp_target_pa,
                                   bpp_flow_m3s=bpp_max_m3s, choke_dp_ref_pa=float(dp),
                                   choke_manual=False, choke_pressure_control=False)
    return machines


def shut_answer(start_s: float, bpp_max_m3s: float, bhp_target_pa: float):
    """The *shut* answer's machine command from ``start_s`` on: the *brake* answer's,
    but from the first measured BHP under ``bhp_target_pa`` until the BHP is back at it
    the choke shut, the back-pressure pump at ``bpp_max_m3s`` and the block reference
    held at the string's position then (the brake off); before ``start_s`` the command
    as it is."""
    brake = brake_answer(start_s, bpp_max_m3s, bhp_target_pa)
    shut: dict = {}         # "block_m": where the string was when the BHP fell under the
                            # target; "over": the BHP has been back at the target since

    def machines(time_s: float, m, command):
        if time_s < start_s:
            return command
        if "block_m" not in shut:
            if m.bhp_pa < bhp_target_pa:
                shut["block_m"] = m.block_position_m if math.isfinite(m.block_position_m) \
                    else command.block_position_ref_m
        elif m.bhp_pa >= bhp_target_pa:
            shut["over"] = True
        if "block_m" not in shut or "over" in shut:
            return brake(time_s, m, command)
        return dataclasses.replace(command, block_position_ref_m=shut["block_m"],
                                   bpp_flow_m3s=bpp_max_m3s, choke_manual=True,
                                   choke_opening_ref=0.0, choke_pressure_control=False,
                                   emergency_stop=False)
    return machines


ANSWERS = {"brake": brake_answer, "shut": shut_answer}


def first_command_after(fault_time_s: float, period_s: float) -> float:
    """The time of the first command whose measurement can show a fault at
    ``fault_time_s`` [s] (the command at the fault's instant reads the frame before it)."""
    return (math.floor(fault_time_s / period_s + 1e-9) + 1) * period_s


def figures(out: dict) -> dict:
    """A bound run's figures under the fault matrix's names (SI)."""
    return {"bhp_under_pore_s": out["bhp_under_pore_s"],
            "bhp_over_fracture_s": out["bhp_over_fracture_s"],
            "worst_underbalance_pa": out["worst_underbalance_pa"],
            "worst_overbalance_over_fracture_pa": out["worst_over_fracture_pa"],
            "influx_volume_m3": out["influx_volume_m3"], "loss_volume_m3": out["loss_volume_m3"],
            "false_alarms": 0}


def bound(phase: str, faults: tuple[str, ...], speed_mps: float, prefix: str) -> dict:
    """The bound row of one cell at trip speed ``speed_mps``, the trip under
    ``prefix`` until the first command after the fault: the answer that leaves BHP less
    time outside the window."""
    config = load_rig(runs.ROOT / "config")
    base = fault_matrix.base_scenario()
    scenario = fault_matrix.cell_scenario(base, phase, faults)
    scenario["schedule"][0]["trip_speed_limit_mps"] = speed_mps
    low, high = config.pressure_window_pa
    start_s = first_command_after(fault_matrix.PHASES[phase].fault_time_s,
                                  config.protection.command_period_s)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{scenario['name']}.yaml"
        path.write_text(yaml.safe_dump(scenario, sort_keys=False))
        for name, answer in ANSWERS.items():
            out = loop_bench.run(str(path), controller=prefix, state="ukf", protection=True,
                                 machines=answer(start_s, config.actuators.bpp.maximum,
                                                 0.5 * (low + high)))
            rows.append({"phase": phase, "faults": list(faults),
                         "controller": fault_matrix.BOUND, "prefix": prefix,
                         "speed_mps": speed_mps, "answer": name, "start_s": start_s,
                         "seed": scenario["seed"], "run_dir": None, **figures(out)})
    return min(rows, key=fault_matrix.outside_s)


def runs_left(rows: list[dict]) -> list[tuple[str, tuple[str, ...], str]]:
    """(phase, faults, controller) of each graph run that left the window."""
    return [(r["phase"], tuple(r["faults"]), r["controller"]) for r in rows
            if r["controller"] in fault_matrix.CONTROLLERS
            and fault_matrix.outside_s(r) > 0.0]


def main(output: Path, speeds=None) -> int:
    """Bounds (at the cells' own trip speed and, where the string moves, each of
    ``speeds``, default SLOWER_SPEEDS_MPS) for each run that left the window, after its own
    controller; the table's earlier bound rows dropped, its page written again."""
    speeds = (fault_matrix.cell_speed_mps(), *(SLOWER_SPEEDS_MPS if speeds is None else speeds))
    table = output.with_suffix(".json")
    rows = [r for r in json.loads(table.read_text()) if r["controller"] != fault_matrix.BOUND]
    for phase, faults, prefix in runs_left(rows):
        moving = bool(fault_matrix.PHASES[phase].targets)     # at rest the speed moves nothing
        for speed in speeds if moving else speeds[:1]:
            row = bound(phase, faults, speed, prefix)
            print(f"[fault bound] {phase} / {' + '.join(faults)} after {prefix} at {speed:g} "
                  f"m/s, {row['answer']} from {row['start_s']:g} s: under pore "
                  f"{row['bhp_under_pore_s']:.1f} s, over fracture {row['bhp_over_fracture_s']:.1f} s",
                  flush=True)
            rows.append(row)
    fault_matrix.write(rows, output)
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=runs.ROOT / "docs" / "fault-matrix.md")
    parser.add_argument("--speeds", type=float, nargs="*", default=SLOWER_SPEEDS_MPS,
                        help="the envelope's trip speeds below the cells' own [m/s] "
                             "(none: the cells' own speed only)")
    args = parser.parse_args()
    sys.exit(main(args.output, tuple(args.speeds)))
