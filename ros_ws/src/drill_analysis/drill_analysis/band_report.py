"""Where a multi-stand trip's bottom-hole pressure left its control band: the seconds
under and over the band per phase of the rig floor (moving, setting the slips, the
pump's ramps, the connection, ...), from the truth's samples and the references in force
at each (a recording's, as drill_analysis.report reads it, or the trip bench's).

The trip sheet gives the band time per stand; this splits it by what the floor was doing,
and by side, which is where a controller's loss on a plant that is not its model shows
(docs/mismatch.md)."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from drill_analysis.prediction_report import PHASE_ORDER
from drill_ros.stamps import seconds_to_ns

UNDER, OVER = "under_s", "over_s"


def outside_band_by_phase(t_s, bhp_pa, ref_pa, band_pa, phases: Mapping[int, str]) -> dict:
    """{phase: {"under_s", "over_s"}}: the seconds the BHP [Pa] at the times ``t_s`` [s]
    was under ``ref_pa - band_pa`` and over ``ref_pa + band_pa`` (scalars or arrays like
    ``t_s``), by the rig floor's phase in force at each time (``phases``: the phase by the
    stamp in ns it was published at, held until the next; samples before the first are
    in no phase). A phase with no time outside is left out; each sample counts the
    median sample period."""
    t = np.asarray(t_s, dtype=float)
    if len(t) < 2 or not phases:
        return {}
    dt_s = float(np.median(np.diff(t)))
    error = np.asarray(bhp_pa, dtype=float) - ref_pa
    side = np.where(error < -np.asarray(band_pa), -1, np.where(error > band_pa, 1, 0))
    stamps = np.array(sorted(phases), dtype=np.int64)
    names = [phases[s] for s in stamps]
    at = np.searchsorted(stamps, [seconds_to_ns(v) for v in t], side="right") - 1
    counts: dict[str, dict[str, int]] = {}
    for k, s in zip(at, side):
        if k < 0 or s == 0:
            continue
        cell = counts.setdefault(names[k], {UNDER: 0, OVER: 0})
        cell[UNDER if s < 0 else OVER] += 1
    return {phase: {key: n * dt_s for key, n in cell.items()} for phase, cell in counts.items()}


def format_rows(by_phase: dict) -> list[str]:
    """The printed table's lines of outside_band_by_phase's figures (seconds)."""
    order = [p for p in PHASE_ORDER if p in by_phase] + sorted(set(by_phase) - set(PHASE_ORDER))
    lines = ["  BHP outside the band by rig-floor phase, under / over [s]"]
    lines += [f"    {phase:12s} {by_phase[phase][UNDER]:6.1f} / {by_phase[phase][OVER]:6.1f}"
              for phase in order]
    return lines
