"""drill_msgs/RigFloor to and from the rig floor's command (drill_core.tripping.rig_floor):
the one place the floor's decisions become a message and a message becomes them again."""
from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from drill_msgs.msg import RigFloor

from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand
from drill_core.tripping.sequence import TripStep


def _none_as_nan(value: float | None) -> float:
    return math.nan if value is None else float(value)


def floor_message(command: FloorCommand, programme: TripProgramme, stamp: Time) -> RigFloor:
    """The floor's ``command`` on the trip ``programme`` stamped ``stamp``."""
    s = command.step
    msg = RigFloor(direction=programme.direction, stand_length_m=programme.stand_length_m,
                   stands=int(programme.stands),
                   discrepancy_alarm_m3=float(programme.discrepancy_alarm_m3),
                   phase=s.phase, stand=int(s.stand), stands_pulled=int(s.stands_pulled),
                   slips_set=bool(s.slips_set), latched=bool(s.latched),
                   pump_factor=float(s.pump_factor),
                   bit_height_target_m=float(s.bit_height_target_m),
                   block_target_m=float(command.block_target_m),
                   racked_from_m=_none_as_nan(command.racked_from_m),
                   racked_to_m=_none_as_nan(command.racked_to_m))
    msg.header.stamp = stamp
    return msg


def floor_programme(msg: RigFloor) -> TripProgramme:
    """What of the trip's programme a message carries: its direction, stands, their length
    and the trip sheet's alarm limit (the rest at the programme's defaults)."""
    return TripProgramme(direction=msg.direction, stands=int(msg.stands),
                         stand_length_m=float(msg.stand_length_m),
                         discrepancy_alarm_m3=float(msg.discrepancy_alarm_m3))


def floor_command(msg: RigFloor) -> FloorCommand:
    """The floor's command a message carries."""
    racked = math.isfinite(msg.racked_to_m)
    step = TripStep(phase=msg.phase, stand=int(msg.stand), slips_set=bool(msg.slips_set),
                    latched=bool(msg.latched), pump_factor=float(msg.pump_factor),
                    bit_height_target_m=float(msg.bit_height_target_m),
                    stands_pulled=int(msg.stands_pulled))
    return FloorCommand(step, float(msg.block_target_m),
                        float(msg.racked_from_m) if racked else None,
                        float(msg.racked_to_m) if racked else None)
