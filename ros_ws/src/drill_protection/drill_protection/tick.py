"""The protection node's per-sample logic as a plain tick class (no rclpy): the
measurement watch (drill_protection.watch) fed every measurement, and the limiter
(drill_protection.protection) between an advisor's command and the machines. The node
moves messages in and out; the in-process loop bench (drill_bringup.loop_bench) steps the
same class."""
from __future__ import annotations

import math

import numpy as np

from drill_core.config import RigConfig
from drill_core.event_codes import Notice
from drill_core.hydraulics import WellModel
from drill_core.input_layout import U_PUMP_PRESSURE
from drill_protection.protection import Decision, ProcessProtection
from drill_protection.watch import MeasurementWatch


class ProtectionTick:
    """``observe`` each measurement, ``limit`` each advisor command against the latest.

    A request is anything with drill_msgs/RigCommand's command fields (SI):
    block_position_ref_m, choke_flow_ref_m3s, bpp_flow_m3s, spp_pa, mud_pump_on,
    choke_manual, choke_opening_ref, choke_pressure_control, choke_dp_ref_pa,
    choke_dp_ref_rate_pa_s, bhp_ref_pa. A measurement is anything with
    drill_msgs/RigMeasurement's fields."""

    def __init__(self, config: RigConfig, wm: WellModel, initial, op):
        """The machines start from the scenario's ``initial`` section at its operating point
        ``op`` (drill_core.operating_point): the block at 0, the operating point's choke flow
        and stand-pipe pressure, the initial bpp flow."""
        start = np.array([0.0, float(op.choke_flow_m3s), float(initial.bpp_flow_m3s),
                          float(op.inputs[U_PUMP_PRESSURE])])
        self.protection = ProcessProtection(config, wm, start)
        self.watch = MeasurementWatch(config, wm, self.protection)

    def observe(self, stamp_ns: int, m) -> list[Notice]:
        """One measurement through the watch: the notices it raised."""
        return self.watch.observe(stamp_ns, m)

    def limit(self, request, m, stamp_ns: int, operator_speed_limit_mps: float) -> Decision:
        """``request`` limited with the measurement ``m`` at ``stamp_ns``."""
        circulation = m.string_flow_m3s if m.string_flow_valid and math.isfinite(m.string_flow_m3s) \
            else 0.0
        self.watch.circulation.request(request.mud_pump_on, request.spp_pa)
        return self.protection.apply(
            [request.block_position_ref_m, request.choke_flow_ref_m3s, request.bpp_flow_m3s,
             request.spp_pa], m.block_position_m, self.watch.velocity_mps, m.bhp_pa,
            max(circulation, 0.0), operator_speed_limit_mps,
            request.choke_opening_ref if request.choke_manual else None,
            (request.choke_dp_ref_pa, request.choke_dp_ref_rate_pa_s)
            if request.choke_pressure_control else None,
            surface_flows=(m.return_flow_m3s, m.bpp_flow_m3s),
            trip_action=self.watch.circulation.action(stamp_ns * 1e-9),
            advisor_bhp_ref_pa=request.bhp_ref_pa, choke_dp_pa=m.choke_dp_pa)
