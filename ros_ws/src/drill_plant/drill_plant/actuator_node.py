"""Actuator node (one process per actuator): drawworks, choke, bpp or mud_pump; the
per-frame rules are its tick (drill_plant.actuator_tick), the node moves messages.

On each measurement stamped t_k it publishes its output over the coming frame,
stamped t_k. In fast mode, when a supervisor command is due at t_k (t_k a multiple
of ``command_period_s``) it waits for the command stamped t_k first, so commands act
from the sample they were computed at. The choke honours the command's manual mode
(``choke_manual``: drive to ``choke_opening_ref``), its pressure controller
(``choke_pressure_control``: hold the measured choke dp at ``choke_dp_ref_pa``, ramped at
``choke_dp_ref_rate_pa_s``, with ``choke_flow_ref_m3s`` as flow feedforward) and otherwise
its PI flow controller on ``choke_flow_ref_m3s`` against the measured return flow (the
valve law when that sample is bad: counted as ``valve_law_frames`` on its status). Under
the command's emergency stop the drawworks sets its brake (the block decelerates to rest
and is held) and the choke holds the BHP at ``emergency_bhp_pa`` on its BHP loop. If
commands stop for longer than the watchdog timeout it holds a safe state (block held where
it is, choke opening and pumps held) and says so on its status topic. A scenario's actuator faults
(drill_core.events) act here: ``stuck`` freezes the output, ``trip`` stops a pump whatever
it is commanded; the frame names the fault acting. On a multi-stand trip the drawworks and
the mud pump also wait for the rig floor's command stamped t_k (/rig/floor): the block on
its encoder while the string is in the slips, the pump's ramps around a connection.
"""
from __future__ import annotations

import sys

import numpy as np
from drill_msgs.msg import ActuatorFrame, RigCommand, RigFloor, RigMeasurement

from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.floor import floor_command
from drill_ros.graph import FLOOR_ACTUATORS
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import ScenarioClock, seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_plant.actuator_tick import UNITS, ActuatorTick


class ActuatorNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("actuator", **node_options)
        ctx = load_context(self, truth_side=True)
        self.ctx = ctx
        self.exit_code = 0
        self.actuator = self.declare_parameter("actuator", "drawworks").value
        if self.actuator not in UNITS:
            raise ValueError(f"parameter actuator: {self.actuator!r} is not one of {', '.join(UNITS)}")
        period = self.declare_parameter("command_period_s", ctx.config.nmpc.sample_time_s).value
        self.command_period_ns = seconds_to_ns(period)
        self.tick = ActuatorTick(self.actuator, ctx.config, ctx.well_model, ctx.operating_point,
                                 ctx.scenario.events)
        self.step_s = ctx.config.plant.step_s
        self.clock = ScenarioClock()             # the faults' times
        self.follows_floor = ctx.scenario.trip is not None and self.actuator in FLOOR_ACTUATORS
        self.inbox = StampedInbox(("measurement", "command", "floor"))
        self.status = StatusReporter(self, ctx.mode)
        self.pub = self.create_publisher(ActuatorFrame, topics.actuator_frame(self.actuator),
                                         topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        self.create_subscription(RigCommand, topics.MACHINE_COMMAND, self._on_command,
                                 topics.RELIABLE)
        if self.follows_floor:
            self.create_subscription(RigFloor, topics.FLOOR, self._on_floor, topics.RELIABLE)

    def get_name(self) -> str:  # status topic and logs carry the actuator's name
        return getattr(self, "actuator", None) or super().get_name()

    def _on_command(self, msg: RigCommand) -> None:
        self.inbox.put("command", msg)
        if self.ctx.fast:
            self._process_pending()
        else:
            self.tick.command(msg, to_ns(msg.header.stamp), self.get_clock().now().nanoseconds)

    def _on_floor(self, msg: RigFloor) -> None:
        self.inbox.put("floor", msg)
        self._process_pending()

    def _on_measurement(self, msg: RigMeasurement) -> None:
        self.inbox.put("measurement", msg)
        if self.ctx.fast:
            self._process_pending()
        else:
            self._act(msg, self.get_clock().now().nanoseconds)

    def _process_pending(self) -> None:
        msg = self.inbox.latest("measurement")
        if msg is None:
            return
        stamp = to_ns(msg.header.stamp)
        due = self.command_period_ns > 0 and stamp % self.command_period_ns == 0
        if due and not self.inbox.has("command", stamp):
            return
        if self.follows_floor and not self.inbox.has("floor", stamp):
            return
        self.inbox.take("measurement", stamp)
        if due:
            command = self.inbox.take("command", stamp)
            self.tick.command(command, to_ns(command.header.stamp), stamp)
        floor = self.inbox.take("floor", stamp) if self.follows_floor else None
        self._act(msg, stamp, floor)

    def _act(self, measurement: RigMeasurement, now_ns: int, floor: RigFloor | None = None) -> None:
        stamp = to_ns(measurement.header.stamp)
        self.clock.start(stamp)
        step = self.tick.step(measurement, stamp, now_ns, self.clock.seconds(stamp),
                              None if floor is None else floor_command(floor))
        if step.fell_silent:
            self.status.error("command stream silent: holding the safe state")
        out = step.output
        frame = ActuatorFrame(actuator=self.actuator, unit=UNITS[self.actuator],
                              command=float(out.command),
                              output=np.asarray(out.output, dtype=float).tolist(),
                              sample_period_s=self.step_s, reference=float(out.reference),
                              watchdog_active=step.watchdog_active, fault=step.fault)
        frame.header.stamp = measurement.header.stamp
        self.pub.publish(frame)
        self.status.mode = f"{self.ctx.mode}/{'watchdog' if step.watchdog_active else 'commanded'}"
        self.status.values = {"command": out.command, "output": float(out.output[-1])}
        if self.actuator == "choke":     # frames its flow loop ran on the valve law
            self.status.values["valve_law_frames"] = float(self.tick.model.valve_law_frames)
        self.status.tick(now_ns)


def main(args=None) -> None:
    sys.exit(run(ActuatorNode, args))


if __name__ == "__main__":
    main()
