"""Screening of measured channels before they are used (plain Python; the UKF's update,
the choke's flow loop on the return-flow meter): a channel repeating exactly the same value
for ``frozen_after`` samples (0: never) is flagged frozen and left out (a live sensor's
noise never repeats a float) until it changes again; each channel's age is the time since
its last usable sample, so a dropout is reported as staleness while the user rides on its
model."""
from __future__ import annotations

import math

import numpy as np


class ChannelWatch:
    """Frozen-value flags and staleness of named measurement channels."""

    def __init__(self, names: tuple[str, ...], frozen_after: int):
        self.names = names
        self.frozen_after = frozen_after
        self._last = [math.nan] * len(names)
        self._repeats = [0] * len(names)
        self._fresh_s = [math.nan] * len(names)     # time of the last usable sample
        self.frozen_samples = 0                      # channel samples left out as frozen

    def screen(self, time_s: float, y) -> tuple[np.ndarray, tuple[str, ...]]:
        """``y`` with frozen channels set to NaN, and their names."""
        y = np.array(y, dtype=float)
        frozen = []
        for i, value in enumerate(y):
            if not math.isfinite(value):
                self._repeats[i] = 0
                continue
            self._repeats[i] = self._repeats[i] + 1 if value == self._last[i] else 1
            self._last[i] = value
            if 0 < self.frozen_after <= self._repeats[i]:
                frozen.append(self.names[i])
                y[i] = math.nan
                self.frozen_samples += 1
            else:
                self._fresh_s[i] = time_s
        return y, tuple(frozen)

    def oldest_age_s(self, time_s: float, used: tuple[str, ...] | None = None) -> float:
        """Seconds since the stalest channel (of ``used``, default all) last gave a usable
        sample (0 before any)."""
        ages = [time_s - t for name, t in zip(self.names, self._fresh_s)
                if math.isfinite(t) and (used is None or name in used)]
        return max(ages, default=0.0)
