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
protection answers it until circulation is back or no longer asked for. The drawworks' and
the choke's frames (/actuators/<name>/frame) feed the actuator watches
(drill_protection.actuator_watch): a block that does not follow its reference has the
reference held at the string, a choke that does not while circulation is lost sets the
protective stop; in fast mode the command stamped t_k waits for the frames stamped t_k - dt.
"""
from __future__ import annotations

import math
import sys
from dataclasses import asdict

from drill_msgs.msg import (ActuatorFrame, OperatorEvent, RigCommand, RigFloor, RigMeasurement,
                            Setpoints)
from std_msgs.msg import Bool, String

from drill_core.event_codes import Notice
from drill_core.tripping.frame_pairs import FramePairs
from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.events import event_message
from drill_ros.floor import floor_command
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import ScenarioClock, from_ns, seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_protection.tick import ProtectionTick


class ProtectionNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("protection", **node_options)
        ctx = load_context(self)
        self.ctx = ctx
        self.exit_code = 0
        self.tick = ProtectionTick(ctx.config, ctx.well_model, ctx.scenario,
                                   ctx.operating_point)
        self.protection, self.watch = self.tick.protection, self.tick.watch
        self.operator_speed_limit = ctx.config.protection.trip_speed_max_mps
        self.clock = ScenarioClock()             # the operator actions' times
        self.last_request: RigCommand | None = None
        self.inbox = StampedInbox(("command", "measurement"))
        # a multi-stand trip: a measurement t_k is read once the rig floor's command
        # stamped t_{k-1} (the frame before it) has come (fast mode)
        self.multi_stand = ctx.scenario.trip is not None
        self.frame_ns = seconds_to_ns(ctx.config.plant.sensor_period_s)
        self.floor_pairs = FramePairs(self.frame_ns)    # measurements with the floor's step
        self.clamp_count = 0
        self.status = StatusReporter(self, ctx.mode)
        self.pub_command = self.create_publisher(RigCommand, topics.MACHINE_COMMAND, topics.RELIABLE)
        self.pub_events = self.create_publisher(OperatorEvent, topics.PROTECTION_EVENTS, topics.EVENT_LOG)
        self.pub_level = self.create_publisher(String, topics.LEVEL_IN_FORCE, topics.LATCHED)
        self.pub_estop = self.create_publisher(Bool, topics.ESTOP_IN_FORCE, topics.LATCHED)
        self._publish_state()
        self.create_subscription(RigCommand, topics.COMMAND, self._on_command, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        for name in topics.WATCHED_ACTUATORS:
            self.create_subscription(ActuatorFrame, topics.actuator_frame(name),
                                     lambda msg, n=name: self._on_frame(n, msg), topics.RELIABLE)
        if self.multi_stand:
            self.create_subscription(RigFloor, topics.FLOOR, self._on_floor, topics.RELIABLE)
        self.create_subscription(Setpoints, topics.SETPOINTS, self._on_setpoints, topics.LATCHED)
        self.create_subscription(Bool, topics.EMERGENCY_STOP, self._on_estop, topics.LATCHED)
        self.create_subscription(String, topics.AUTOMATION_LEVEL, self._on_level, topics.LATCHED)

    def _on_setpoints(self, msg: Setpoints) -> None:
        if math.isfinite(msg.trip_speed_limit_mps) and msg.trip_speed_limit_mps > 0.0:
            self.operator_speed_limit = msg.trip_speed_limit_mps

    def _on_estop(self, msg: Bool) -> None:
        now = self._now_ns()
        if self._announce(self.tick.set_emergency_stop(msg.data), now) and not self.ctx.fast:
            measurement = self.inbox.latest("measurement")
            if self.last_request is not None and measurement is not None:
                self._limit(self.last_request, measurement, now)    # at the machines now

    def _now_ns(self) -> int:
        """Rig time for operator events: the latest measurement's stamp (simulated time in
        fast mode, the plant's wall clock in realtime), so the node needs no /clock."""
        if self.watch.positions:
            return self.watch.positions[-1][0]
        return 0 if self.ctx.fast else self.get_clock().now().nanoseconds

    def _on_level(self, msg: String) -> None:
        self._announce(self.tick.set_automation_level(msg.data), self._now_ns())

    def _announce(self, notices, stamp: int) -> bool:
        """The operator buttons' notices out, each change followed by the state in force;
        whether there was any."""
        for notice in notices:
            self._event(notice, stamp)
            if notice.code != "level_refused":
                self._publish_state()
        return bool(notices)

    def _publish_state(self) -> None:
        """The automation level and emergency stop in force, latched."""
        self.pub_level.publish(String(data=self.protection.automation_level))
        self.pub_estop.publish(Bool(data=bool(self.protection.emergency_stop)))

    def _on_measurement(self, msg: RigMeasurement) -> None:
        if not self.multi_stand:
            self._observe(msg)
            return
        self._drain(self.floor_pairs.item(to_ns(msg.header.stamp), msg))

    def _on_floor(self, msg: RigFloor) -> None:
        self._drain(self.floor_pairs.partner(to_ns(msg.header.stamp), msg))

    def _drain(self, released) -> None:
        """The measurements released in stamp order, each after the floor's command for the
        frame before it (none before the first frame)."""
        for _, measurement, floor in released:
            if floor is not None:
                self.tick.floor(floor_command(floor))
            self._observe(measurement)

    def _observe(self, msg: RigMeasurement) -> None:
        stamp = to_ns(msg.header.stamp)
        self.clock.start(stamp)
        for notice in self.tick.observe(stamp, msg):
            self._event(notice, stamp)
        self.inbox.put("measurement", msg)
        self._process()

    def _on_frame(self, name: str, msg: ActuatorFrame) -> None:
        self.tick.observe_frame(name, to_ns(msg.header.stamp), msg.reference, msg.output)
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
            due = stamp - self.frame_ns            # the last frames before t_k
            if not self.inbox.has("measurement", stamp) or \
                    (due >= 0 and not self.tick.has_frames(due)):
                return
            measurement = self.inbox.take("measurement", stamp)
        else:
            measurement = self.inbox.latest("measurement")
            if measurement is None:
                return
        self.inbox.take("command", stamp)
        self.last_request = request
        self._announce(self.tick.press_due(self.clock.seconds(stamp)), stamp)
        self._limit(request, measurement, stamp)

    def _limit(self, request: RigCommand, m: RigMeasurement, stamp: int) -> None:
        decision = self.tick.limit(request, m, stamp, self.operator_speed_limit)
        out = RigCommand(**asdict(self.tick.machine_command(decision, request)),
                         source=f"protection<{request.source}")
        out.header.stamp = from_ns(stamp)
        self.pub_command.publish(out)
        for notice in decision.clamps:
            self.clamp_count += 1
            self._event(notice, stamp)
        for notice in self.tick.check_window(m):
            self._event(notice, stamp)
        level = "emergency_stop" if self.protection.emergency_stop else self.protection.automation_level
        self.status.mode = f"{self.ctx.mode}/{level}"
        alarms = self.watch.alarm_count + self.tick.window_exits
        self.status.values = {"clamps": float(self.clamp_count), "alarms": float(alarms),
                              "rejected_flow_samples": float(self.watch.detector.rejected),
                              "rejected_pit_samples": float(self.watch.detector.rejected_pit),
                              "trip_speed_limit_in_mps": decision.trip_speed_limits_mps[0],
                              "trip_speed_limit_out_mps": decision.trip_speed_limits_mps[1]}
        self.status.tick(stamp)

    def _event(self, notice: Notice, stamp: int) -> None:
        self.pub_events.publish(event_message(notice, from_ns(stamp), notice.kind != "alarm"))


def main(args=None) -> None:
    sys.exit(run(ProtectionNode, args))


if __name__ == "__main__":
    main()
