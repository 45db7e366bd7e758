"""The last frame of a multi-stand trip's run: the scenario's ``duration_s`` at the latest,
or the trip's ``settle_s`` after the rig floor first reports it done. The plant and, in
fast mode, the estimator read the same floor frames, so each ends on the same sample."""
from __future__ import annotations

import math

from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import DONE


class RunEnd:
    """``last_k``: the run's last frame (its stamp ``last_k`` x the frame period)."""

    def __init__(self, duration_s: float, frame_s: float, programme: TripProgramme | None):
        self.frame_s = frame_s
        self.last_k = int(round(duration_s / frame_s))
        settle_s = None if programme is None else programme.settle_s
        # at least one frame after the floor's: the estimator reads the floor's frame t_k
        # with the measurement t_{k+1}
        self._settle_frames = None if settle_s is None \
            else max(1, math.ceil(round(settle_s / frame_s, 9)))
        self.done_k: int | None = None

    def floor_frame(self, k: int, phase: str) -> None:
        """The rig floor's command stamped frame ``k`` is in ``phase``."""
        if self.done_k is None and phase == DONE:
            self.done_k = k
            if self._settle_frames is not None:
                self.last_k = min(self.last_k, k + self._settle_frames)

    @property
    def end_s(self) -> float:
        """The run's last sample time [s]."""
        return self.last_k * self.frame_s
