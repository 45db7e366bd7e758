"""Whether the drawworks follows its reference, judged from its own frames.

A drawworks that is stuck (a brake set, a fault) does not move its block while its
reference runs on; when it lets go it catches up at its speed limit, and the string,
jerked, swabs or surges (docs/faults.md, the fault matrix). The string's position says
little here (a string stopped at speed rings on its stretch, and the block controller's
integral lets the string rest a metre from its reference), so the watch reads the
drawworks' frames, the block output its encoder reports: over a short window the
reference moved and the block did not. Plain Python; the protection acts on it.
"""
from __future__ import annotations

import math
from collections import deque

from drill_core.config import DrawworksWatch as DrawworksWatchConfig


class DrawworksWatch:
    """``frame`` each drawworks frame (its stamp, the reference it followed, its block
    output samples); ``not_following(now_s)`` says whether, over the window before
    ``now_s``, the reference moved at least ``reference_travel_m`` (in the frames the block
    has had ``response_s`` to answer) while the block moved less than ``block_travel_m``;
    once it does, it keeps saying so for ``hold_s``."""

    def __init__(self, config: DrawworksWatchConfig):
        self.config = config
        self.frames: deque[tuple[float, float, float, float]] = deque()  # (t s, ref m, block lo, hi m)
        self.held_until_s = -math.inf

    def frame(self, stamp_s: float, reference_m: float, output) -> None:
        """One drawworks frame stamped ``stamp_s`` [s] (reference NaN: braked, none
        followed; non-finite output samples are left out, a frame without any is not
        judged)."""
        values = [float(v) for v in output if math.isfinite(v)]
        lo, hi = (min(values), max(values)) if values else (math.nan, math.nan)
        self.frames.append((stamp_s, float(reference_m), lo, hi))
        while self.frames and self.frames[0][0] < stamp_s - self.config.window_s:
            self.frames.popleft()

    def has(self, stamp_s: float) -> bool:
        """Whether the frame stamped ``stamp_s`` has come."""
        return any(f[0] == stamp_s for f in self.frames)

    def not_following(self, now_s: float) -> bool:
        """The judgement at ``now_s`` from the frames stamped within the window before it."""
        c = self.config
        if now_s < self.held_until_s:
            return True
        seen = [f for f in self.frames if now_s - c.window_s <= f[0] < now_s]
        if len(seen) < 2 or not all(math.isfinite(v) for f in seen for v in f[1:]):
            return False          # too few frames, braked (its own stop) or a blank output
        references = [f[1] for f in seen if f[0] <= now_s - c.response_s]   # answered since
        block_travel = max(f[3] for f in seen) - min(f[2] for f in seen)
        reference_travel = max(references) - min(references) if references else 0.0
        if reference_travel >= c.reference_travel_m and block_travel < c.block_travel_m:
            self.held_until_s = now_s + c.hold_s
            return True
        return False
