"""Herschel-Bulkley wall shear stress for pipe and annulus (docs/design.md §3).

Laminar: the exact Rabinowitsch-Mooney relations (pipe) and the slot relation
(annulus, gap h = (d_o - d_i)/2), inverted for the wall stress by Newton steps on
log(v) versus log(tau_w - tau_y), whose slope stays between 1/n and 1/n + 1 so a
fixed number of steps converges from any start. Turbulent: tau = a rho v^2 Re_g^-b
with Re_g = 8 rho v^2 / tau_lam (pipe) or 12 rho v^2 / tau_lam (annulus), blended
smoothly between Re = 3470 - 1370 n and 4270 - 1370 n. The yield-stress jump at
v = 0 is smoothed by the factor v / sqrt(v^2 + v_reg^2).

Written against an array namespace ``xp`` (drill_core.backend) so the same code
serves numpy (vectorised) and CasADi symbols.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.backend import clip
from drill_core.config import Mud, Turbulence
from drill_core.well import FlowSection

_NEWTON_STEPS = 6
_SPEED_FLOOR_MPS = 1e-9


@dataclass(frozen=True)
class Fluid:
    """Rheology of one flow region (string or annulus) plus turbulence constants."""
    density_kgm3: float
    yield_stress_pa: float
    consistency_pa_sn: float
    flow_index: float
    turbulence_a: float
    turbulence_b: float


def string_fluid(mud: Mud, turbulence: Turbulence) -> Fluid:
    return Fluid(mud.density_kgm3, mud.yield_stress_pa, mud.consistency_pa_sn, mud.flow_index,
                 turbulence.string_a, turbulence.string_b)


def annulus_fluid(mud: Mud, turbulence: Turbulence) -> Fluid:
    if turbulence.annulus_model == "dodge_metzner":
        # Fanning f = a/Re^b with a = (log10 n + 3.93)/50, b = (1.75 - log10 n)/7; tau = f rho v^2 / 2
        log_n = math.log10(mud.flow_index)
        a, b = (log_n + 3.93) / 100.0, (1.75 - log_n) / 7.0
    else:
        a, b = turbulence.annulus_a, turbulence.annulus_b
    return Fluid(mud.density_kgm3, mud.annulus_yield_stress_pa, mud.consistency_pa_sn,
                 mud.flow_index, a, b)


def _velocity_and_slope(xp, log_excess, fluid: Fluid, section: FlowSection):
    """Mean velocity v(tau_w) and d log v / d log(tau_w - tau_y) for wall stress
    tau_y + exp(log_excess) (powers as exp of a multiple of the log: one exp, no pow)."""
    m = 1.0 / fluid.flow_index
    ty = fluid.yield_stress_pa
    k_m = fluid.consistency_pa_sn ** (-m)
    s = xp.exp(log_excess)
    s_m = xp.exp(m * log_excess)
    tau = ty + s
    tau_2 = tau * tau
    if section.annulus:
        gap = 0.5 * section.hydraulic_diameter_m
        # v = h/(2 tau^2) K^-m J,  J = int_0^S (s + ty) s^m ds
        j = s_m * s * (s / (m + 2.0) + ty / (m + 1.0))
        v = 0.5 * gap * k_m * j / tau_2
        dv = 0.5 * gap * k_m * (s_m / tau - 2.0 * j / (tau_2 * tau))
    else:
        radius = 0.5 * section.hydraulic_diameter_m
        # v = R/tau^3 K^-m I,  I = int_0^S (s + ty)^2 s^m ds
        i = s_m * s * (s * s / (m + 3.0) + 2.0 * ty * s / (m + 2.0) + ty * ty / (m + 1.0))
        v = radius * k_m * i / (tau_2 * tau)
        dv = radius * k_m * (s_m / tau - 3.0 * i / (tau_2 * tau_2))
    return v, s * dv / v


def laminar_wall_stress(xp, speed_mps, fluid: Fluid, section: FlowSection):
    """Exact laminar HB wall stress [Pa] for mean speed ``speed_mps`` >= 0 (pipe or slot)."""
    speed = xp.fmax(speed_mps, _SPEED_FLOOR_MPS)
    n = fluid.flow_index
    if section.annulus:
        shear_rate = 6.0 * speed / (0.5 * section.hydraulic_diameter_m) * (2.0 * n + 1.0) / (3.0 * n)
    else:
        shear_rate = 8.0 * speed / section.hydraulic_diameter_m * (3.0 * n + 1.0) / (4.0 * n)
    log_s = math.log(fluid.consistency_pa_sn) + n * xp.log(shear_rate)
    log_target = xp.log(speed)
    for _ in range(_NEWTON_STEPS):
        v, slope = _velocity_and_slope(xp, log_s, fluid, section)
        log_s = log_s - (xp.log(v) - log_target) / slope
    return fluid.yield_stress_pa + xp.exp(log_s)


def reynolds_number(xp, speed_mps, laminar_stress_pa, fluid: Fluid, section: FlowSection):
    """Generalised Reynolds number 8 rho v^2/tau_lam (pipe) or 12 rho v^2/tau_lam (annulus)."""
    factor = 12.0 if section.annulus else 8.0
    return factor * fluid.density_kgm3 * speed_mps * speed_mps / laminar_stress_pa


def wall_stress_magnitude(xp, speed, fluid: Fluid, section: FlowSection):
    """Wall stress [Pa] for mean speed ``speed`` >= 0, laminar to turbulent (no yield smoothing)."""
    tau_lam = laminar_wall_stress(xp, speed, fluid, section)
    re = reynolds_number(xp, speed, tau_lam, fluid, section)
    tau_turb = fluid.turbulence_a * fluid.density_kgm3 * speed * speed \
        * xp.fmax(re, 1.0) ** (-fluid.turbulence_b)
    re_low = 3470.0 - 1370.0 * fluid.flow_index
    re_high = 4270.0 - 1370.0 * fluid.flow_index
    s = clip(xp, (re - re_low) / (re_high - re_low), 0.0, 1.0)
    weight = s * s * (3.0 - 2.0 * s)
    return (1.0 - weight) * tau_lam + weight * tau_turb


def wall_stress(xp, velocity_mps, fluid: Fluid, section: FlowSection, regularisation_mps: float):
    """Signed wall stress [Pa] for mean (effective) velocity ``velocity_mps``, laminar to turbulent."""
    tau = wall_stress_magnitude(xp, xp.fabs(velocity_mps), fluid, section)
    return tau * velocity_mps / xp.sqrt(velocity_mps * velocity_mps + regularisation_mps ** 2)


def path_pressure_loss(xp, flow_m3s, string_velocity_mps, fluid: Fluid,
                       sections: tuple[FlowSection, ...], regularisation_mps: float):
    """Frictional pressure loss [Pa] over a path: sum of 4 tau_w L / d_h per section.

    Annulus: effective velocity v_e = q/A_f - K_c v_s (flow and v_s positive up).
    String: velocity relative to the wall q/A_I + v_s (q positive down, v_s positive up).
    """
    total = 0.0
    for sec in sections:
        mean = flow_m3s / sec.flow_area_m2
        rel = mean - sec.clinging * string_velocity_mps if sec.annulus else mean + string_velocity_mps
        total = total + 4.0 * sec.length_m / sec.hydraulic_diameter_m \
            * wall_stress(xp, rel, fluid, sec, regularisation_mps)
    return total
