"""Protection node: advisor commands in (/supervisor/command), machine commands out
(/rig/command), every clamp and alarm out as drill_msgs/OperatorEvent on
/protection/events (so they are recorded) and counted on /protection/status.

fast mode: the advisor command stamped t_k is limited with the measurement stamped
t_k and published stamped t_k. realtime mode: each request is limited with the
latest measurement. The latched /setpoints give the operator's trip-speed limit;
the latched /operator/emergency_stop (std_msgs/Bool) sets the drawworks brake and holds the
BHP on the choke's own loop (drill_protection.protection; in realtime a command saying so
goes out at once, not at the next advisor command); the latched
/operator/automation_level (std_msgs/String: manual, advisory, closed_loop) says whether
advisor commands reach the machines (only in closed_loop). The scenario's operator
actions (drill_core.operator_actions) act as the same buttons, at the first command at or
after their time (scenario time: from the first measurement). Every measurement feeds
the protection's measurement watch (drill_protection.watch, which the in-process loop
bench feeds too): the flow-balance kick detector (drill_protection.kick_detection); a
kick or losses alarm is raised and cleared as an event and, with ``stop_trip``, holds the
trip (the block reference brakes to rest within the acceleration limit) until it clears.
Every measurement also feeds the circulation watch (drill_protection.pump_trip): a lost
circulation (the mud pump asked for, the string-flow meter blank) is an alarm, and the
protection answers it until circulation is back or no longer asked for.
"""
from __future__ import annotations

import math
import sys

from drill_msgs.msg import OperatorEvent, RigCommand, RigMeasurement, Setpoints
from std_msgs.msg import Bool, String

from drill_core.automation import AUTOMATION_LEVELS
from drill_core.event_codes import Notice
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.operator_actions import OperatorScript
from drill_core.units import PA_PER_BAR
from drill_core.ros import topics
from drill_core.ros.context import load_context
from drill_core.ros.events import event_message
from drill_core.ros.inbox import StampedInbox
from drill_core.ros.node import RigNode
from drill_core.ros.runner import run
from drill_core.ros.stamps import ScenarioClock, from_ns, to_ns
from drill_core.ros.status import StatusReporter
from drill_protection.tick import ProtectionTick


class ProtectionNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("protection", **node_options)
        ctx = load_context(self)
        self.ctx = ctx
        self.exit_code = 0
        self.tick = ProtectionTick(ctx.config, ctx.well_model, ctx.scenario.initial,
                                   ctx.operating_point)
        self.protection, self.watch = self.tick.protection, self.tick.watch
        self.operator_speed_limit = ctx.config.protection.trip_speed_max_mps
        self.script = OperatorScript(ctx.scenario.operator)
        self.clock = ScenarioClock()             # the operator actions' times
        self.last_request: RigCommand | None = None
        self.inbox = StampedInbox(("command", "measurement"))
        self.clamp_count = 0
        self.window_exits = 0
        self.in_window = True
        self.status = StatusReporter(self, ctx.mode)
        self.pub_command = self.create_publisher(RigCommand, topics.MACHINE_COMMAND, topics.RELIABLE)
        self.pub_events = self.create_publisher(OperatorEvent, topics.PROTECTION_EVENTS, topics.EVENT_LOG)
        self.pub_level = self.create_publisher(String, topics.LEVEL_IN_FORCE, topics.LATCHED)
        self.pub_estop = self.create_publisher(Bool, topics.ESTOP_IN_FORCE, topics.LATCHED)
        self._publish_state()
        self.create_subscription(RigCommand, topics.COMMAND, self._on_command, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        self.create_subscription(Setpoints, topics.SETPOINTS, self._on_setpoints, topics.LATCHED)
        self.create_subscription(Bool, topics.EMERGENCY_STOP, self._on_estop, topics.LATCHED)
        self.create_subscription(String, topics.AUTOMATION_LEVEL, self._on_level, topics.LATCHED)

    def _on_setpoints(self, msg: Setpoints) -> None:
        if math.isfinite(msg.trip_speed_limit_mps) and msg.trip_speed_limit_mps > 0.0:
            self.operator_speed_limit = msg.trip_speed_limit_mps

    def _operator_speed_limit(self, request: RigCommand) -> float:
        """The operator's trip-speed limit [m/s] the advisor planned ``request`` under (it
        rides on the command, so every run applies it at the same stamp), else the latched
        /setpoints' (the open-loop sequencer sends none)."""
        limit = min(request.trip_speed_limit_in_mps, request.trip_speed_limit_out_mps)
        return limit if math.isfinite(limit) and limit > 0.0 else self.operator_speed_limit

    def _on_estop(self, msg: Bool) -> None:
        now = self._now_ns()
        if self._set_estop(msg.data, now) and not self.ctx.fast:
            measurement = self.inbox.latest("measurement")
            if self.last_request is not None and measurement is not None:
                self._limit(self.last_request, measurement, now)    # at the machines now

    def _set_estop(self, engaged: bool, stamp: int, by: str = "") -> bool:
        """Engage or release the emergency stop; whether that changed it."""
        if engaged == self.protection.emergency_stop:
            return False
        self.protection.emergency_stop = engaged
        self._event(Notice("estop_engaged" if engaged else "estop_released", "emergency stop "
                           + ("engaged" if engaged else "released") + by), stamp)
        self._publish_state()
        return True

    def _now_ns(self) -> int:
        """Rig time for operator events: the latest measurement's stamp (simulated time in
        fast mode, the plant's wall clock in realtime), so the node needs no /clock."""
        if self.watch.positions:
            return self.watch.positions[-1][0]
        return 0 if self.ctx.fast else self.get_clock().now().nanoseconds

    def _on_level(self, msg: String) -> None:
        self._set_level(msg.data, self._now_ns())

    def _set_level(self, level: str, stamp: int, by: str = "") -> None:
        if level not in AUTOMATION_LEVELS:
            self._event(Notice("level_refused", f"automation level {level!r} is not one of "
                               f"{', '.join(AUTOMATION_LEVELS)}"), stamp)
            return
        if level != self.protection.automation_level:
            self.protection.automation_level = level
            self._event(Notice("automation_level", f"automation level {level}{by}"), stamp)
            self._publish_state()

    def _press_due(self, stamp: int) -> None:
        """The scenario's operator actions whose time has come (drill_core.operator_actions)."""
        for action in self.script.due(self.clock.seconds(stamp)):
            by = f" (scenario operator action at {action.time_s:g} s)"
            if action.action == "automation_level":
                self._set_level(action.level, stamp, by)
            else:
                self._set_estop(action.action == "emergency_stop", stamp, by)

    def _publish_state(self) -> None:
        """The automation level and emergency stop in force, latched."""
        self.pub_level.publish(String(data=self.protection.automation_level))
        self.pub_estop.publish(Bool(data=bool(self.protection.emergency_stop)))

    def _on_measurement(self, msg: RigMeasurement) -> None:
        stamp = to_ns(msg.header.stamp)
        self.clock.start(stamp)
        for notice in self.tick.observe(stamp, msg):
            self._event(notice, stamp)
        self.inbox.put("measurement", msg)
        self._process()

    def _on_command(self, msg: RigCommand) -> None:
        self.inbox.put("command", msg)
        self._process()

    def _process(self) -> None:
        request = self.inbox.latest("command")
        if request is None:
            return
        stamp = to_ns(request.header.stamp)
        if self.ctx.fast:
            if not self.inbox.has("measurement", stamp):
                return
            measurement = self.inbox.take("measurement", stamp)
        else:
            measurement = self.inbox.latest("measurement")
            if measurement is None:
                return
        self.inbox.take("command", stamp)
        self.last_request = request
        self._press_due(stamp)
        self._limit(request, measurement, stamp)

    def _limit(self, request: RigCommand, m: RigMeasurement, stamp: int) -> None:
        decision = self.tick.limit(request, m, stamp, self._operator_speed_limit(request))
        manual = decision.manual_choke_opening
        dp_setpoint = decision.choke_dp_setpoint
        out = RigCommand(block_position_ref_m=float(decision.command[U_BLOCK]),
                         choke_flow_ref_m3s=float(decision.command[U_CHOKE]),
                         bpp_flow_m3s=float(decision.command[U_BPP_FLOW]),
                         spp_pa=float(decision.command[U_PUMP_PRESSURE]),
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
                         emergency_stop=decision.emergency_stop,
                         emergency_bhp_pa=decision.emergency_bhp_pa,
                         source=f"protection<{request.source}")
        out.header.stamp = from_ns(stamp)
        self.pub_command.publish(out)
        for notice in decision.clamps:
            self.clamp_count += 1
            self._event(notice, stamp)
        self._check_window(m.bhp_pa, stamp)
        level = "emergency_stop" if self.protection.emergency_stop else self.protection.automation_level
        self.status.mode = f"{self.ctx.mode}/{level}"
        alarms = self.watch.alarm_count + self.window_exits
        self.status.values = {"clamps": float(self.clamp_count), "alarms": float(alarms),
                              "rejected_flow_samples": float(self.watch.detector.rejected),
                              "rejected_pit_samples": float(self.watch.detector.rejected_pit),
                              "trip_speed_limit_in_mps": decision.trip_speed_limits_mps[0],
                              "trip_speed_limit_out_mps": decision.trip_speed_limits_mps[1]}
        self.status.tick(stamp)

    def _check_window(self, bhp_pa: float, stamp: int) -> None:
        p = self.ctx.config.well.formation
        if not math.isfinite(bhp_pa):
            return              # no reading: the window is judged on the next one
        inside = p.pore_pressure_pa <= bhp_pa <= p.fracture_pressure_pa
        if inside != self.in_window:
            self.in_window = inside
            if not inside:
                self.window_exits += 1
            self._event(Notice("window_return" if inside else "window_exit", f"BHP "
                               f"{bhp_pa / PA_PER_BAR:.1f} bar " + ("back inside" if inside else "outside")
                               + f" the pore/fracture window {p.pore_pressure_pa / PA_PER_BAR:.0f}-"
                               f"{p.fracture_pressure_pa / PA_PER_BAR:.0f} bar", bhp_pa), stamp)

    def _event(self, notice: Notice, stamp: int) -> None:
        self.pub_events.publish(event_message(notice, from_ns(stamp), notice.kind != "alarm"))


def main(args=None) -> None:
    sys.exit(run(ProtectionNode, args))


if __name__ == "__main__":
    main()
