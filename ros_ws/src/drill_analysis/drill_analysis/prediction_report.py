"""How well the NMPC's model predicted the bottom-hole pressure in a run (a recording's,
as drill_analysis.report reads it, or the trip bench's): each solve's predicted BHP some
seconds ahead (drill_msgs/NmpcStatus) against the truth's BHP at that time, as a mean and
an RMS error per horizon, over the run and, on a multi-stand trip, per phase of the rig
floor at the solve.

One second ahead the plan's first input is the one applied, so that error is the model's
and the estimate's; further ahead the plan's later inputs differ from those applied after
each re-plan, so the figures also hold the plan's changes. On a plant that is not the
model this is where the model is wrong, phase by phase
(docs/experiments/2026-12-07-ramp-down-choke-and-prediction.md)."""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from drill_core.tripping.sequence import DONE, STAND_PHASES
from drill_core.units import PA_PER_BAR
from drill_ros.stamps import seconds_to_ns

HORIZONS_S = (1.0, 5.0)      # how far ahead the predictions are judged [s]
RUN = "run"                  # the group of every solve
TIME_MATCH_S = 1.0e-6        # a prediction's time equals a horizon within this [s]
PHASE_ORDER = (*STAND_PHASES["out"], DONE)     # the printed rows' order after RUN


def prediction_errors(solves: Iterable[tuple[int, list, list]], truth_bhp_pa: Mapping[int, float],
                      phases: Mapping[int, str] | None = None,
                      horizons_s: tuple[float, ...] = HORIZONS_S) -> dict:
    """Errors (predicted less truth, Pa) per group and horizon: ``solves`` (stamp ns, the
    prediction's times after the stamp [s], its BHP [Pa]); ``truth_bhp_pa`` by stamp ns;
    ``phases`` the rig floor's phase by stamp ns (None: none). Returns {group: {"1s":
    {"mean_pa", "rms_pa", "count"}}}, the groups RUN and each phase met, a horizon only
    where some prediction reached a truth sample."""
    errors: dict[str, dict[float, list[float]]] = {}
    for stamp, times, bhp in solves:
        groups = [RUN] + ([phases[stamp]] if phases and stamp in phases else [])
        for horizon in horizons_s:
            k = next((i for i, t in enumerate(times) if abs(t - horizon) < TIME_MATCH_S), None)
            at = stamp + seconds_to_ns(horizon)
            if k is None or k >= len(bhp) or at not in truth_bhp_pa or not math.isfinite(bhp[k]):
                continue
            for group in groups:
                errors.setdefault(group, {}).setdefault(horizon, []).append(
                    bhp[k] - truth_bhp_pa[at])
    return {group: {f"{h:g}s": {"mean_pa": sum(e) / len(e),
                                 "rms_pa": math.sqrt(sum(v * v for v in e) / len(e)),
                                 "count": len(e)}
                    for h, e in by_horizon.items()}
            for group, by_horizon in errors.items()}


def errors_over_run(solves, truth_t_s, truth_bhp_pa, phases: Mapping[int, str]) -> dict:
    """prediction_errors against a run's truth: its BHP [Pa] at the times ``truth_t_s`` [s]
    (a recording's stamps, or a bench's sample times)."""
    truth = {seconds_to_ns(t): float(b) for t, b in zip(truth_t_s, truth_bhp_pa)}
    return prediction_errors(solves, truth, phases)


def format_rows(errors: dict) -> list[str]:
    """The printed table's lines of prediction_errors' figures (display units: bar)."""
    horizons = list(errors[RUN])
    order = [RUN] + [p for p in PHASE_ORDER if p in errors] \
        + sorted(set(errors) - {RUN, *PHASE_ORDER})
    lines = ["  NMPC's BHP prediction less the truth, mean / RMS [bar]: "
             + ", ".join(f"{h.removesuffix('s')} s ahead" for h in horizons)]
    for group in order:
        cells = [f"{c['mean_pa'] / PA_PER_BAR:+6.2f} / {c['rms_pa'] / PA_PER_BAR:4.2f}"
                 if (c := errors[group].get(h)) else "     -       " for h in horizons]
        lines.append(f"    {group:12s} " + "   ".join(cells))
    return lines
