"""A gauge's finite samples stamped within the last span of time, and their median or
mean (plain Python): the protection acts on, and the trip sheet books, the gauges read
through single samples' noise and spikes (the BHP gauge's noise is 1 bar at 10 Hz).
Non-finite samples are left out; time passes all the same."""
from __future__ import annotations

import math
import statistics
from collections import deque

BHP_WINDOW_S = 1.0      # the BHP gauge is read over this long: the protection's median,
                        # the trip sheet's mean [s]
_STAMP_TOLERANCE_S = 1.0e-9


class RecentSamples:
    """Samples of the last ``span_s`` seconds, their median and mean (NaN with none)."""

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
        while self._samples and self._samples[0][0] < time_s - self.span_s + _STAMP_TOLERANCE_S:
            self._samples.popleft()
        if not self._samples:
            self._since_s = None

    def __bool__(self) -> bool:
        return bool(self._samples)

    def full(self, time_s: float) -> bool:
        """The samples have covered a whole span by ``time_s`` (none missing for as long)."""
        return self._since_s is not None and \
            time_s - self._since_s >= self.span_s - _STAMP_TOLERANCE_S

    def spans(self, time_s: float, share: float) -> bool:
        """The oldest sample held is at least ``share`` of a span older than ``time_s``."""
        return bool(self._samples) and \
            time_s - self._samples[0][0] >= share * self.span_s - _STAMP_TOLERANCE_S

    @property
    def median(self) -> float:
        return statistics.median(v for _, v in self._samples) if self._samples else math.nan

    @property
    def mean(self) -> float:
        return sum(v for _, v in self._samples) / len(self._samples) if self._samples else math.nan
