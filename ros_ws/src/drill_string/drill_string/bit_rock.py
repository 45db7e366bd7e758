"""Bit-rock interaction of a drag bit (Richard et al. 2007), as used in Tengesdal (2021), Paper IV.

* Depth of cut (eq. (7)): d(t) = u_n(t) - u_n(t - t_n(t)), the bit's axial advance since the
  preceding blade passed the same angle; the delay t_n solves phi_n(t) - phi_n(t - t_n) =
  2 pi / n_b (eq. (11)). ``BladeHistory`` answers both from the bit's recorded angle and
  axial position by linear interpolation in the angle (the angle record is kept
  non-decreasing: rock already cut is not cut again).
* Forces and torques (eqs. (8)-(10), (13)-(14)): W = k_c d + k_f h, T = t_c d + t_f h with
  h the wear-flat engagement (1 while the bit moves down, 0 while it moves up, in between
  while the bit is axially stuck); no contact (d <= 0) means no force (section 5.1.2).
* Stick (sections 5.1.2-5.1.3): the bit does not turn backwards; while it stands still in
  rotation it does not advance axially either. How the reaction that holds the bit is found
  at each step is in ``simulate`` (a velocity-level constraint solved per step).

Here the law is written in the scaled units of eqs. (24) and (26) (forces per
``LumpedParameters.force_scale_n``, lengths in metres); ``SiBitRock`` gives the SI
coefficients.
"""
from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass

from .parameters import LumpedParameters


@dataclass(frozen=True)
class SiBitRock:
    """SI coefficients of eqs. (13)-(14): k_c [N/m], k_f [N], t_c [N m/m], t_f [N m]."""
    k_c_n_m: float
    k_f_n: float
    t_c_nm_m: float
    t_f_nm: float

    @classmethod
    def of(cls, p: LumpedParameters) -> "SiBitRock":
        br, rb = p.bit_rock, p.section.bit_radius_m
        k_f = br.n_blades * rb * br.wear_flat_length_m * br.contact_stress_pa
        return cls(k_c_n_m=br.n_blades * rb * br.cutting_face_ratio * br.specific_energy_pa,
                   k_f_n=k_f,
                   t_c_nm_m=br.n_blades * rb ** 2 * br.specific_energy_pa / 2.0,
                   t_f_nm=rb * br.friction_coefficient * br.wear_flat_distribution * k_f / 2.0)


@dataclass(frozen=True)
class ScaledBitRock:
    """The bit terms of eqs. (24) and (26): W = nb_alpha (d + lambda h),
    T = nb_torque_gain (d + beta lambda h)."""
    nb_alpha: float
    wear_flat_depth_m: float
    beta: float
    nb_torque_gain: float
    n_blades: int

    @classmethod
    def of(cls, p: LumpedParameters) -> "ScaledBitRock":
        return cls(p.nb_alpha, p.wear_flat_depth_m, p.beta,
                   p.bit_rock.n_blades * p.torque_gain, p.bit_rock.n_blades)

    @property
    def blade_angle_rad(self) -> float:
        return 2.0 * math.pi / self.n_blades

    def wob(self, depth_of_cut_m: float, engagement: float) -> float:
        if depth_of_cut_m <= 0.0:
            return 0.0
        return self.nb_alpha * (depth_of_cut_m + self.wear_flat_depth_m * engagement)

    def tob(self, depth_of_cut_m: float, engagement: float) -> float:
        if depth_of_cut_m <= 0.0:
            return 0.0
        return self.nb_torque_gain * (depth_of_cut_m
                                      + self.beta * self.wear_flat_depth_m * engagement)

    def nominal(self, v0: float, omega0: float) -> tuple[float, float, float, float]:
        """Steady drilling (eq. (17)): delay tau_n0, depth d0, scaled WOB and TOB."""
        tau0 = self.blade_angle_rad / omega0
        d0 = v0 * tau0
        return tau0, d0, self.wob(d0, 1.0), self.tob(d0, 1.0)


class BladeHistory:
    """Record of the bit's total angle and axial position, and the delay lookup of eq. (11).

    ``angle`` is kept non-decreasing. ``lookup(angle_now)`` returns the delay and the axial
    position the bit had when its angle was ``angle_now - 2 pi / n_b``, interpolated linearly
    in the angle; before the first record the history is extended along its first segment.
    """

    def __init__(self, blade_angle_rad: float, times, angles, positions):
        self.blade = float(blade_angle_rad)
        self.t = [float(x) for x in times]
        self.angle = [float(x) for x in angles]
        self.pos = [float(x) for x in positions]
        if len(self.t) < 2:
            raise ValueError("the history needs at least two records")
        self._lo = 0

    def append(self, t: float, angle: float, position: float) -> float:
        """Add a record; returns the stored (non-decreasing) angle."""
        last = self.angle[-1]
        if angle < last:
            angle = last
        self.t.append(t)
        self.angle.append(angle)
        self.pos.append(position)
        return angle

    def lookup(self, t_now: float, angle_now: float) -> tuple[float, float]:
        """(delay, past axial position) for the blade that passed ``angle_now - 2 pi/n_b``."""
        target = angle_now - self.blade
        angles = self.angle
        lo = self._lo if angles[self._lo] <= target else 0
        i = bisect_left(angles, target, lo)
        if i == 0:
            i = 1
        elif i >= len(angles):
            i = len(angles) - 1
        self._lo = i - 1
        a0, a1 = angles[i - 1], angles[i]
        span = a1 - a0
        w = (target - a0) / span if span > 0.0 else 1.0
        t_past = self.t[i - 1] + w * (self.t[i] - self.t[i - 1])
        pos = self.pos[i - 1] + w * (self.pos[i] - self.pos[i - 1])
        return t_now - t_past, pos
