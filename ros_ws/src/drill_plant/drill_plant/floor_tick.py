"""The rig floor's per-frame logic on a multi-stand trip as a plain tick class (no rclpy):
the rig floor (drill_core.tripping.rig_floor) fed the measurement at t_k (hook load, the
string's position) and the block's encoder, read from the drawworks' frame before it. The
floor node moves messages in and out; the in-process trip bench (drill_studies.trip_bench)
steps the same class.
"""
from __future__ import annotations

import math

from drill_core.config import Well
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand, RigFloor


class FloorTick:
    """``drawworks_frame`` with each of the drawworks' frames, ``step`` at each sensor
    time: what the floor does over the coming frame."""

    def __init__(self, well: Well, programme: TripProgramme, initial_block_m: float,
                 step_s: float, stands_pulled: int = 0):
        self.floor = RigFloor(well, programme, 0.0, stands_pulled)
        self.step_s = step_s
        self.block_m = initial_block_m       # the encoder at the next step's time [m]
        self.block_speed_mps = 0.0           # [m/s]

    def drawworks_frame(self, output) -> None:
        """The drawworks' output samples over the last frame [m]: the encoder at its end
        (the last sample moved on by its last step's rate) and that rate."""
        out = [float(v) for v in output]
        rate = (out[-1] - out[-2]) / self.step_s if len(out) > 1 else 0.0
        if all(math.isfinite(v) for v in out[-2:]):
            self.block_speed_mps = rate
            self.block_m = out[-1] + rate * self.step_s

    def step(self, time_s: float, hook_load_n: float, string_position_m: float) -> FloorCommand:
        """The floor after the measurement at ``time_s`` [s]: hook load [N], the string's
        position in the present string's frame [m]."""
        return self.floor.step(time_s, hook_load_n, string_position_m, self.block_m,
                               self.block_speed_mps)
