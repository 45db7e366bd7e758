"""The protection node's per-sample logic as a plain tick class (no rclpy): every
measurement screened for frozen gauges (drill_protection.reading) and fed to the
measurement watch (drill_protection.watch), the operator's buttons
(the emergency stop, the automation level) and the scenario's operator actions
(drill_core.operator_actions) pressing them, the limiter (drill_protection.protection)
between an advisor's command and the machines with the machine command it sends, and the
pore/fracture window's exits and returns. The node moves messages in and out; the
in-process loop bench (drill_studies.loop_bench) steps the same class."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from drill_core.automation import AUTOMATION_LEVELS
from drill_core.config import RigConfig
from drill_core.event_codes import Notice
from drill_core.hydraulics import WellModel
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.operator_actions import OperatorScript
from drill_core.tripping.sequence import CONNECTION_PHASES, position_after_connection
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import TripSheet
from drill_core.units import PA_PER_BAR
from drill_protection.actuator_watch import ActuatorWatch, PumpDeliveryWatch, StuckValveWatch
from drill_protection.protection import Decision, ProcessProtection
from drill_protection.reading import ReadingScreen
from drill_protection.watch import MeasurementWatch


@dataclass(frozen=True)
class MachineCommand:
    """What goes to the machines: drill_msgs/RigCommand's fields but its header and
    source, each with the message's meaning and unit (SI)."""
    block_position_ref_m: float
    choke_flow_ref_m3s: float
    bpp_flow_m3s: float
    spp_pa: float
    mud_pump_on: bool
    choke_manual: bool
    choke_opening_ref: float
    choke_pressure_control: bool
    choke_dp_ref_pa: float
    choke_dp_ref_rate_pa_s: float
    bhp_ref_pa: float
    bhp_window_low_pa: float
    bhp_window_high_pa: float
    trip_speed_limit_in_mps: float
    trip_speed_limit_out_mps: float
    emergency_stop: bool
    emergency_bhp_pa: float

    @classmethod
    def as_requested(cls, request) -> "MachineCommand":
        """An advisor's request sent to the machines unchanged: no protection between
        (an in-process bench's open loop), no emergency stop."""
        return cls(**{f.name: getattr(request, f.name) for f in fields(cls)
                      if f.name not in ("emergency_stop", "emergency_bhp_pa")},
                   emergency_stop=False, emergency_bhp_pa=math.nan)


class ProtectionTick:
    """``observe`` each measurement, ``limit`` each advisor command against the latest.

    A request is anything with drill_msgs/RigCommand's command fields (SI):
    block_position_ref_m, choke_flow_ref_m3s, bpp_flow_m3s, spp_pa, mud_pump_on,
    choke_manual, choke_opening_ref, choke_pressure_control, choke_dp_ref_pa,
    choke_dp_ref_rate_pa_s, bhp_ref_pa, trip_speed_limit_in_mps, trip_speed_limit_out_mps.
    A measurement is anything with
    drill_msgs/RigMeasurement's fields."""

    def __init__(self, config: RigConfig, wm: WellModel, scenario, op):
        """The machines start from ``scenario``'s ``initial`` section at its operating point
        ``op`` (drill_core.operating_point): the block at 0, the operating point's choke flow
        and stand-pipe pressure, the initial bpp flow."""
        start = np.array([0.0, float(op.choke_flow_m3s), float(scenario.initial.bpp_flow_m3s),
                          float(op.inputs[U_PUMP_PRESSURE])])
        self.protection = ProcessProtection(config, wm, start)
        self.watch = MeasurementWatch(config, wm, self.protection,
                                      trip_tank=scenario.trip is not None)
        self.screen = ReadingScreen(config.protection.frozen_after_samples)
        self.drawworks = ActuatorWatch(config.protection.drawworks_watch)
        self.choke = StuckValveWatch(config.protection.choke_watch, config.actuators.choke)
        self.bpp = PumpDeliveryWatch(config.protection.bpp_watch, config.actuators.bpp,
                                     start[U_BPP_FLOW])
        self.choke_on_flow_loop = True      # the last decision's choke mode
        self.return_flow_m3s = math.nan     # the last measured return flow (the choke's)
        self.script = OperatorScript(scenario.operator)
        self.floor_step = None              # the rig floor's last step (a multi-stand trip)
        # a multi-stand trip's sheet, kept live for its trip-tank alarm (the band unused)
        self.trip_sheet = None if scenario.trip is None else TripSheet(
            scenario.trip, StandVolumes.of(wm.geometry, scenario.trip.stand_length_m), math.inf)
        self.formation = config.well.formation
        self.in_window = True
        self.window_exits = 0

    def floor(self, command) -> None:
        """The rig floor's command for the frame before the next measurement
        (drill_core.tripping.rig_floor): at a connection the string's position counts from
        its new top, so the block reference and the positions the protection keeps move with
        it; the phase says whether the mud pump is stopped by the floor (not a loss)."""
        if command.racked_to_m is not None:
            shift_m = position_after_connection(0.0, command.racked_from_m, command.racked_to_m)
            self.protection.previous[U_BLOCK] += shift_m
            self.watch.recount_positions(shift_m)
        self.floor_step = command.step

    @property
    def in_connection(self) -> bool:
        """The rig floor has the mud pump under its rate for a connection (not a loss; the
        flows not balanced)."""
        return self.floor_step is not None and self.floor_step.phase in CONNECTION_PHASES

    def observe(self, stamp_ns: int, m) -> list[Notice]:
        """One measurement screened (a gauge found frozen or live again is announced) and
        through the watch (and on a multi-stand trip through the trip sheet, whose trip tank
        against the steel tripped raises its own alarm): the notices it raised."""
        notices = self.screen.observe(stamp_ns * 1e-9, m)
        m = self.screen.of(m)
        self.return_flow_m3s = m.return_flow_m3s
        self.bpp.observe(stamp_ns * 1e-9, m.bpp_flow_m3s)
        notices += self.watch.observe(stamp_ns, m, balance=not self.in_connection)
        if self.trip_sheet is not None and self.floor_step is not None:
            alarms = self.trip_sheet.observe(stamp_ns * 1e-9, self.floor_step, m.bhp_pa,
                                             math.nan, m.trip_tank_volume_m3)
            self.watch.alarm_count += len(alarms)
            notices += alarms
        return notices

    def observe_frame(self, actuator: str, stamp_ns: int, reference: float, output) -> None:
        """One frame of the drawworks or the choke (drill_msgs/ActuatorFrame's stamp,
        reference and output). The choke is judged on its flow loop only (its reference is
        then a flow; on the pressure loop a set-point): the loop's error against the last
        measured return flow."""
        if actuator == "drawworks":
            self.drawworks.frame(stamp_ns * 1e-9, reference, output)
        elif actuator == "choke":
            error = reference - self.return_flow_m3s if self.choke_on_flow_loop else math.nan
            self.choke.frame(stamp_ns * 1e-9, error, output)

    def has_frames(self, stamp_ns: int) -> bool:
        """Whether the drawworks' and the choke's frames stamped ``stamp_ns`` have come."""
        t = stamp_ns * 1e-9
        return self.drawworks.has(t) and self.choke.has(t)

    def limit(self, request, m, stamp_ns: int, latched_speed_limit_mps: float) -> Decision:
        """``request`` limited with the measurement ``m`` at ``stamp_ns`` (its gauges
        screened as the last ``observe`` found them; the drawworks' and the choke's frames
        stamped before it), under the
        operator's trip-speed limit the advisor planned it under (it rides on the command,
        so every run applies it at the same stamp), else ``latched_speed_limit_mps`` (the
        latched setpoints'; the open-loop sequencer sends none) [m/s]."""
        m = self.screen.of(m)
        limit = min(request.trip_speed_limit_in_mps, request.trip_speed_limit_out_mps)
        operator_speed_limit_mps = limit if math.isfinite(limit) and limit > 0.0 \
            else latched_speed_limit_mps
        circulation = m.string_flow_m3s if m.string_flow_valid and math.isfinite(m.string_flow_m3s) \
            else 0.0
        self.watch.circulation.request(request.mud_pump_on and not self.in_connection,
                                       request.spp_pa)
        decision = self.protection.apply(
            [request.block_position_ref_m, request.choke_flow_ref_m3s, request.bpp_flow_m3s,
             request.spp_pa], m.block_position_m, self.watch.velocity_mps, m.bhp_pa,
            max(circulation, 0.0), operator_speed_limit_mps,
            request.choke_opening_ref if request.choke_manual else None,
            (request.choke_dp_ref_pa, request.choke_dp_ref_rate_pa_s)
            if request.choke_pressure_control else None,
            surface_flows=(m.return_flow_m3s, m.bpp_flow_m3s),
            trip_action=self.watch.circulation.action(stamp_ns * 1e-9),
            advisor_bhp_ref_pa=request.bhp_ref_pa, choke_dp_pa=m.choke_dp_pa,
            block_not_following=self.drawworks.not_following(stamp_ns * 1e-9),
            choke_not_following=self.choke.not_following(stamp_ns * 1e-9),
            choke_moving=self.choke.moving(stamp_ns * 1e-9),
            bpp_not_delivering=self.bpp.not_delivering,
            surface_bhp_pa=self.watch.circulation.judged_bhp_pa())
        self.bpp.command(decision.command[U_BPP_FLOW])
        self.choke_on_flow_loop = decision.manual_choke_opening is None and \
            decision.choke_dp_setpoint is None and not decision.emergency_stop
        return decision

    def machine_command(self, decision: Decision, request) -> MachineCommand:
        """The machine command of ``decision`` on ``request`` (the window in force on it)."""
        manual = decision.manual_choke_opening
        dp_setpoint = decision.choke_dp_setpoint
        c = decision.command
        return MachineCommand(
            block_position_ref_m=float(c[U_BLOCK]), choke_flow_ref_m3s=float(c[U_CHOKE]),
            bpp_flow_m3s=float(c[U_BPP_FLOW]), spp_pa=float(c[U_PUMP_PRESSURE]),
            mud_pump_on=request.mud_pump_on, choke_manual=manual is not None,
            choke_opening_ref=float(manual) if manual is not None else 0.0,
            choke_pressure_control=dp_setpoint is not None,
            choke_dp_ref_pa=float(dp_setpoint[0]) if dp_setpoint
            else decision.emergency_dp_start_pa if decision.emergency_stop else 0.0,
            choke_dp_ref_rate_pa_s=float(dp_setpoint[1]) if dp_setpoint else 0.0,
            bhp_ref_pa=decision.bhp_ref_pa,
            bhp_window_low_pa=float(self.protection.window_pa[0]),
            bhp_window_high_pa=float(self.protection.window_pa[1]),
            trip_speed_limit_in_mps=float(decision.standing_speed_limits_mps[0]),
            trip_speed_limit_out_mps=float(decision.standing_speed_limits_mps[1]),
            emergency_stop=decision.emergency_stop, emergency_bhp_pa=decision.emergency_bhp_pa)

    def set_emergency_stop(self, engaged: bool, by: str = "") -> list[Notice]:
        """Engage or release the emergency stop; its notice if that changed it."""
        if engaged == self.protection.emergency_stop:
            return []
        self.protection.emergency_stop = engaged
        word = "engaged" if engaged else "released"
        return [Notice(f"estop_{word}", f"emergency stop {word}{by}")]

    def set_automation_level(self, level: str, by: str = "") -> list[Notice]:
        """Set the automation level; its notice if that changed it, a refusal if unknown."""
        if level not in AUTOMATION_LEVELS:
            return [Notice("level_refused", f"automation level {level!r} is not one of "
                                            f"{', '.join(AUTOMATION_LEVELS)}")]
        if level == self.protection.automation_level:
            return []
        self.protection.automation_level = level
        return [Notice("automation_level", f"automation level {level}{by}")]

    def press_due(self, time_s: float) -> list[Notice]:
        """The scenario's operator actions due by scenario time ``time_s`` [s], pressed."""
        notices = []
        for action in self.script.due(time_s):
            by = f" (scenario operator action at {action.time_s:g} s)"
            if action.action == "automation_level":
                notices += self.set_automation_level(action.level, by)
            else:
                notices += self.set_emergency_stop(action.action == "emergency_stop", by)
        return notices

    def check_window(self, m) -> list[Notice]:
        """The measured BHP of ``m`` against the pore/fracture window: a notice as it leaves
        or returns (a reading without a usable BHP is judged on the next one)."""
        bhp_pa = self.screen.of(m).bhp_pa
        if not math.isfinite(bhp_pa):
            return []
        p = self.formation
        inside = p.pore_pressure_pa <= bhp_pa <= p.fracture_pressure_pa
        if inside == self.in_window:
            return []
        self.in_window = inside
        self.window_exits += 0 if inside else 1
        return [Notice("window_return" if inside else "window_exit", f"BHP "
                       f"{bhp_pa / PA_PER_BAR:.1f} bar " + ("back inside" if inside else "outside")
                       + f" the pore/fracture window {p.pore_pressure_pa / PA_PER_BAR:.0f}-"
                       f"{p.fracture_pressure_pa / PA_PER_BAR:.0f} bar", bhp_pa)]
