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

import math
import sys

from drill_msgs.msg import RigCommand, StateEstimate

from drill_core.estimation_model import DENSITY_OFFSET, build_estimation_model
from drill_core.ros import topics
from drill_core.ros.runner import run
from drill_core.ros.stamps import to_ns
from drill_nmpc.advisor_node import AdvisorNode
from drill_nmpc.automated_mpd import AutomatedMpd, EstimateView
from drill_nmpc.setpoint_book import within_speed_limits


class AutomatedMpdNode(AdvisorNode):
    def __init__(self, **node_options):
        super().__init__("automated_mpd", **node_options)
        cfg, ini, op = self.ctx.config, self.ctx.scenario.initial, self.ctx.operating_point
        self.em = build_estimation_model(cfg)
        self.controller = AutomatedMpd(cfg, self.em, float(ini.bpp_flow_m3s), op.spp_pa)
        self.held = RigCommand(block_position_ref_m=0.0, choke_flow_ref_m3s=float(op.choke_flow_m3s),
                               bpp_flow_m3s=float(ini.bpp_flow_m3s), spp_pa=op.spp_pa,
                               mud_pump_on=ini.circulation_m3s > 0.0, source="automated_mpd")
        self.create_subscription(StateEstimate, topics.ESTIMATE, self._on_estimate, topics.RELIABLE)

    def _view(self, msg: StateEstimate) -> EstimateView:
        mean = msg.mean
        return EstimateView(bhp_pa=float(msg.bhp_pa), string_position_m=float(mean[0]),
                            string_velocity_mps=float(msg.string_velocity_mps),
                            string_flow_m3s=float(mean[self.em.string_flow]),
                            friction_factor=tuple(float(v) for v in msg.friction_parameter),
                            density_offset_kgm3=float(dict(zip(msg.state_names, mean)).get(
                                DENSITY_OFFSET, 0.0)),
                            string_flow_observable=bool(msg.string_flow_observable))

    def _on_estimate(self, msg: StateEstimate) -> None:
        stamp = to_ns(msg.header.stamp)
        if self.gate.admit(stamp):
            self.offer(msg, stamp)

    def act(self, msg: StateEstimate, stamp: int) -> None:
        view = self._view(msg)
        self.follow_schedule(stamp)
        self.publish_events(self.book.resolve_bhp(view.bhp_pa), stamp)
        sp = self.book.active
        if self.controller.profile is None and math.isfinite(view.string_position_m):
            self.held.block_position_ref_m = view.string_position_m
        if not self.book.bhp_resolved or not all(math.isfinite(v) for v in
                                                  (view.bhp_pa, view.string_position_m)):
            self.status.error(f"estimate at {stamp * 1e-9:.3f} s is not finite: last command held")
            self.publish_command(self.held, stamp)   # the fast-mode lockstep waits for a command
            return
        self.controller.adopt_applied(self.applied_block_m)
        c = self.controller.step(view, within_speed_limits(sp, self.speed_limits_mps,
                                                           view.string_position_m), sp.bhp_ref_pa)
        self.held = RigCommand(block_position_ref_m=c.block_position_ref_m,
                               choke_flow_ref_m3s=c.choke_flow_feedforward_m3s,
                               bpp_flow_m3s=c.bpp_flow_m3s, spp_pa=c.spp_pa,
                               mud_pump_on=bool(sp.mud_pump_on), choke_manual=False,
                               choke_pressure_control=True, choke_dp_ref_pa=c.choke_dp_ref_pa,
                               choke_dp_ref_rate_pa_s=c.choke_dp_ref_rate_pa_s,
                               source="automated_mpd")
        self.publish_command(self.held, stamp)
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
