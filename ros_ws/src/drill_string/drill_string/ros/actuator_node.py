"""Drilling drive node: the top drive (``top_drive``, rad/s) or the block feed
(``block_feed``, m/s positive down), parameter ``actuator`` (drill_string.drives).

On the surface measurement stamped t_k it publishes its output over the coming frame as
drill_msgs/ActuatorFrame stamped t_k; when a driller's command is due at t_k (t_k a
multiple of config/drilling.yaml command_period_s) it waits for the command stamped t_k
first, so a command acts from the sample it was issued at (the tripping actuators'
lockstep, docs/architecture.md).
"""
from __future__ import annotations

import sys

from drill_msgs.msg import ActuatorFrame, DrillingCommand, SurfaceMeasurement

from drill_ros import topics
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_string.drives import SpeedDrive
from drill_string.ros.context import load_drilling_context

UNITS = {"top_drive": "rad/s", "block_feed": "m/s"}


class DrillingActuatorNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("drilling_actuator", **node_options)
        ctx = load_drilling_context(self)
        self.exit_code = 0
        self.actuator = self.declare_parameter("actuator", "top_drive").value
        if self.actuator not in topics.DRILLING_ACTUATORS:
            raise ValueError(f"parameter actuator: {self.actuator!r} is not one of "
                             f"{', '.join(topics.DRILLING_ACTUATORS)}")
        top = self.actuator == "top_drive"
        start = ctx.scenario.start_speeds
        self.drive = SpeedDrive(ctx.rig.top_drive if top else ctx.rig.block_feed,
                                start.top_drive_rad_s if top else start.block_speed_m_s)
        self.command = self.drive.command
        self.step_s = ctx.rig.actuator_step_s
        self.steps = ctx.rig.steps_per_frame
        self.command_period_ns = seconds_to_ns(ctx.rig.command_period_s)
        self.inbox = StampedInbox(("measurement", "command"))
        self.status = StatusReporter(self, "fast")
        self.pub = self.create_publisher(ActuatorFrame, topics.actuator_frame(self.actuator),
                                         topics.RELIABLE)
        self.create_subscription(SurfaceMeasurement, topics.SURFACE,
                                 lambda msg: self._on("measurement", msg), topics.RELIABLE)
        self.create_subscription(DrillingCommand, topics.DRILLING_COMMAND,
                                 lambda msg: self._on("command", msg), topics.RELIABLE)

    def get_name(self) -> str:  # status topic and logs carry the drive's name
        return getattr(self, "actuator", None) or super().get_name()

    def _on(self, kind: str, msg) -> None:
        self.inbox.put(kind, msg)
        measurement = self.inbox.latest("measurement")
        if measurement is None:
            return
        stamp = to_ns(measurement.header.stamp)
        due = stamp % self.command_period_ns == 0
        if due and not self.inbox.has("command", stamp):
            return
        self.inbox.take("measurement", stamp)
        if due:
            cmd = self.inbox.take("command", stamp)
            self.command = (cmd.top_drive_speed_ref_rad_s if self.actuator == "top_drive"
                            else cmd.block_speed_ref_m_s)
        self._act(measurement, stamp)

    def _act(self, measurement: SurfaceMeasurement, stamp_ns: int) -> None:
        out = self.drive.frame(self.command, self.step_s, self.steps)
        frame = ActuatorFrame(actuator=self.actuator, unit=UNITS[self.actuator],
                              command=float(out.command), output=[float(v) for v in out.output],
                              sample_period_s=self.step_s, reference=float(out.reference))
        frame.header.stamp = measurement.header.stamp
        self.pub.publish(frame)
        self.status.values = {"command": out.command, "output": float(out.output[-1])}
        self.status.tick(stamp_ns)


def main(args=None) -> None:
    sys.exit(run(DrillingActuatorNode, args))


if __name__ == "__main__":
    main()
