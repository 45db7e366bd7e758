"""The conventional MPD baseline's control law (plain Python, no rclpy; the node is
drill_nmpc.baseline_node): a fixed-speed trip and a PI choke on the measured BHP.

Each sample the block reference moves toward the target at the fixed trip speed (a ramp
of speed * t_s per sample, stopping on the target; on a multi-stand trip slowing down to it
at ``braking_mps2``, so that each stand comes to rest on its end for the slips) and the
choke-flow reference is
q_c0 + k_p e + (k_p / T_i) * integral(e), e = BHP_measured - BHP_ref (BHP too high: open
the choke, let more out), clipped to [0, q_max] with anti-windup: the integral stands while
the reference is at a limit, and while the measured return flow has missed the reference
by more than FLOW_TRACKING_TOLERANCE_M3S for FLOW_SHORTFALL_SAMPLES samples running, in
the direction the integral would push it (the choke's flow loop is not delivering it: a
stuck or saturated choke, or a reference the process protection overrode; the flow loop's
own transients last a few seconds), so a choke freed after a fault is not sent a wound-up
flow.
"""
from __future__ import annotations

import math

from drill_nmpc.setpoint_book import protection_changed

FLOW_TRACKING_TOLERANCE_M3S = 100.0 / 60000.0   # 100 L/min
FLOW_SHORTFALL_SAMPLES = 3


class BaselinePi:
    """PI choke-flow controller on the BHP error, positional form with anti-windup."""

    def __init__(self, q0_m3s: float, kp_m3s_per_pa: float, ti_s: float, q_max_m3s: float):
        self.q0, self.kp, self.ti, self.q_max = q0_m3s, kp_m3s_per_pa, ti_s, q_max_m3s
        self.integral_pa_s = 0.0
        self.shortfall_samples = 0     # samples running the flow was not delivered

    def update(self, error_pa: float, dt_s: float, flow_shortfall_m3s: float = math.nan) -> float:
        """The reference for the BHP error [Pa] after ``dt_s``; ``flow_shortfall_m3s`` is the
        last reference less the measured return flow [m^3/s] (NaN: unknown)."""
        trial = self.integral_pa_s + error_pa * dt_s
        q = self.q0 + self.kp * (error_pa + trial / self.ti)
        short = abs(flow_shortfall_m3s) > FLOW_TRACKING_TOLERANCE_M3S \
            and flow_shortfall_m3s * error_pa > 0.0
        self.shortfall_samples = self.shortfall_samples + 1 if short else 0
        if 0.0 <= q <= self.q_max and self.shortfall_samples < FLOW_SHORTFALL_SAMPLES:
            self.integral_pa_s = trial            # integrate only while unsaturated
        else:
            q = self.q0 + self.kp * (error_pa + self.integral_pa_s / self.ti)
        return min(max(q, 0.0), self.q_max)


class Baseline:
    """The baseline's state between samples: the block ramp and the PI choke."""

    def __init__(self, q0_m3s: float, kp_m3s_per_pa: float, ti_s: float, q_max_m3s: float,
                 trip_speed_mps: float, sample_time_s: float, braking_mps2: float = math.inf):
        self.pi = BaselinePi(q0_m3s, kp_m3s_per_pa, ti_s, q_max_m3s)
        self.speed_mps, self.ts = trip_speed_mps, sample_time_s
        self.braking_mps2 = braking_mps2     # the ramp's deceleration onto the target [m/s^2]
        self.block_ref_m: float | None = None
        self.choke_ref_m3s = q0_m3s

    def adopt_applied(self, applied_block_m: float) -> None:
        """Ramp on from the block reference the process protection applied to the last
        command [m] when it changed ours (a held or slowed trip), not from ours: a ramp run
        ahead of the string makes it overshoot the target once the protection lets go."""
        if self.block_ref_m is not None and protection_changed(applied_block_m, self.block_ref_m):
            self.block_ref_m = applied_block_m

    def step(self, position_m: float, bhp_pa: float, target_m: float, bhp_ref_pa: float | None,
             enabled: bool = True, return_flow_m3s: float = math.nan) -> bool:
        """One sample from the measured block position, BHP and return flow [m^3/s] (NaN:
        none); updates ``block_ref_m`` and
        ``choke_ref_m3s``. Disabled, the block is held where it is measured and the choke
        reference kept. Returns False when the BHP (or its reference) was missing and the
        choke reference was held."""
        if self.block_ref_m is None:
            self.block_ref_m = position_m if math.isfinite(position_m) else 0.0
        if not enabled:
            if math.isfinite(position_m):
                self.block_ref_m = position_m
            return True
        gap = target_m - self.block_ref_m
        speed = min(self.speed_mps, math.sqrt(2.0 * self.braking_mps2 * abs(gap)))
        step = speed * self.ts
        self.block_ref_m += max(-step, min(step, gap))
        if not (math.isfinite(bhp_pa) and bhp_ref_pa is not None):
            return False
        self.choke_ref_m3s = self.pi.update(bhp_pa - bhp_ref_pa, self.ts,
                                            self.choke_ref_m3s - return_flow_m3s)
        return True
