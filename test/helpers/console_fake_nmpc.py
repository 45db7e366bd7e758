"""Development stand-in for the NMPC node (realtime mode only), used by the console
tests while ``drill_nmpc.nmpc_node`` does not exist: launch it as node "nmpc".

It honours the supervisor's contract as far as the console needs it: validating
/set_setpoints service (pressure window with margin, trip speed, drawworks range,
positive bands), latched /setpoints (scenario schedule, then operator changes),
/nmpc/status about once a second with the BHP reference in use, and a
/supervisor/command at 1 Hz that moves the block reference toward the trip target at
the speed limit and holds flows and pump pressure at the initial operating point.
It is not a controller.
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np
from drill_msgs.msg import NmpcStatus, RigCommand, RigMeasurement, Setpoints
from drill_msgs.srv import SetSetpoints
from rclpy.node import Node

from drill_core.ros import topics
from drill_core.ros.context import load_context
from drill_core.ros.runner import run
from drill_core.scenario import ActiveSetpoints, setpoints_at
from drill_plant.plant_model import steady_state

FIELDS = ("bhp_ref_pa", "bhp_band_pa", "choke_dp_ref_pa", "choke_dp_band_pa", "block_position_target_m",
          "trip_speed_limit_mps", "controller_enabled", "mud_pump_on")


class FakeNmpc(Node):
    def __init__(self):
        super().__init__("nmpc")
        ctx = load_context(self)
        self.ctx = ctx
        ini = ctx.scenario.initial
        self.initial = steady_state(ctx.well_model, ini.circulation_m3s, ini.choke_dp_pa, ini.bpp_flow_m3s)
        self.u = np.array([0.0, self.initial.choke_flow_m3s, ini.bpp_flow_m3s, self.initial.inputs[3]])
        n = ctx.config.nmpc
        self.start = ActiveSetpoints(math.nan, n.bhp_band_pa, ini.choke_dp_pa, n.choke_dp_band_pa, 0.0,
                                     n.velocity_limit_mps, True, ini.circulation_m3s > 0)
        self.active = self.start
        self.source = "scenario"
        self.operator = False
        self.bhp_default = None
        self.t0 = time.monotonic()
        self.fallbacks = 0
        self.pub_sp = self.create_publisher(Setpoints, topics.SETPOINTS, topics.LATCHED)
        self.pub_cmd = self.create_publisher(RigCommand, topics.COMMAND, topics.RELIABLE)
        self.pub_status = self.create_publisher(NmpcStatus, topics.NMPC_STATUS, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement, topics.RELIABLE)
        self.create_service(SetSetpoints, topics.SET_SETPOINTS, self._on_request)
        self.create_timer(1.0, self._tick)
        self._publish_setpoints()

    def _on_measurement(self, m: RigMeasurement) -> None:
        if self.bhp_default is None:
            self.bhp_default = m.bhp_pa

    def _publish_setpoints(self) -> None:
        msg = Setpoints(**{f: (bool(getattr(self.active, f)) if isinstance(getattr(self.active, f), bool)
                               else float(getattr(self.active, f))) for f in FIELDS}, source=self.source)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.pub_sp.publish(msg)
        return msg

    def check(self, s: Setpoints) -> str:
        p, a = self.ctx.config.protection, self.ctx.config.actuators
        low, high = p.pore_pressure_pa + p.pressure_margin_pa, p.fracture_pressure_pa - p.pressure_margin_pa
        if math.isfinite(s.bhp_ref_pa) and not low <= s.bhp_ref_pa <= high:
            return (f"BHP setpoint {s.bhp_ref_pa / 1e5:.1f} bar is outside the pressure window "
                    f"{low / 1e5:.1f}-{high / 1e5:.1f} bar (pore/fracture with margin)")
        if not (s.bhp_band_pa > 0 and s.choke_dp_band_pa > 0):
            return "bands must be positive"
        if not 0 < s.trip_speed_limit_mps <= p.trip_speed_max_mps:
            return f"trip speed limit must be in (0, {p.trip_speed_max_mps}] m/s"
        if not a.drawworks.minimum <= s.block_position_target_m <= a.drawworks.maximum:
            return (f"trip target {s.block_position_target_m:.1f} m is outside the drawworks range "
                    f"{a.drawworks.minimum:.0f}..{a.drawworks.maximum:.0f} m")
        return ""

    def _on_request(self, request, response):
        reason = self.check(request.setpoints)
        if not reason:
            s = request.setpoints
            self.active = ActiveSetpoints(*(getattr(s, f) for f in FIELDS))
            self.source = s.source or "operator"
            self.operator = True
        response.accepted = not reason
        response.reason = reason
        response.active = self._publish_setpoints()
        return response

    def _tick(self) -> None:
        t = time.monotonic() - self.t0
        if not self.operator:
            new = setpoints_at(self.ctx.scenario, t, self.start)
            if new != self.active:
                self.active = new
                self._publish_setpoints()
        sp = self.active
        step = sp.trip_speed_limit_mps * 0.6
        target = sp.block_position_target_m if sp.controller_enabled else self.u[0]
        self.u[0] += float(np.clip(target - self.u[0], -step, step))
        stamp = self.get_clock().now().to_msg()
        cmd = RigCommand(block_position_ref_m=float(self.u[0]), choke_flow_ref_m3s=float(self.u[1]),
                         bpp_flow_m3s=float(self.u[2]), spp_pa=float(self.u[3]), mud_pump_on=sp.mud_pump_on,
                         source="nmpc")
        cmd.header.stamp = stamp
        self.pub_cmd.publish(cmd)
        ref = sp.bhp_ref_pa if math.isfinite(sp.bhp_ref_pa) else (self.bhp_default or math.nan)
        status = NmpcStatus(configuration="FAKE", solve_time_s=0.012, iterations=7, solver_status="fake",
                            success=True, fallback="none", fallback_count=0, bhp_ref_pa=float(ref),
                            block_position_ref_m=float(self.u[0]))
        status.header.stamp = stamp
        self.pub_status.publish(status)


def main(args=None) -> None:
    sys.exit(run(FakeNmpc, args))


if __name__ == "__main__":
    main()
