"""``rig run``'s progress in fast mode: simulated time, wall time and the real-time factor
as the run goes, from the plant's marker lines (drill_ros.progress). On a terminal one
line rewritten in place; otherwise (a CI log) a plain line every PLAIN_EVERY_S of
simulated time."""
from __future__ import annotations

import sys
import time
from pathlib import Path

from drill_ros import progress

PLAIN_EVERY_S = 100.0        # simulated seconds between plain lines
POLL_EVERY_S = 1.0           # wall seconds between looks at the log


class ProgressDisplay:
    def __init__(self, plant_log: Path, started_s: float, terminal: bool, out=sys.stdout,
                 clock=time.monotonic):
        self.log, self.started_s, self.terminal, self.out, self.clock = \
            plant_log, started_s, terminal, out, clock
        self._looked_s = -POLL_EVERY_S
        self._shown_s = 0.0
        self._next_plain_s = PLAIN_EVERY_S

    def line(self, simulated_s: float, duration_s: float, wall_s: float) -> str:
        return (f"[rig] {simulated_s:.0f} / {duration_s:.0f} s simulated, {wall_s:.0f} s wall, "
                f"real-time factor {wall_s / simulated_s:.3f}")

    def poll(self) -> None:
        """Look at the plant's log (at most once a second) and show what is new."""
        now_s = self.clock()
        if now_s - self._looked_s < POLL_EVERY_S:
            return
        self._looked_s = now_s
        last = progress.last_marker(self.log)
        if last is None or last[0] <= self._shown_s:
            return
        simulated_s, duration_s = last
        self._shown_s = simulated_s
        text = self.line(simulated_s, duration_s, now_s - self.started_s)
        if self.terminal:
            self.out.write("\r" + text)
        elif simulated_s >= self._next_plain_s:
            self.out.write(text + "\n")
            self._next_plain_s = (simulated_s // PLAIN_EVERY_S + 1) * PLAIN_EVERY_S
        else:
            return
        self.out.flush()

    def close(self) -> None:
        """End the rewritten line."""
        if self.terminal and self._shown_s > 0.0:
            self.out.write("\n")
            self.out.flush()
