"""The protection's answer to a confirmed kick or loss: the BHP window it holds narrowed
(plain Python; docs/design.md §10, docs/faults.md).

The flow-balance detector (drill_protection.kick_detection) says the formation flows in
(kick) or takes mud (losses); it does not say at what pressure. So the answer is the one
an MPD crew gives by hand, in steps:

* on a kick alarm the window's low edge goes to the measured BHP (the median of its last
  second) plus ``step_pa``, and up by ``step_pa`` again every ``interval_s`` while the
  detector's excess flow stays over half its threshold (the well still flowing);
* on a losses alarm the high edge comes down the same way while the well still takes mud;
* never closer to the other edge than ``gap_pa``, never beyond the configured window.

From the first step on the protection holds BHP at a target half a step inside the moved
edge (the middle of the window once both edges moved) until the advisor aims there. Every
machine command (/rig/command) carries the window and the BHP reference in force, the
target while the advisor's reference is outside the window; the advisor takes the target
as its reference at its next sample (drill_nmpc.setpoint_book) and its command's
reference is inside the window from then on: the choke is the advisor's again, the window
still the protection's (the trip-speed limits keep to it). Both travel on lockstepped
topics, so the handover happens at the same sample in every run.

While the protection holds, it holds the choke on its pressure loop at the set-point
that puts BHP at the target: dp_set = target - (BHP - dp), where BHP - dp (the annulus
column and friction between the gauges) is low-passed over ``offset_time_constant_s``
(taken sample by sample it carries the pressure waves the choke's own moves make, and
the set-point chases them: a 10 s oscillation of ±15 bar in the kick scenario); with the
measured return flow as the loop's flow feed-forward, whatever the advisor asks for the
choke. The window is not given back during the run: the formation's pressure is still
there.
"""
from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass

from drill_core.config import WellControl
from drill_core.units import PA_PER_BAR

BHP_MEDIAN_S = 1.0          # the BHP the first step starts from: the median of this long


@dataclass(frozen=True)
class Hold:
    """The protection holding BHP at a target in the narrowed window."""
    choke_dp_pa: float        # the choke's pressure-loop set-point [Pa]
    target_bhp_pa: float      # the BHP it puts the well at [Pa]
    reason: str


class WindowResponse:
    """The window the protection holds BHP in [Pa], narrowed by kick and losses alarms."""

    def __init__(self, config: WellControl, window_pa: tuple[float, float]):
        self.config = config
        self.configured_pa = window_pa
        self.low_pa, self.high_pa = window_pa
        self._bhp: deque = deque()              # (time s, BHP Pa) of the last second
        self._stepped_at_s: float | None = None
        self.offset_pa = math.nan               # BHP - choke dp, low-passed [Pa]
        self._offset_at_s = math.nan

    @property
    def window_pa(self) -> tuple[float, float]:
        return self.low_pa, self.high_pa

    @property
    def narrowed(self) -> bool:
        return self.window_pa != self.configured_pa

    @property
    def target_bhp_pa(self) -> float:
        """The BHP the choke is held at [Pa] (NaN while the window is as configured)."""
        low, high = self.configured_pa
        half = 0.5 * self.config.step_pa
        if self.low_pa > low and self.high_pa < high:
            return 0.5 * (self.low_pa + self.high_pa)
        if self.low_pa > low:
            return min(self.low_pa + half, 0.5 * (self.low_pa + self.high_pa))
        if self.high_pa < high:
            return max(self.high_pa - half, 0.5 * (self.low_pa + self.high_pa))
        return math.nan

    def hold(self) -> Hold | None:
        """The choke-dp set-point that puts BHP at the target, and why; None while the
        window is as configured or before a finite pair of pressures."""
        if not self.narrowed or not math.isfinite(self.offset_pa):
            return None
        target = self.target_bhp_pa
        setpoint = max(target - self.offset_pa, 0.0)
        return Hold(setpoint, target,
                    f"well control: choke held at {setpoint / PA_PER_BAR:.1f} bar dp for BHP "
                    f"{target / PA_PER_BAR:.1f} bar (window {self.low_pa / PA_PER_BAR:.1f}-"
                    f"{self.high_pa / PA_PER_BAR:.1f} bar)")

    def observe(self, time_s: float, bhp_pa: float, choke_dp_pa: float, alarm: str,
                excess_flow_m3s: float, flow_threshold_m3s: float) -> str:
        """Take one measurement and the detector's reading after it; the event text when an
        edge moved ("" otherwise)."""
        if math.isfinite(bhp_pa):
            self._bhp.append((time_s, bhp_pa))
        if math.isfinite(bhp_pa) and math.isfinite(choke_dp_pa):
            offset = bhp_pa - choke_dp_pa
            if math.isfinite(self.offset_pa):
                weight = min((time_s - self._offset_at_s) / self.config.offset_time_constant_s, 1.0)
                offset = self.offset_pa + weight * (offset - self.offset_pa)
            self.offset_pa, self._offset_at_s = offset, time_s
        while self._bhp and self._bhp[0][0] < time_s - BHP_MEDIAN_S + 1e-9:
            self._bhp.popleft()
        if alarm not in ("kick", "losses") or not self._bhp:
            self._stepped_at_s = None
            return ""
        kick = alarm == "kick"
        if self._stepped_at_s is not None:
            flowing = excess_flow_m3s > 0.5 * flow_threshold_m3s if kick \
                else excess_flow_m3s < -0.5 * flow_threshold_m3s
            if not flowing or time_s - self._stepped_at_s < self.config.interval_s - 1e-9:
                return ""
        c = self.config
        bhp = statistics.median(p for _, p in self._bhp)
        low, high = self.configured_pa
        if kick:
            start = self.low_pa if self._stepped_at_s is not None else max(self.low_pa, bhp)
            edge = min(start + c.step_pa, self.high_pa - c.gap_pa, high)
            moved, self.low_pa = edge > self.low_pa, max(self.low_pa, edge)
        else:
            start = self.high_pa if self._stepped_at_s is not None else min(self.high_pa, bhp)
            edge = max(start - c.step_pa, self.low_pa + c.gap_pa, low)
            moved, self.high_pa = edge < self.high_pa, min(self.high_pa, edge)
        self._stepped_at_s = time_s
        if not moved:
            return ""
        which = "low edge raised" if kick else "high edge lowered"
        return (f"{alarm}: BHP window's {which} to {edge / PA_PER_BAR:.1f} bar (window "
                f"{self.low_pa / PA_PER_BAR:.1f}-{self.high_pa / PA_PER_BAR:.1f} bar; BHP "
                f"{bhp / PA_PER_BAR:.1f} bar)")
