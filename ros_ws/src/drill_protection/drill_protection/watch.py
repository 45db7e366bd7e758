"""What the protection reads from every measurement (plain Python), in the order it reads
it: the flow-balance kick and loss detector (drill_protection.kick_detection) and, with
``stop_trip``, the trip hold of its alarm; the window a kick or loss answer narrows and
its hold (drill_protection.well_control); the circulation watch (drill_protection.pump_trip);
the BHP median the emergency stop holds; the block's velocity over VELOCITY_WINDOW_NS.
The protection node and the in-process loop bench both feed it, so each rule is here once.
"""
from __future__ import annotations

import math
from collections import deque

from drill_core import hydraulics as hy
from drill_core.config import RigConfig
from drill_core.event_codes import Notice
from drill_core.units import L_PER_M3, LPM_PER_M3S
from drill_protection.kick_detection import FlowSample, detector_for
from drill_protection.protection import ProcessProtection
from drill_protection.pump_trip import PumpTripResponse
from drill_protection.well_control import WindowResponse

VELOCITY_WINDOW_NS = 1_000_000_000      # the block velocity: over the last second [ns]
DETECTOR_CODES = ("kick_detected", "losses_detected", "kick_cleared", "losses_cleared")


def _flows(reading) -> str:
    """The detector's two readings at the display edge."""
    pit = reading.pit_gain_flow_m3s
    return (f"excess flow {reading.excess_flow_m3s * LPM_PER_M3S:+.0f} L/min" +
            (f", pit gain {pit * LPM_PER_M3S:+.0f} L/min" if math.isfinite(pit) else ""))


class MeasurementWatch:
    """Feeds ``protection`` from each measurement; counts the alarms it raised."""

    def __init__(self, config: RigConfig, wm: hy.WellModel, protection: ProcessProtection,
                 trip_tank: bool = False):
        """``trip_tank``: the well's returns go to the trip tank (a multi-stand trip), whose
        level the detector reads as the pit."""
        p = config.protection
        self.trip_tank = trip_tank
        self.protection = protection
        self.detector = detector_for(config, wm.geometry)
        self.window = WindowResponse(p.well_control, config.pressure_window_pa)
        self.circulation = PumpTripResponse(p.pump_trip, wm, config.pressure_window_pa)
        self.stop_trip = p.kick_detection.stop_trip
        self.flow_threshold_m3s = p.kick_detection.flow_threshold_m3s
        self.positions: deque = deque()         # (stamp ns, block position m), the last second
        self.alarm_count = 0

    def recount_positions(self, shift_m: float) -> None:
        """The string's position now counts from another origin (a connection racked a
        stand): the positions kept for the velocity move with it [m]."""
        self.positions = deque((stamp, position + shift_m) for stamp, position in self.positions)

    def observe(self, stamp_ns: int, m, balance: bool = True) -> list[Notice]:
        """Take one measurement (drill_msgs/RigMeasurement fields); the events it raised.
        ``balance`` False: the flows are not balanced now (the rig floor ramps the mud pump
        for a connection), so the detector starts its balance again once they are."""
        time_s = stamp_ns * 1e-9
        notices: list[Notice] = []
        before = self.detector.alarm
        circulating = m.string_flow_valid and balance
        reading = self.detector.update(FlowSample(
            time_s, m.return_flow_m3s, m.string_flow_m3s if circulating else math.nan,
            m.bpp_flow_m3s, m.block_position_m, m.choke_dp_pa, m.bhp_pa,
            m.trip_tank_volume_m3 if self.trip_tank else m.pit_volume_m3))
        if reading.raised:
            self.alarm_count += 1
            notices.append(Notice(f"{reading.alarm}_detected", f"{reading.alarm} detected: "
                                  f"{_flows(reading)}, {reading.volume_at_alarm_m3 * L_PER_M3:+.0f}"
                                  " L since it began", reading.volume_at_alarm_m3))
        elif before and not reading.alarm:
            notices.append(Notice(f"{before}_cleared", f"{before} alarm cleared: {_flows(reading)}"))
        if self.stop_trip:
            self.protection.trip_hold = f"{reading.alarm} alarm: trip stopped" if reading.alarm else ""
        narrowed = self.window.observe(time_s, m.bhp_pa, m.choke_dp_pa, reading.alarm,
                                       reading.excess_volume_m3, self.flow_threshold_m3s,
                                       self.protection.bhp_ref_pa)
        if narrowed:
            self.alarm_count += 1
            notices.append(narrowed)
        self.protection.window_pa = self.window.window_pa
        self.protection.well_control = self.window.hold()
        change = self.circulation.observe(time_s, m.string_flow_valid, m.choke_dp_pa, m.bhp_pa,
                                          m.return_flow_m3s - m.bpp_flow_m3s, self.velocity_mps)
        if change:
            self.alarm_count += self.circulation.lost
            notices.append(change)
        self.protection.observe_bhp(time_s, m.bhp_pa)
        self.positions.append((stamp_ns, m.block_position_m))
        while self.positions and stamp_ns - self.positions[0][0] > VELOCITY_WINDOW_NS:
            self.positions.popleft()
        return notices

    @property
    def velocity_mps(self) -> float:
        """The block's velocity over the last second [m/s] (0 before two samples)."""
        if len(self.positions) < 2:
            return 0.0
        (t0, x0), (t1, x1) = self.positions[0], self.positions[-1]
        return (x1 - x0) / ((t1 - t0) * 1e-9) if t1 > t0 else 0.0
