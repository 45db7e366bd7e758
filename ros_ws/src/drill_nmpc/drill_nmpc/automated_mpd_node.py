"""Automated MPD controller as node ``automated_mpd``: a planned trip and a model-based
choke-dp set-point for the choke's pressure loop (drill_nmpc.automated_mpd), the stronger
conventional baseline the NMPC is measured against.

    python -m drill_nmpc.automated_mpd_node --ros-args -p config_dir:=... -p scenario:=... \
        -p mode:=fast -p use_sim_time:=true

Subscribes /estimator/estimate (never /rig/truth) and /rig/command (the protection's
answer: the BHP window and reference in force, drill_nmpc.advisor_node); on the estimate
stamped t_k with t_k a multiple of the sample time (fast mode, once the protection's answer
to the last command is in; realtime: the first estimate of each new sample period) it
publishes drill_msgs/RigCommand stamped t_k with the choke in pressure
control: block reference, choke-dp set-point and its ramp, the flow feedforward, and the
pumps held at the scenario's initial operating point (design knowledge of the well:
drill_core.operating_point). The setpoints are the advisors' setpoint book
(drill_nmpc.setpoint_book): the schedule applies by time, validated; a NaN BHP reference
is the first estimate's BHP. ``controller_enabled: false`` holds the string where
it is estimated. The setpoints in force go out on the latched /setpoints topic whenever they
change.
"""
from __future__ import annotations

import sys

from drill_msgs.msg import StateEstimate

from drill_core.estimation_model import DENSITY_OFFSET, build_estimation_model
from drill_ros import topics
from drill_ros.runner import run
from drill_ros.stamps import to_ns
from drill_nmpc.advisor_node import AdvisorNode
from drill_nmpc.advisor_ticks import AutomatedMpdTick
from drill_nmpc.automated_mpd import EstimateView


class AutomatedMpdNode(AdvisorNode):
    def __init__(self, **node_options):
        super().__init__("automated_mpd", **node_options)
        self.em = build_estimation_model(self.ctx.config)
        self.tick = AutomatedMpdTick(self.ctx.config, self.em, self.start, self.ctx.scenario.trip)
        self.create_subscription(StateEstimate, topics.ESTIMATE, self._on_estimate, topics.RELIABLE)

    def _view(self, msg: StateEstimate) -> EstimateView:
        mean = msg.mean
        return EstimateView(bhp_pa=float(msg.bhp_pa), string_position_m=float(mean[0]),
                            string_velocity_mps=float(msg.string_velocity_mps),
                            string_flow_m3s=float(mean[self.em.string_flow]),
                            friction_factor=tuple(float(v) for v in msg.friction_parameter),
                            density_offset_kgm3=float(dict(zip(msg.state_names, mean)).get(
                                DENSITY_OFFSET, 0.0)),
                            string_flow_observable=bool(msg.string_flow_observable),
                            bottom_annulus_flow_m3s=float(mean[self.em.flow(self.em.n)]))

    def _on_estimate(self, msg: StateEstimate) -> None:
        stamp = to_ns(msg.header.stamp)
        if self.gate.admit(stamp):
            self.offer(msg, stamp)

    def act(self, msg: StateEstimate, stamp: int) -> None:
        view = self._view(msg)
        self.follow_schedule(stamp)
        self.publish_events(self.book.resolve_bhp(view.bhp_pa), stamp)
        sp = self.book.active
        floor = self.floor_at(stamp)
        cmd, c = self.tick.step(view, sp, self.book.bhp_resolved, self.speed_limits_mps,
                                self.applied_block_m, floor)
        self.publish_command(cmd, stamp)     # the fast-mode lockstep waits for a command
        if c is None:
            self.status.error(f"estimate at {stamp * 1e-9:.3f} s is not finite: last command held")
            return
        self.status.mode = f"{self.ctx.mode}/{'automated_mpd' if sp.controller_enabled else 'manual'}"
        self.status.values = {"block_ref_m": c.block_position_ref_m,
                              "choke_dp_ref_pa": c.choke_dp_ref_pa, "trim_pa": c.trim_pa,
                              "trip_speed_limit_out_mps": c.trip_speed_limit_out_mps,
                              "trip_speed_limit_in_mps": c.trip_speed_limit_in_mps}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(AutomatedMpdNode, args))


if __name__ == "__main__":
    main()
