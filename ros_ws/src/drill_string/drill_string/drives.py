"""The drilling-mode drives: the top drive (rotary speed, rad/s) and the block feed (the
drawworks lowering the block, m/s, positive down). Each is a first-order lag with range
and rate limits on the driller's speed command, the tripping actuators' lag
(drill_plant.actuators.FirstOrderLag); a non-finite command holds the last one. Plain
Python; ``drill_string.ros.actuator_node`` moves it to topics."""
from __future__ import annotations

import math

from drill_core.config import Lag
from drill_plant.actuators import FirstOrderLag, FrameOutput


class SpeedDrive:
    """A speed-commanded drive; ``frame`` gives its output samples over one sensor frame."""

    def __init__(self, lag: Lag, initial: float):
        self.lag = FirstOrderLag(lag, initial)
        self.command = self.lag.value

    def frame(self, command: float, step_s: float, steps: int) -> FrameOutput:
        """The output at the start of each of ``steps`` steps toward ``command`` (limited
        to the drive's range; non-finite: the last command held)."""
        if math.isfinite(command):
            self.command = self.lag.limit(command)
        return FrameOutput(self.command, command, self.lag.advance(self.command, step_s, steps))
