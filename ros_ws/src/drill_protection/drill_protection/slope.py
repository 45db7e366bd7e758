"""Least-squares slope of a run of (time, value) samples from running sums (plain Python):
the pit's reading of the flow balance (drill_protection.kick_detection) and the flow the
well-control answer judges after a step (drill_protection.well_control)."""
from __future__ import annotations

import math
from collections import deque


class LeastSquaresSlope:
    """Samples taken in at the end and out at the start; their slope from the sums of t, v,
    t^2 and t v (times best counted from a nearby start, for the sums' precision)."""

    def __init__(self):
        self.samples: deque = deque()           # (t, v), oldest first
        self._sums = [0.0] * 4                  # of t, v, t^2, t v

    def __len__(self) -> int:
        return len(self.samples)

    def append(self, t: float, v: float) -> None:
        self.samples.append((t, v))
        self._add(t, v, 1.0)

    def drop_before(self, t: float) -> None:
        """Take out the samples older than ``t``."""
        while self.samples and self.samples[0][0] < t:
            self._add(*self.samples.popleft(), -1.0)

    def clear(self) -> None:
        self.samples.clear()
        self._sums = [0.0] * 4

    def _add(self, t: float, v: float, sign: float) -> None:
        for i, term in enumerate((t, v, t * t, t * v)):
            self._sums[i] += sign * term

    @property
    def slope(self) -> float:
        """dv/dt by least squares; NaN under three samples or without a spread in t."""
        n = len(self.samples)
        sum_t, sum_v, sum_tt, sum_tv = self._sums
        spread = sum_tt - sum_t * sum_t / n if n else 0.0
        if n < 3 or spread <= 0.0:
            return math.nan
        return (sum_tv - sum_t * sum_v / n) / spread
