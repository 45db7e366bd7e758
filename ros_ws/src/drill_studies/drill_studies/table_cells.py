"""Cells of the comparison tables (``rig compare``): a figure's mean and worst over the
seeds, and which seeds' runs miss a target."""
from __future__ import annotations

import numpy as np


def stat(values, scale: float, digits: int, worst=max) -> str:
    """'mean / worst' of ``values`` over ``scale`` (None values left out; n/a: none)."""
    values = [v for v in values if v is not None]
    if not values:
        return "n/a"
    return f"{np.mean(values) / scale:.{digits}f} / {worst(values) / scale:.{digits}f}"


def missed_targets(group: list[dict], figures: list[dict], misses) -> str:
    """'seed S: target, ...; ...' for the runs of ``group`` (rows with their seed) that miss
    a target, 'none' when every run meets them; ``misses(row, figures)`` names the targets
    one run misses."""
    failing = [(r["seed"], misses(r, f)) for r, f in zip(group, figures)]
    return "; ".join(f"seed {s}: {', '.join(m)}" for s, m in failing if m) or "none"
