"""Open-loop command sequencer as node ``sequencer`` (controller ``open_loop``;
docs/design.md §8, the paper's estimation study): the advisor when no controller closes the loop.

    python -m drill_nmpc.sequencer_node --ros-args -p config_dir:=... -p scenario:=... \
        -p mode:=fast -p use_sim_time:=true

Subscribes /rig/measurement only as its clock; on the measurement stamped t_k with t_k a
multiple of the command period t_s (nmpc.sample_time_s, the period the actuators wait
for; realtime: the first measurement of each new period) it publishes the scenario's
open-loop commands at t_k (drill_core.open_loop) as drill_msgs/RigCommand stamped t_k on
the advisor topic, which process protection forwards to the machines. Initial choke flow
and stand-pipe pressure: drill_core.operating_point of the scenario's initial
operating point, the point the actuators and protection start from.
"""
from __future__ import annotations

import math
import sys

from drill_msgs.msg import RigCommand, RigMeasurement

from drill_core.open_loop import OpenLoopPlan, start_command
from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.sampling import SampleGate
from drill_ros.stamps import from_ns, seconds_to_ns, to_ns
from drill_ros.status import StatusReporter


class SequencerNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("sequencer", **node_options)
        ctx = load_context(self)
        self.ctx = ctx
        self.exit_code = 0
        ini = ctx.scenario.initial
        op = ctx.operating_point
        start = start_command(ini, float(op.choke_flow_m3s), op.spp_pa)
        self.plan = OpenLoopPlan(ctx.scenario.schedule, start)
        self.gate = SampleGate(seconds_to_ns(ctx.config.nmpc.sample_time_s), ctx.fast)
        self.status = StatusReporter(self, ctx.mode)
        self.pub = self.create_publisher(RigCommand, topics.COMMAND, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)

    def _on_measurement(self, msg: RigMeasurement) -> None:
        stamp = to_ns(msg.header.stamp)
        if not self.gate.admit(stamp):
            return
        c = self.plan.command_at(self.gate.scenario_time_s(stamp))
        low, high = self.ctx.config.pressure_window_pa
        cmd = RigCommand(block_position_ref_m=c.block_position_ref_m,
                         choke_flow_ref_m3s=c.choke_flow_ref_m3s, bpp_flow_m3s=c.bpp_flow_m3s,
                         spp_pa=c.spp_pa, mud_pump_on=c.mud_pump_on, choke_manual=c.choke_manual,
                         choke_opening_ref=c.choke_opening if c.choke_manual else 0.0,
                         bhp_ref_pa=math.nan, bhp_window_low_pa=low, bhp_window_high_pa=high,
                         trip_speed_limit_in_mps=math.nan, trip_speed_limit_out_mps=math.nan,
                         source="sequencer")          # open loop: no BHP reference or limit
        cmd.header.stamp = from_ns(stamp)
        self.pub.publish(cmd)
        self.status.mode = f"{self.ctx.mode}/open_loop"
        self.status.values = {"block_ref_m": c.block_position_ref_m, "bpp_flow_m3s": c.bpp_flow_m3s,
                              "choke_manual": float(c.choke_manual), "choke_opening": c.choke_opening}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(SequencerNode, args))


if __name__ == "__main__":
    main()
