"""Driller node (``driller``): the drilling scenario's schedule of surface speeds
(drill_string.scenario) as drill_msgs/DrillingCommand.

Subscribes /drilling/surface only as its clock; on the measurement stamped t_k with t_k a
multiple of the command period (config/drilling.yaml command_period_s, the period the
drives wait for) it publishes the speeds in force at t_k, stamped t_k.
"""
from __future__ import annotations

import sys

from drill_msgs.msg import DrillingCommand, SurfaceMeasurement

from drill_ros import topics
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.sampling import SampleGate
from drill_ros.stamps import seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_string.ros.context import load_drilling_context


class DrillerNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("driller", **node_options)
        self.ctx = load_drilling_context(self)
        self.exit_code = 0
        self.gate = SampleGate(seconds_to_ns(self.ctx.rig.command_period_s), fast=True)
        self.status = StatusReporter(self, "fast")
        self.pub = self.create_publisher(DrillingCommand, topics.DRILLING_COMMAND,
                                         topics.RELIABLE)
        self.create_subscription(SurfaceMeasurement, topics.SURFACE, self._on_surface,
                                 topics.RELIABLE)

    def _on_surface(self, msg: SurfaceMeasurement) -> None:
        stamp = to_ns(msg.header.stamp)
        if not self.gate.admit(stamp):
            return
        speeds = self.ctx.scenario.speeds_at(self.gate.scenario_time_s(stamp))
        cmd = DrillingCommand(top_drive_speed_ref_rad_s=speeds.top_drive_rad_s,
                              block_speed_ref_m_s=speeds.block_speed_m_s, source="driller")
        cmd.header.stamp = msg.header.stamp
        self.pub.publish(cmd)
        self.status.values = {"top_drive_speed_ref_rad_s": speeds.top_drive_rad_s,
                              "block_speed_ref_m_s": speeds.block_speed_m_s}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(DrillerNode, args))


if __name__ == "__main__":
    main()
