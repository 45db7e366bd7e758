"""Open-loop command sequence (controller ``open_loop``; docs/design.md §8, the paper's
estimation study, sec. 4.3: run in 28 m with circulation off, choke 50 %, back-pressure
pump ramped to 400 L/min at t = 2 min).

The actuator commands at time t follow from the scenario schedule alone, no feedback:

* block-position reference u_r: each block move goes from rest to rest toward
  ``block_position_target_m`` with a trapezoidal speed profile (``block_speed_mps``,
  ``block_acceleration_mps2``), so process protection's acceleration limit (docs/design.md
  §10) never has to clip it; a move starts only once the previous one has ended;
* back-pressure pump flow: a linear ramp over ``bpp_ramp_s`` from the flow in force at
  the entry's time to ``bpp_flow_m3s`` (a step without ``bpp_ramp_s``);
* choke: ``choke_opening`` puts it in manual mode at that opening, ``choke_flow_ref_m3s``
  back on its PI flow controller with that reference;
* mud pump: ``mud_pump_on``, at the stand-pipe pressure of the initial operating point.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from drill_core.schema import FieldError

_TIME_TOLERANCE_S = 1e-9        # command stamps are integer ns, schedule times YAML floats
_BLOCK_FIELDS = ("block_position_target_m", "block_speed_mps", "block_acceleration_mps2")


@dataclass(frozen=True)
class OpenLoopCommand:
    """The commands in force (the fields of drill_msgs/RigCommand, SI)."""
    block_position_ref_m: float     # block-position reference u_r, positive up [m]
    choke_manual: bool              # true: the choke holds choke_opening
    choke_opening: float            # manual choke opening [1]
    choke_flow_ref_m3s: float       # reference of the choke's PI flow controller [m^3/s]
    bpp_flow_m3s: float             # back-pressure pump flow [m^3/s]
    spp_pa: float                   # stand-pipe pressure while the mud pump runs [Pa]
    mud_pump_on: bool


def start_command(initial, choke_flow_m3s: float = math.nan, spp_pa: float = math.nan
                  ) -> OpenLoopCommand:
    """Commands before the first entry: block at rest at 0, choke on its PI flow controller
    and pumps at the scenario's ``initial`` operating point (choke flow and stand-pipe
    pressure from drill_core.operating_point; NaN where only the plan's shape
    matters, as in scenario validation)."""
    return OpenLoopCommand(block_position_ref_m=0.0, choke_manual=False, choke_opening=0.0,
                           choke_flow_ref_m3s=choke_flow_m3s, bpp_flow_m3s=initial.bpp_flow_m3s,
                           spp_pa=spp_pa, mud_pump_on=initial.circulation_m3s > 0.0)


@dataclass(frozen=True)
class BlockMove:
    """Rest-to-rest move of the block reference: accelerate, cruise, decelerate."""
    start_s: float
    from_m: float
    to_m: float
    speed_mps: float
    acceleration_mps2: float

    @property
    def ramp_s(self) -> float:
        """Duration of the acceleration phase (= the deceleration phase)."""
        distance = abs(self.to_m - self.from_m)
        return min(self.speed_mps / self.acceleration_mps2,
                   math.sqrt(distance / self.acceleration_mps2))

    @property
    def duration_s(self) -> float:
        peak = self.acceleration_mps2 * self.ramp_s
        return 2.0 * self.ramp_s + (abs(self.to_m - self.from_m) - peak * self.ramp_s) / peak

    def position_m(self, t_s: float) -> float:
        a, t_a, total = self.acceleration_mps2, self.ramp_s, self.duration_s
        tau = min(max(t_s - self.start_s, 0.0), total)
        if tau <= t_a:
            moved = 0.5 * a * tau ** 2
        elif tau <= total - t_a:
            moved = 0.5 * a * t_a ** 2 + a * t_a * (tau - t_a)
        else:
            moved = abs(self.to_m - self.from_m) - 0.5 * a * (total - tau) ** 2
        return self.from_m + math.copysign(moved, self.to_m - self.from_m)


@dataclass(frozen=True)
class Ramp:
    """Linear change from ``from_value`` at ``start_s`` to ``to_value`` over ``duration_s``."""
    start_s: float
    from_value: float
    to_value: float
    duration_s: float

    def value(self, t_s: float) -> float:
        if t_s >= self.start_s + self.duration_s:
            return self.to_value
        fraction = max(t_s - self.start_s, 0.0) / self.duration_s
        return self.from_value + (self.to_value - self.from_value) * fraction


class OpenLoopPlan:
    """A schedule's commands as functions of time, checked once when built.

    Bad entries raise :class:`FieldError` naming ``schedule[i].<field>``.
    """

    def __init__(self, schedule, start: OpenLoopCommand):
        self.start = start
        self.moves: list[BlockMove] = []
        self.ramps: list[Ramp] = []
        self.switches: list[tuple[float, dict]] = []    # choke mode and mud pump changes
        speed = acceleration = math.nan
        for i, entry in enumerate(schedule):
            t = entry.time_s
            block = entry.changes(_BLOCK_FIELDS)
            speed = block.get("block_speed_mps", speed)
            acceleration = block.get("block_acceleration_mps2", acceleration)
            if block:
                self._check_at_rest(i, t)
            target = block.get("block_position_target_m")
            if target is not None and target != self.rest_position_m:
                for name, value in (("block_speed_mps", speed), ("block_acceleration_mps2", acceleration)):
                    if math.isnan(value):
                        raise FieldError(f"schedule[{i}].{name}", "a block move needs a block speed and "
                                         "acceleration, set in this or an earlier entry")
                self.moves.append(BlockMove(t, self.rest_position_m, target, speed, acceleration))
            self._add_bpp(i, entry)
            self._add_switches(i, entry)

    @property
    def rest_position_m(self) -> float:
        """Where the block reference stops after the last move."""
        return self.moves[-1].to_m if self.moves else self.start.block_position_ref_m

    def _check_at_rest(self, i: int, t_s: float) -> None:
        if self.moves and self.moves[-1].start_s + self.moves[-1].duration_s > t_s + _TIME_TOLERANCE_S:
            move = self.moves[-1]
            raise FieldError(f"schedule[{i}].time_s", (
                f"the block reference is still moving at {t_s:g} s (from {move.from_m:g} m to "
                f"{move.to_m:g} m until {move.start_s + move.duration_s:.1f} s); a block move or "
                "speed change may follow only once it has ended"))

    def _add_bpp(self, i: int, entry) -> None:
        bpp = entry.changes(("bpp_flow_m3s", "bpp_ramp_s"))
        if "bpp_ramp_s" in bpp and "bpp_flow_m3s" not in bpp:
            raise FieldError(f"schedule[{i}].bpp_ramp_s", "a ramp needs its bpp_flow_m3s in the same entry")
        if "bpp_flow_m3s" in bpp:
            self.ramps.append(Ramp(entry.time_s, self._bpp_at(entry.time_s), bpp["bpp_flow_m3s"],
                                   bpp.get("bpp_ramp_s", 0.0)))

    def _add_switches(self, i: int, entry) -> None:
        change = entry.changes(("choke_opening", "choke_flow_ref_m3s", "mud_pump_on"))
        if "choke_opening" in change and "choke_flow_ref_m3s" in change:
            raise FieldError(f"schedule[{i}].choke_flow_ref_m3s",
                             "choke_opening (manual) and choke_flow_ref_m3s (automatic) exclude each other")
        if change.get("mud_pump_on") and not self.start.mud_pump_on:
            raise FieldError(f"schedule[{i}].mud_pump_on", "the run starts with circulation off, so there "
                             "is no stand-pipe pressure to run the mud pump at")
        fields = {}
        if "choke_opening" in change:
            fields.update(choke_manual=True, choke_opening=change["choke_opening"])
        if "choke_flow_ref_m3s" in change:
            fields.update(choke_manual=False, choke_flow_ref_m3s=change["choke_flow_ref_m3s"])
        if "mud_pump_on" in change:
            fields["mud_pump_on"] = change["mud_pump_on"]
        if fields:
            self.switches.append((entry.time_s, fields))

    def _bpp_at(self, t_s: float) -> float:
        value = self.start.bpp_flow_m3s
        for ramp in self.ramps:
            if ramp.start_s <= t_s + _TIME_TOLERANCE_S:
                value = ramp.value(t_s)
        return value

    def command_at(self, t_s: float) -> OpenLoopCommand:
        """The commands in force at ``t_s`` (seconds from the start of the run)."""
        block = self.start.block_position_ref_m
        for move in self.moves:
            if move.start_s <= t_s + _TIME_TOLERANCE_S:
                block = move.position_m(t_s)
        fields = {}
        for time_s, change in self.switches:
            if time_s <= t_s + _TIME_TOLERANCE_S:
                fields.update(change)
        return dataclasses.replace(self.start, block_position_ref_m=block,
                                   bpp_flow_m3s=self._bpp_at(t_s), **fields)
