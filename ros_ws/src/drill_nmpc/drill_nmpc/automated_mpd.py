"""Automated MPD as the industry runs it: a planned trip and a model-based surface
back-pressure set-point for a fast choke pressure loop (plain Python, no rclpy).

Each sample (t_s) the controller

1. advances a *motion profile* of the block reference toward the target: trapezoidal
   speed, the acceleration of ``automated_mpd.yaml`` (at most the process protection's),
   the cruise speed the smallest of the setpoint trip-speed limit and the *surge/swab
   envelope* - the largest speed each way at which the steady surge/swab model
   (drill_core.surge_swab, the estimation model with the UKF's friction correction)
   still lets the choke hold the BHP reference with its dp inside the dp limits;
2. computes the choke-dp set-point that holds the BHP reference at the string speed the
   plan will have ``feedforward_lead_s`` later (preview of the pipe motion), plus a trim:
   the integral of the estimated BHP error (UKF), which takes up the model's bias; the
   friction in it is that of the estimated bit flow, low-passed against the hoisting
   oscillation while the string-flow meter reads and taken as it is when it reads nothing;
   while the rig floor has the string (``string_held``: the slips, a connection's pump
   ramps) the bit flow is the estimate's flow up the bottom of the annulus, unfiltered (the
   string at rest carries no hoisting oscillation, and the string's top flow runs ahead of
   the bit's as the pump ramps), the trim stands, and while the mud pump stands
   (``mud_at_rest``) the set-point adds ``held_bhp_gain`` times the estimated BHP error:
   a yield-stress mud at rest passes a pressure change down the annulus only as it flows,
   so the BHP follows the choke slowly and the set-point overdrives it in proportion;
3. sends the set-point at t_k with its rate toward the value at t_k+1, so the choke
   controller ramps it between samples, and the steady choke flow of that motion (plus the
   mud stored by the rising pressure) as the valve's flow feedforward.

The pumps hold the initial operating point: circulation stays up through the trip.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drill_core.config import RigConfig
from drill_core.estimation_model import EstimationModel
from drill_core.hydraulics import annulus_compliance_m3_per_pa
from drill_core.scenario import ActiveSetpoints
from drill_core.surge_swab import SurgeSwabModel
from drill_nmpc.motion_profile import MotionProfile
from drill_nmpc.setpoint_book import protection_changed


@dataclass(frozen=True)
class EstimateView:
    """What the controller reads of a state estimate (SI)."""
    bhp_pa: float
    string_position_m: float
    string_velocity_mps: float
    string_flow_m3s: float
    friction_factor: tuple[float, ...]     # theta_2..theta_n of the estimation model
    density_offset_kgm3: float = 0.0       # the estimate's density offset (0: not estimated)
    string_flow_observable: bool = True    # the string-flow meter reads a flow (False: no circulation)
    bottom_annulus_flow_m3s: float = math.nan  # the estimate's flow up the bottom annulus path q_n [m^3/s]


@dataclass(frozen=True)
class MpdCommand:
    """One sample's command (SI)."""
    block_position_ref_m: float
    choke_dp_ref_pa: float          # set-point at the command's stamp
    choke_dp_ref_rate_pa_s: float   # its ramp until the next command
    choke_flow_feedforward_m3s: float
    bpp_flow_m3s: float
    spp_pa: float
    trip_speed_limit_out_mps: float  # surge/swab envelope (pulling out, running in)
    trip_speed_limit_in_mps: float
    trim_pa: float


class AutomatedMpd:
    """The controller's state between samples: the motion profile and the BHP trim."""

    def __init__(self, config: RigConfig, em: EstimationModel, bpp_flow_m3s: float,
                 spp_pa: float):
        self.cfg = config.automated_mpd
        self.sample_s = config.nmpc.sample_time_s
        self.acceleration = min(self.cfg.acceleration_mps2,
                                config.protection.trip_acceleration_max_mps2)
        self.model = SurgeSwabModel(em)
        self.storage_m3_per_pa = annulus_compliance_m3_per_pa(em.wm)
        self.downstream_pa = em.wm.well.choke_downstream_pressure_pa
        self.bpp = bpp_flow_m3s
        self.spp = spp_pa
        self.string_lag_s = config.actuators.drawworks.time_constant_s
        self.profile: MotionProfile | None = None
        self.string_speed_mps = 0.0     # the plan's string speed at this sample (lagged reference)
        self.bit_flow_m3s = math.nan    # low-passed bit flow of the estimates
        self.trim_pa = 0.0
        self.applied_block_m = math.nan  # the block reference the protection applied last
        self.string_held = False        # the rig floor has the string (slips, a connection)
        self.mud_at_rest = False        # the mud pump stands for a connection

    def string_speeds(self, reference_speeds: list[float], offsets_s) -> list[float]:
        """The string speed the plan gives at ``offsets_s`` after this sample: the reference
        speeds (one per sample, from this one on) through the drawworks lag."""
        out = []
        for offset in offsets_s:
            v, t = self.string_speed_mps, 0.0
            while t < offset - 1e-12:
                k = min(int(t / self.sample_s + 1e-9), len(reference_speeds) - 1)
                dt = min((k + 1) * self.sample_s, offset) - t
                r = reference_speeds[k]
                v = r + (v - r) * math.exp(-dt / self.string_lag_s)
                t += dt
            out.append(v)
        return out

    def speed_envelope(self, bhp_ref_pa: float, theta, bit_flow_m3s: float,
                       speed_cap_mps: float, dp_low_pa: float, dp_high_pa: float,
                       density_offset_kgm3: float = 0.0) -> tuple[float, float]:
        """Largest speed pulling out and running in (<= cap, 0.01 m/s grid) at which the
        steady choke dp holding ``bhp_ref_pa`` stays inside [dp_low, dp_high]."""
        grid = np.minimum(np.arange(1, int(round(speed_cap_mps / 0.01)) + 1) * 0.01,
                          speed_cap_mps)
        limits = []
        for direction in (1.0, -1.0):
            if not grid.size:                           # a cap below the grid's first speed
                limits.append(0.0)
                continue
            dp = self.model.choke_dp_for_bhp(bhp_ref_pa, theta, bit_flow_m3s, direction * grid,
                                             self.downstream_pa, density_offset_kgm3) \
                + self.trim_pa
            outside = np.flatnonzero(~((dp_low_pa <= dp) & (dp <= dp_high_pa)))
            last = outside[0] if outside.size else grid.size     # speeds before the first miss
            limits.append(float(grid[last - 1]) if last > 0 else 0.0)
        return limits[0], limits[1]

    def adopt_applied(self, applied_block_m: float) -> None:
        """Go on from the block reference the process protection applied to the last
        command [m] when it changed ours (a held or slowed trip): the profile continues
        from there at the applied speed, instead of running ahead of the string and
        braking too late once the protection lets it go."""
        previous, self.applied_block_m = self.applied_block_m, applied_block_m
        if self.profile is None or not protection_changed(applied_block_m,
                                                          self.profile.position_m):
            return
        speed = (applied_block_m - previous) / self.sample_s if math.isfinite(previous) else 0.0
        self.profile.position_m, self.profile.speed_mps = applied_block_m, speed

    def step(self, est: EstimateView, sp: ActiveSetpoints, bhp_ref_pa: float) -> MpdCommand:
        """One sample from the estimate and the setpoints in force."""
        if self.profile is None:
            self.profile = MotionProfile(est.string_position_m)
            self.string_speed_mps = 0.0
        theta = est.friction_factor
        held = self.string_held and math.isfinite(est.bottom_annulus_flow_m3s)
        # held: not below nothing - mud flowing down the annulus at rest is mud the choke's
        # own rise compresses, and a set-point chasing the friction it makes runs away
        bit_flow = max(est.bottom_annulus_flow_m3s, 0.0) if held \
            else self.model.bit_flow_m3s(est.string_flow_m3s, est.string_velocity_mps)
        if math.isfinite(bit_flow):
            # unfiltered while the meter reads nothing (a pump trip) or the string rests in
            # the slips (no hoisting oscillation; the pump ramps): the friction goes with the
            # pump, and a filtered flow would keep a set-point for friction that is gone
            keep = math.exp(-self.sample_s / self.cfg.flow_filter_time_constant_s) \
                if est.string_flow_observable and not held else 0.0
            self.bit_flow_m3s = bit_flow if not math.isfinite(self.bit_flow_m3s) \
                else keep * self.bit_flow_m3s + (1.0 - keep) * bit_flow
        q = self.bit_flow_m3s if math.isfinite(self.bit_flow_m3s) else 0.0
        if math.isfinite(est.bhp_pa) and not held:
            step = self.sample_s / self.cfg.trim_time_constant_s * (bhp_ref_pa - est.bhp_pa)
            self.trim_pa = min(max(self.trim_pa + step, -self.cfg.trim_limit_pa),
                               self.cfg.trim_limit_pa)
        density = est.density_offset_kgm3

        overdrive = self.cfg.held_bhp_gain * (bhp_ref_pa - est.bhp_pa) \
            if self.mud_at_rest and math.isfinite(est.bhp_pa) else 0.0

        def setpoint(speed_mps: float) -> float:
            return self.model.choke_dp_for_bhp(bhp_ref_pa, theta, q, speed_mps,
                                               self.downstream_pa, density) + self.trim_pa \
                + overdrive

        dp_low, dp_high = sp.following_rest(setpoint(0.0), self.cfg.choke_dp_min_pa) \
            .choke_dp_limits(self.cfg.choke_dp_min_pa)
        out_limit, in_limit = self.speed_envelope(bhp_ref_pa, theta, q, sp.trip_speed_limit_mps,
                                                  dp_low, dp_high, density)
        profile = self.profile
        heading_out = sp.block_position_target_m >= profile.position_m
        cruise = out_limit if heading_out else in_limit
        if sp.controller_enabled:
            profile.step(sp.block_position_target_m, cruise, self.acceleration, self.sample_s)
        else:
            profile.position_m, profile.speed_mps = est.string_position_m, 0.0
            self.string_speed_mps = 0.0
        lead = self.cfg.feedforward_lead_s
        ahead = profile.speeds_ahead(sp.block_position_target_m, cruise, self.acceleration,
                                     self.sample_s, int(math.ceil(lead / self.sample_s)) + 2)
        v_now, v_next, v_next_sample = self.string_speeds(
            ahead, (lead, lead + self.sample_s, self.sample_s))
        self.string_speed_mps = v_next_sample

        def bounded(speed_mps: float) -> float:
            return min(max(setpoint(speed_mps), dp_low), dp_high)

        dp_now = bounded(v_now)
        rate = (bounded(v_next) - dp_now) / self.sample_s
        flow = self.model.choke_flow_m3s(q, self.bpp, v_now) - self.storage_m3_per_pa * rate
        return MpdCommand(block_position_ref_m=profile.position_m, choke_dp_ref_pa=dp_now,
                          choke_dp_ref_rate_pa_s=rate, choke_flow_feedforward_m3s=max(flow, 0.0),
                          bpp_flow_m3s=self.bpp, spp_pa=self.spp,
                          trip_speed_limit_out_mps=out_limit, trip_speed_limit_in_mps=in_limit,
                          trim_pa=self.trim_pa)
