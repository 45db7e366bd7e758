"""How late the realtime plant's frames are against the wall clock: frame k is due at the
first frame's time plus k periods; its lateness is how much later it started."""
from __future__ import annotations

import numpy as np


class FrameLateness:
    """Lateness of each frame [s] against its due time (the first frame sets the grid)."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self.first_s: float | None = None
        self.frames = 0
        self.late_s: list[float] = []

    def tick(self, now_s: float) -> float:
        """Frame started at wall time ``now_s``; returns its lateness [s]."""
        if self.first_s is None:
            self.first_s = now_s
        late = max(0.0, now_s - (self.first_s + self.frames * self.period_s))
        self.frames += 1
        self.late_s.append(late)
        return late

    def values(self) -> dict[str, float]:
        """p99 and max lateness so far [s] (0 before any frame)."""
        if not self.late_s:
            return {"frame_late_p99_s": 0.0, "frame_late_max_s": 0.0}
        late = np.asarray(self.late_s)
        return {"frame_late_p99_s": float(np.percentile(late, 99)),
                "frame_late_max_s": float(np.max(late))}
