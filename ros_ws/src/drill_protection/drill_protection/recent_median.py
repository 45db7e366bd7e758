"""The median of a gauge's samples over the last span of time (plain Python): the
pressures the protection acts on, read through single samples' noise and spikes (the BHP
gauge's noise is 1 bar). Non-finite samples are left out; time passes all the same."""
from __future__ import annotations

import math
import statistics
from collections import deque

BHP_MEDIAN_S = 1.0      # the protection's reading of the BHP: the median of this long [s]


class RecentMedian:
    """Samples of the last ``span_s`` seconds and their median (NaN with none)."""

    def __init__(self, span_s: float):
        self.span_s = span_s
        self._samples: deque = deque()          # (time s, value), oldest first
        self._since_s: float | None = None      # when the samples last began (none before)

    def add(self, time_s: float, value: float) -> None:
        """Take one sample (a non-finite one only moves the span on)."""
        if math.isfinite(value):
            if not self._samples:
                self._since_s = time_s
            self._samples.append((time_s, value))
        while self._samples and self._samples[0][0] < time_s - self.span_s + 1e-9:
            self._samples.popleft()
        if not self._samples:
            self._since_s = None

    def __bool__(self) -> bool:
        return bool(self._samples)

    def full(self, time_s: float) -> bool:
        """The samples have covered a whole span by ``time_s`` (none missing for as long)."""
        return self._since_s is not None and time_s - self._since_s >= self.span_s - 1e-9

    @property
    def value(self) -> float:
        return statistics.median(v for _, v in self._samples) if self._samples else math.nan
