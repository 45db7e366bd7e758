"""How late the realtime plant's frames start against their timer's schedule, and how
many the timer skipped. A ROS timer that fires more than a period late skips the periods
it missed and keeps its phase, so frame k is due at the first frame's time plus a whole
number of periods: a frame's lateness is how much later than the last such time it
started, and the periods passed over without a frame are counted as skipped (the plant's
physics then lags the wall clock by as many frames)."""
from __future__ import annotations

import math

import numpy as np

_EARLY_TOLERANCE = 0.5          # a frame up to half a period early is on its own period


class FrameLateness:
    """Lateness of each frame [s] against its period's start (the first frame sets the
    schedule) and the periods skipped."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self.first_s: float | None = None
        self.periods = 0                   # the schedule's periods passed, this one included
        self.skipped = 0
        self.late_s: list[float] = []

    def tick(self, now_s: float) -> float:
        """Frame started at wall time ``now_s``; returns its lateness [s]."""
        if self.first_s is None:
            self.first_s = now_s
        period = max(self.periods,
                     math.floor((now_s - self.first_s) / self.period_s + _EARLY_TOLERANCE))
        self.skipped += max(0, period - self.periods)
        self.periods = period + 1
        late = max(0.0, now_s - (self.first_s + period * self.period_s))
        self.late_s.append(late)
        return late

    def values(self) -> dict[str, float]:
        """p99 and max lateness so far [s] (0 before any frame), the periods skipped."""
        if not self.late_s:
            return {"frame_late_p99_s": 0.0, "frame_late_max_s": 0.0, "frames_skipped": 0.0}
        late = np.asarray(self.late_s)
        return {"frame_late_p99_s": float(np.percentile(late, 99)),
                "frame_late_max_s": float(np.max(late)), "frames_skipped": float(self.skipped)}
