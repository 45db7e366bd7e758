"""The protection's answer to a confirmed kick or loss: the BHP window it holds narrowed
(plain Python; docs/design.md §10, docs/faults.md).

The flow-balance detector (drill_protection.kick_detection) says the formation flows in
(kick) or takes mud (losses); it does not say at what pressure. So the answer is the one
an MPD crew gives by hand, in steps, judging each on the well's flow after it:

* on a kick alarm the window's low edge goes ``step_pa`` over the pressure the well flowed
  at: the measured BHP (the median of its last second) or the BHP reference in force,
  whichever is higher (the BHP at the alarm may be a passing wave);
* every ``interval_s`` the flow since the last step is judged: the least-squares slope of
  the detector's excess volume, the first ``settle_s`` after a step left out (the choke
  and the pressures settling). While it is over half the detector's threshold (the well
  still flows) the edge goes up another ``step_pa``; the first time it is not, the
  formation's pressure has been passed, and the edge goes up ``kick_margin_pa`` more;
* on a losses alarm the high edge comes down the same way, from the lower of the two, and
  ``losses_margin_pa`` more once the well no longer takes mud;
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
from dataclasses import dataclass

from drill_core.config import WellControl
from drill_core.event_codes import Notice
from drill_core.recent_samples import BHP_WINDOW_S, RecentSamples
from drill_core.units import LPM_PER_M3S, PA_PER_BAR
from drill_protection.slope import LeastSquaresSlope


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
        self._bhp = RecentSamples(BHP_WINDOW_S)  # the BHP the first step starts from
        self._answering = ""                      # the alarm being answered ("" none)
        self._stepped_at_s = math.nan             # its last step (or judgement) [s]
        self._volumes = LeastSquaresSlope()       # (time s since it, excess volume m^3)
        self._margin_taken = False
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
                excess_volume_m3: float, flow_threshold_m3s: float,
                reference_pa: float = math.nan) -> Notice | None:
        """Take one measurement, the detector's reading after it (its alarm and excess
        volume) and the BHP reference in force (NaN: none); the event when an edge moved
        (None otherwise)."""
        self._bhp.add(time_s, bhp_pa)
        if math.isfinite(bhp_pa) and math.isfinite(choke_dp_pa):
            offset = bhp_pa - choke_dp_pa
            if math.isfinite(self.offset_pa):
                weight = min((time_s - self._offset_at_s) / self.config.offset_time_constant_s, 1.0)
                offset = self.offset_pa + weight * (offset - self.offset_pa)
            self.offset_pa, self._offset_at_s = offset, time_s
        if not self._bhp:
            return None
        bhp = self._bhp.median
        if alarm in ("kick", "losses") and alarm != self._answering:    # the alarm's first step
            self._answering, self._margin_taken = alarm, False
            flowed_at = [bhp] + ([reference_pa] if math.isfinite(reference_pa) else [])
            start = max(self.low_pa, *flowed_at) if alarm == "kick" \
                else min(self.high_pa, *flowed_at)
            return self._step(start, time_s, bhp, "")
        if not self._answering:
            return None
        kick = self._answering == "kick"
        since = time_s - self._stepped_at_s
        if since >= self.config.settle_s - 1e-9 and math.isfinite(excess_volume_m3):
            self._volumes.append(since, excess_volume_m3)
        if since < self.config.interval_s - 1e-9:
            return None
        flow = self._volumes.slope
        self._stepped_at_s = time_s             # the next judgement an interval from now
        self._volumes.clear()
        if math.isnan(flow):
            return None
        flowing = flow > 0.5 * flow_threshold_m3s if kick else flow < -0.5 * flow_threshold_m3s
        why = f"; {flow * LPM_PER_M3S:+.0f} L/min since the last step"
        step = self.config.step_pa
        if flowing:
            self._margin_taken = False
        elif self._margin_taken:
            if not alarm:                       # answered, and the detector agrees
                self._answering = ""
            return None
        else:
            self._margin_taken = True
            step = self.config.kick_margin_pa if kick else self.config.losses_margin_pa
            why += f": the well no longer {'flows' if kick else 'takes mud'}, a margin"
        return self._step(self.low_pa if kick else self.high_pa, time_s, bhp, why, step)

    def _step(self, start_pa: float, time_s: float, bhp_pa: float, why: str,
              step_pa: float | None = None) -> Notice | None:
        """Move the answered alarm's edge ``step_pa`` (a step if None) from ``start_pa``;
        the event (None if it did not move)."""
        c = self.config
        step_pa = c.step_pa if step_pa is None else step_pa
        kick = self._answering == "kick"
        low, high = self.configured_pa
        if kick:
            edge = min(start_pa + step_pa, self.high_pa - c.gap_pa, high)
            moved, self.low_pa = edge > self.low_pa, max(self.low_pa, edge)
        else:
            edge = max(start_pa - step_pa, self.low_pa + c.gap_pa, low)
            moved, self.high_pa = edge < self.high_pa, min(self.high_pa, edge)
        self._stepped_at_s = time_s
        self._volumes.clear()
        if not moved:
            return None
        which = "low edge raised" if kick else "high edge lowered"
        return Notice("window_narrowed", f"{self._answering}: BHP window's {which} to "
                      f"{edge / PA_PER_BAR:.1f} bar (window {self.low_pa / PA_PER_BAR:.1f}-"
                      f"{self.high_pa / PA_PER_BAR:.1f} bar; BHP {bhp_pa / PA_PER_BAR:.1f} "
                      f"bar{why})", edge)

