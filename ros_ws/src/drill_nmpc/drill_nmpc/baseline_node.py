"""Conventional MPD baseline as node ``baseline`` (docs/design.md §8): a fixed-speed trip
and a PI choke on the measured BHP; the comparison the NMPC's value is shown against.

    python -m drill_nmpc.baseline_node --ros-args -p config_dir:=... -p scenario:=... \
        -p mode:=fast -p use_sim_time:=true

Subscribes /rig/measurement and /rig/command (the protection's answer: the BHP window and
reference in force, drill_nmpc.advisor_node); on the measurement stamped t_k with t_k a
multiple of the sample time t_s (fast mode, once the protection's answer to the last
command is in; realtime: the first measurement of each new sample period) it publishes
drill_msgs/RigCommand stamped t_k:

* block reference: moves toward the scenario's block target at the fixed
  ``baseline_trip_speed_mps`` (a ramp of speed * t_s per sample, stopping on the target);
* choke-flow reference: q_c0 + k_p e + (k_p / T_i) * integral(e), e = BHP_measured - BHP_ref
  (BHP too high: open the choke, let more out), clipped to [0, the NMPC's upper bound] with
  anti-windup; BHP_ref from the schedule, or the first measured BHP when it is NaN;
* back-pressure pump and stand-pipe pressure held at the scenario's initial operating point
  (design knowledge: drill_core.operating_point of the initial circulation and
  choke dp, not the truth topic).

The setpoints are the advisors' setpoint book (drill_nmpc.setpoint_book: the schedule applies
by time, validated); ``controller_enabled: false`` holds the block where it is measured and
the choke flow at its last value. The setpoints in force (the BHP reference
resolved) go out on the latched /setpoints topic whenever they change, as the NMPC's do.
"""
from __future__ import annotations

import math
import sys

from drill_msgs.msg import RigMeasurement

from drill_ros import topics
from drill_ros.runner import run
from drill_ros.stamps import to_ns
from drill_nmpc.advisor_node import AdvisorNode
from drill_nmpc.advisor_ticks import BASELINE_KP_M3S_PER_PA, BASELINE_TI_S, BaselineTick


class BaselineNode(AdvisorNode):
    def __init__(self, **node_options):
        super().__init__("baseline", **node_options)
        kp = self.declare_parameter("kp_m3s_per_pa", BASELINE_KP_M3S_PER_PA).value
        ti = self.declare_parameter("ti_s", BASELINE_TI_S).value
        self.tick = BaselineTick(self.ctx.config, float(self.ctx.scenario.baseline_trip_speed_mps),
                                 self.start, float(kp), float(ti), self.ctx.scenario.trip)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)

    def _on_measurement(self, msg: RigMeasurement) -> None:
        stamp = to_ns(msg.header.stamp)
        if self.gate.admit(stamp):
            self.offer(msg, stamp)

    def act(self, msg: RigMeasurement, stamp: int) -> None:
        position, bhp = float(msg.block_position_m), float(msg.bhp_pa)
        self.follow_schedule(stamp)
        self.publish_events(self.book.resolve_bhp(bhp), stamp)
        sp = self.book.active
        floor = self.floor_at(stamp)
        cmd, ok = self.tick.step(position, bhp, sp, self.book.bhp_resolved, self.applied_block_m,
                                 float(msg.return_flow_m3s), floor)
        if not ok:
            self.status.error(f"measurement at {stamp * 1e-9:.3f} s without a finite BHP: "
                              "choke reference held")
        self.publish_command(cmd, stamp)
        self.status.mode = f"{self.ctx.mode}/{'baseline' if sp.controller_enabled else 'manual'}"
        self.status.values = {"block_ref_m": cmd.block_position_ref_m,
                              "choke_flow_ref_m3s": cmd.choke_flow_ref_m3s,
                              "bhp_ref_pa": float(sp.bhp_ref_pa) if self.book.bhp_resolved
                              else math.nan}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(BaselineNode, args))


if __name__ == "__main__":
    main()
