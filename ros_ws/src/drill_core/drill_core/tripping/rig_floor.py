"""The rig floor's machines on a multi-stand trip, as a tick class: the stand sequencer
(drill_core.tripping.sequence) fed from the floor's own instruments (the hook load, the
string's position, the block's encoder), and the block's moves while the string is in
the slips, where the string's position says nothing of the block.

Per phase the block is on the string's loop (moving: the controller's reference) or on
its encoder with a target in the string's frame: lifted until the line carries the
string (pick up), lowered until it is slack (set slips), held (pump ramps), a stand down
(pulling out) or up (running in) while the connection is made, so that it meets the new
top of the string slack when the elevator latches. At the end of each connection the
floor says which length the string is tripped to (the plant racks it, the estimators
change their model) and the string's position counts from the new top
(sequence.position_after_connection).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.config import Well
from drill_core.tripping.hoist import buoyed_weight_n
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import (CONNECTION, MOVING, PICK_UP, SET_SLIPS, StandSequencer,
                                          TripStep, position_after_connection)
from drill_core.tripping.stands import tripped_geometry

LIFT_OVERTRAVEL_M = 0.10     # picking up, the block aims this far past the string's stretch
SLACK_UNDERTRAVEL_M = 0.05   # slacking off, this far below the string's top
LATCH_TOLERANCE_M = 0.05     # a connection ends with the block this close to the new top ...
LATCH_SPEED_MPS = 0.01       # ... and this slow


@dataclass(frozen=True)
class FloorCommand:
    """What the floor does after one tick (SI)."""
    step: TripStep
    block_target_m: float        # the block on its encoder to here [m]; NaN: on the string's loop
    racked_from_m: float | None  # the string tripped on this tick from this length pulled ...
    racked_to_m: float | None    # ... to this one [m]

    def advisor_target_m(self, string_position_m: float, stand_length_m: float) -> float:
        """The block target an advisor plans to, in the present string's frame [m]: the
        stand's end while it moves, else where the string is (the floor has it)."""
        if self.step.phase != MOVING:
            return string_position_m
        return self.step.bit_height_target_m - self.step.stands_pulled * stand_length_m

    @property
    def string_held(self) -> bool:
        """The slips hold the still string over the frame and the block moves on its own
        (the estimator's model then holds the string at rest on the line)."""
        return self.step.slips_set and self.step.phase != MOVING

    @property
    def pump_stopped(self) -> bool:
        """The floor has the mud pump stopped for the connection (its share 0): the string-
        flow meter reads nothing, by plan rather than by a trip of the pump."""
        return self.step.pump_factor == 0.0


class RigFloor:
    """``step`` once per sensor sample with the floor's measurements."""

    def __init__(self, well: Well, programme: TripProgramme, start_time_s: float,
                 stands_pulled: int = 0):
        self.well = well
        self.programme = programme
        self._geometry = tripped_geometry(well, stands_pulled, programme.stand_length_m)
        self.sequencer = StandSequencer(programme, self._weight_n(), start_time_s, stands_pulled)
        self._phase: str | None = None                 # the phase of the last tick
        self._phase_start_position_m = math.nan        # the string's position as it began
        self.stands_pulled = stands_pulled

    @property
    def pulled_m(self) -> float:
        return self.stands_pulled * self.programme.stand_length_m

    def _weight_n(self) -> float:
        return buoyed_weight_n(self._geometry, self.well.gravity_mps2)

    def step(self, time_s: float, hook_load_n: float, string_position_m: float,
             block_position_m: float, block_speed_mps: float) -> FloorCommand:
        """Advance on the hook load [N], the string's position in the present string's
        frame [m] and the block's position and speed from its encoder [m, m/s]. A
        connection lasts its programmed time and until the block has reached the new top
        of the string (its travel of a stand may take longer)."""
        tension = hook_load_n - self.well.travelling_block_weight_n
        ready = True
        if self._phase == CONNECTION:
            target = self._block_target_m(CONNECTION, string_position_m)
            ready = (abs(block_position_m - target) <= LATCH_TOLERANCE_M
                     and abs(block_speed_mps) <= LATCH_SPEED_MPS)
        step = self.sequencer.step(time_s, self.pulled_m + string_position_m, block_speed_mps,
                                   tension, ready)
        racked_from = racked_to = None
        if step.stands_pulled != self.stands_pulled:
            racked_from = self.pulled_m
            self.stands_pulled = step.stands_pulled
            self._geometry = tripped_geometry(self.well, self.stands_pulled,
                                              self.programme.stand_length_m)
            self.sequencer.weight_n = self._weight_n()
            racked_to = self.pulled_m
            string_position_m = position_after_connection(string_position_m, racked_from,
                                                          racked_to)
        if step.phase != self._phase:
            self._phase = step.phase
            self._phase_start_position_m = string_position_m
        return FloorCommand(step, self._block_target_m(step.phase, string_position_m),
                            racked_from, racked_to)

    def _block_target_m(self, phase: str, string_position_m: float) -> float:
        held_at = self._phase_start_position_m
        if phase == MOVING:
            return math.nan
        if phase == PICK_UP:
            return held_at + self._geometry.static_stretch_m + LIFT_OVERTRAVEL_M
        if phase == SET_SLIPS:
            return held_at - SLACK_UNDERTRAVEL_M
        if phase == CONNECTION:      # a stand down pulling out (sign +1), up running in
            return held_at - self.sequencer.sign * self.programme.stand_length_m
        return held_at
