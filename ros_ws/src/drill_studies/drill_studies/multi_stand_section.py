"""``rig compare``'s multi-stand trips: the KPI table of a whole section tripped through its
connections (drill_core.tripping), per controller the mean and worst over the seeds, each
run checked against the issue's targets and against the PI baseline on the same seed."""
from __future__ import annotations

import numpy as np

from drill_core.scenario import MULTI_STAND_CONTROLLERS
from drill_core.units import L_PER_M3, PA_PER_BAR
from drill_studies.table_cells import missed_targets, stat as _stat

MULTI_STAND_CASES = ("trip_out", "trip_in")
# per run (SI): BHP RMSE over the trip, band time per stand (connections included), and no
# time outside the pore / fracture window
TARGETS = {"bhp_rmse_pa": 0.7e5, "outside_band_per_stand_s": 10.0, "outside_window_s": 0.0}
STANDS_PER_HOUR_GAIN = 1.10      # the NMPC trips this much faster than automated MPD ...
PEER = {"nmpc": "automated_mpd"}  # ... at equal or better BHP figures on the same seed


def kpis(s: dict) -> dict:
    """The multi-stand figures of one run's summary (SI)."""
    stands = max(1, s.get("stands_tripped", 0))
    return {"stands_per_hour": s.get("stands_per_hour"),
            "stands_tripped": s.get("stands_tripped", 0),
            "bhp_rmse_pa": s["bhp_rmse_pa"],
            "outside_band_s": s["bhp_time_outside_s"],
            "outside_band_per_stand_s": s["bhp_time_outside_s"] / stands,
            "worst_excursion_pa": s["bhp_worst_excursion_pa"],
            "outside_window_s": s.get("bhp_under_pore_s", 0.0) + s.get("bhp_over_fracture_s", 0.0),
            "trip_tank_discrepancy_m3": s.get("trip_tank_discrepancy_m3")}


def misses(k: dict, baseline: dict | None, peer: tuple[str, dict] | None = None) -> list[str]:
    """The targets one run misses: the issue's, against the baseline on its seed, and
    (``peer``: its name and figures) the stands per hour and BHP figures of the controller
    it is to beat on its seed (PEER)."""
    out = [key for key, limit in TARGETS.items() if k[key] > limit]
    if baseline is not None:
        out += [f"{key} vs baseline" for key in ("bhp_rmse_pa", "outside_band_s")
                if k[key] >= baseline[key]]
    if peer is not None:
        name, figures = peer
        if k["stands_per_hour"] < STANDS_PER_HOUR_GAIN * figures["stands_per_hour"]:
            out.append(f"stands_per_hour vs {name}")
        out += [f"{key} vs {name}" for key in ("bhp_rmse_pa", "outside_band_s")
                if k[key] > figures[key]]
    return out


_COLUMNS = ("stands per hour", "BHP RMSE [bar]", "outside band [s]",
            "outside band per stand [s]", "worst excursion [bar]", "outside the window [s]",
            "trip tank vs steel [L]", "wall [s]", "runs missing a target")
_TARGETS_NOTE = ("Targets per run (issue: trip a whole section): BHP RMSE <= 0.7 bar over the "
                 "trip, <= 10 s outside the band per stand, no time outside the pore / fracture "
                 "window, and BHP RMSE and band time below the PI baseline's on the same seed; "
                 "the NMPC is to trip >= 10 % more stands per hour than automated MPD at equal "
                 "or better BHP figures")


def _header(leading: tuple[str, ...]) -> list[str]:
    names = (*leading, *_COLUMNS)
    return ["| " + " | ".join(names) + " |", "|" + " --- |" * len(names)]


def _case_rows(by: dict, case: str, controllers, leading: str) -> list[str]:
    """One row per controller of ``case`` from ``by`` ((case, controller): rows), each run
    judged against the baseline and its peer on the same seed; ``leading`` the row's first
    cells."""
    lines = []
    by_seed = {c: {r["seed"]: kpis(r["summary"]) for r in by.get((case, c), [])}
               for c in controllers}
    for controller in controllers:
        group = by.get((case, controller))
        if not group:
            continue
        ks = [kpis(r["summary"]) for r in group]
        peer = PEER.get(controller)

        def judged(r, k, controller=controller, peer=peer):
            base = by_seed["baseline"].get(r["seed"]) if controller != "baseline" else None
            figures = by_seed.get(peer, {}).get(r["seed"]) if peer else None
            return misses(k, base, (peer, figures) if figures else None)
        failed = missed_targets(group, ks, judged)
        stands_h = [k["stands_per_hour"] for k in ks]
        lines.append(
            f"| {leading} | {controller} | "
            f"{np.mean(stands_h):.2f} / {min(stands_h):.2f} (slowest) | "
            f"{_stat([k['bhp_rmse_pa'] for k in ks], PA_PER_BAR, 2)} | "
            f"{_stat([k['outside_band_s'] for k in ks], 1.0, 0)} | "
            f"{_stat([k['outside_band_per_stand_s'] for k in ks], 1.0, 1)} | "
            f"{_stat([k['worst_excursion_pa'] for k in ks], PA_PER_BAR, 2)} | "
            f"{_stat([k['outside_window_s'] for k in ks], 1.0, 1)} | "
            f"{_stat([abs(k['trip_tank_discrepancy_m3']) for k in ks], 1.0 / L_PER_M3, 0)} | "
            f"{_stat([r.get('wall_s') for r in group], 1.0, 0)} | {failed} |")
    return lines


def section(by: dict, controllers) -> list[str]:
    """The multi-stand table from the compared rows grouped by (case, controller)."""
    cases = [c for c in MULTI_STAND_CASES if any((c, k) in by for k in controllers)]
    if not cases:
        return []
    lines = ["", "## Multi-stand trips (mean / worst over seeds)", "",
             "A whole section tripped through its connections (`config/scenarios/trip_out.yaml`: "
             "ten 28 m stands pulled out, 90 s slips to slips, the mud pump ramped down and up "
             "over 30 s each; `trip_in.yaml`: the same ten run back in from a string ten "
             "stands short): BHP figures over the whole run, connections included, which "
             "ends a minute after the trip is done (`settle_s`); *stands "
             "per hour* slips to slips, from the first stand's start to the last one's end; "
             "*trip tank* the trip sheet's measured less expected hole fill (or returns) at "
             "the end. "
             f"Controllers that plan a multi-stand trip: {', '.join(MULTI_STAND_CONTROLLERS)}.",
             "", *_header(("case", "controller"))]
    for case in cases:
        lines += _case_rows(by, case, controllers, case)
    return lines + ["", _TARGETS_NOTE + "."]


def mismatch_section(rows: list[dict], controllers) -> list[str]:
    """The multi-stand trips on plants that are not the model (rows with a ``mismatch``):
    the same figures per case, plant and controller, each run judged against the other
    controllers on the same plant and seed."""
    rows = [r for r in rows if r["case"] in MULTI_STAND_CASES]
    if not rows:
        return []
    by: dict = {}
    for r in rows:
        by.setdefault(r["mismatch"], {}).setdefault((r["case"], r["controller"]), []).append(r)
    lines = ["", "## Multi-stand trips on a plant that is not the model (mean / worst over "
             "seeds)", "",
             "The multi-stand cases above on plants whose mud, choke and hole differ from "
             "config/well.yaml by a member of config/mismatch.yaml (docs/mismatch.md); the "
             "estimator, the controllers and the protection read well.yaml as it is.", "",
             *_header(("case", "plant", "controller"))]
    for case in MULTI_STAND_CASES:
        for member, grouped in by.items():
            lines += _case_rows(grouped, case, controllers, f"{case} | {member}")
    return lines + ["", _TARGETS_NOTE + ", on the same plant."]
