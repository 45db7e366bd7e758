"""One actuator's per-frame logic as a plain tick class (no rclpy): the command in force,
the command watchdog and its safe state, the emergency stop's brake and BHP loop, the
choke's manual, pressure and flow modes, the scenario's actuator faults (``stuck``
freezes the output, ``trip`` stops a pump whatever it is commanded), and on a multi-stand
trip the rig floor's share (the block on its encoder while the string is in the slips,
the mud pump's ramps around a connection). The actuator node
moves messages in and out; the in-process loop bench (drill_studies.loop_bench) steps
the same class.

A command is anything with drill_msgs/RigCommand's fields (SI); a measurement anything
with drill_msgs/RigMeasurement's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.config import RigConfig
from drill_core.events import of_owner
from drill_core.hydraulics import WellModel
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.tripping.sequence import DONE, MOVING
from drill_plant.actuators import Choke, Drawworks, FrameOutput, Pump, Watchdog

UNITS = {"drawworks": "m", "choke": "1", "bpp": "m^3/s", "mud_pump": "Pa"}   # of each output


@dataclass(frozen=True)
class ActuatorStep:
    """One frame of an actuator: its output, the fault acting ('' none), whether the
    watchdog holds the safe state, and whether the command stream has just gone silent
    (the watchdog tripped with a command seen before)."""
    output: FrameOutput
    fault: str
    watchdog_active: bool
    fell_silent: bool


def command_value(name: str, command) -> float:
    """The command field actuator ``name`` follows (SI; the mud pump's is 0 while off)."""
    if name == "drawworks":
        return command.block_position_ref_m
    if name == "choke":
        return command.choke_flow_ref_m3s
    if name == "bpp":
        return command.bpp_flow_m3s
    return command.spp_pa if command.mud_pump_on else 0.0


class ActuatorTick:
    """``command`` each machine command as it arrives, ``step`` each measurement: the
    output over the coming frame."""

    def __init__(self, name: str, config: RigConfig, wm: WellModel, op, events):
        """Actuator ``name`` (one of UNITS) starting at the operating point ``op``
        (drill_core.operating_point) with the scenario's ``events``."""
        if name not in UNITS:
            raise ValueError(f"actuator {name!r} is not one of {', '.join(UNITS)}")
        self.name = name
        a, inputs = config.actuators, op.inputs
        self.model = {
            "drawworks": lambda: Drawworks(a, wm.geometry.static_stretch_m, float(inputs[U_BLOCK])),
            "choke": lambda: Choke(a, wm, float(inputs[U_CHOKE])),
            "bpp": lambda: Pump(a.bpp, float(inputs[U_BPP_FLOW])),
            "mud_pump": lambda: Pump(a.mud_pump, float(inputs[U_PUMP_PRESSURE])),
        }[name]()
        self.held_command = {"drawworks": 0.0, "choke": op.choke_flow_m3s,
                             "bpp": float(inputs[U_BPP_FLOW]),
                             "mud_pump": float(inputs[U_PUMP_PRESSURE])}[name]
        self.step_s, self.steps = config.plant.step_s, config.plant.steps_per_frame
        self.watchdog = Watchdog(a.watchdog_timeout_s)
        self.faults = of_owner(events, "actuator", name)
        self.command_in_force = None
        self.command_stamp_ns = 0
        self.safe_hold: float | None = None

    def command(self, command, stamp_ns: int, received_ns: int) -> None:
        """The command stamped ``stamp_ns`` is in force from now; it feeds the watchdog at
        ``received_ns``."""
        self.command_in_force, self.command_stamp_ns = command, stamp_ns
        self.watchdog.feed(received_ns)

    def fault(self, time_s: float) -> str:
        """The scenario fault acting at scenario time ``time_s`` ('' none)."""
        return next((e.kind for e in self.faults if e.active(time_s)), "")

    def step(self, m, stamp_ns: int, now_ns: int, time_s: float, floor=None) -> ActuatorStep:
        """The output over the frame from the measurement ``m`` stamped ``stamp_ns``; the
        watchdog judged at ``now_ns``, the scenario's faults at ``time_s``; ``floor`` the
        rig floor's command for the frame (drill_core.tripping.rig_floor; None: no
        multi-stand trip)."""
        tripped = self.watchdog.tripped(now_ns)
        fell_silent = False
        if tripped and self.safe_hold is None:
            self.safe_hold = self._safe_command(m)
            fell_silent = self.command_in_force is not None
        elif not tripped:
            self.safe_hold = None
        target = self.safe_hold if tripped else command_value(self.name, self.command_in_force)
        if floor is not None and self.name == "mud_pump":
            target *= floor.step.pump_factor
        fault = self.fault(time_s)
        if fault == "stuck":
            out = FrameOutput(target, target, self.model.lag.hold(self.steps))
        else:
            out = self._frame(0.0 if fault == "trip" else target, m, stamp_ns, hold=tripped,
                              floor=floor)
        return ActuatorStep(out, fault, tripped, fell_silent)

    def _safe_command(self, m) -> float:
        if self.name == "drawworks":
            return self.model.safe_reference(m.block_position_m)
        if self.command_in_force is None:
            return self.held_command
        return command_value(self.name, self.command_in_force)

    def _frame(self, target: float, m, stamp_ns: int, hold: bool, floor=None) -> FrameOutput:
        cmd, step_s, steps = self.command_in_force, self.step_s, self.steps
        stop = cmd is not None and cmd.emergency_stop      # even if then silent
        if self.name == "drawworks":
            if stop:
                return self.model.brake(step_s, steps)
            if floor is not None and floor.step.phase != MOVING:    # the string in the slips
                done = floor.step.phase == DONE or not math.isfinite(floor.block_target_m)
                return self.model.drive_block(self.model.lag.value if done
                                              else floor.block_target_m, step_s, steps)
            return self.model.frame(target, m.block_position_m, step_s, steps)
        if self.name != "choke":
            return self.model.frame(target, step_s, steps)
        dp_pa, bhp_pa = self.model.gauges(m.choke_dp_pa, m.bhp_pa)
        if stop:
            return self.model.bhp_frame(cmd.emergency_bhp_pa, bhp_pa, cmd.choke_dp_ref_pa,
                                        target, dp_pa, step_s, steps)
        if hold:
            opening = self.model.lag.value
            return FrameOutput(opening, target, self.model.lag.advance(opening, step_s, steps))
        if cmd.choke_pressure_control and not cmd.choke_manual:
            since_s = (stamp_ns - self.command_stamp_ns) * 1e-9
            return self.model.pressure_frame(cmd.choke_dp_ref_pa, cmd.choke_dp_ref_rate_pa_s,
                                             since_s, target, dp_pa, step_s, steps)
        manual = cmd.choke_opening_ref if cmd.choke_manual else None
        return self.model.frame(target, dp_pa, step_s, steps, manual, m.return_flow_m3s)
