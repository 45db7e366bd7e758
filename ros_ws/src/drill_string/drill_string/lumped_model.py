"""Lumped multi-element drill string: n point masses on massless springs, axial and torsional.

Tengesdal (2021), Paper IV, sections 2.1-2.2: the top spring hangs from the travelling block
(axial) or the top drive (torsional), the bit is on the last block, z points down. Each block
is drill pipe or collar. Two forms are built here:

* SI matrices M, D, K (axial, eqs. (1)-(3)) and J, C, K (torsional, eqs. (4)-(6)) with the
  block's own mud-drag coefficient, for eigen-analysis and the analytic steady state of
  section 2.4 (eqs. (15)-(19));
* the scaled matrices A1, A2, L1, L2 of eqs. (24) and (26) (time in units of t* = L / c_t,
  proportional damping), which the simulator and the stability analysis use.

The continuum references of the thesis' section 2.2.8 (a fixed-free rod) are here too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh, eigvalsh_tridiagonal

from .parameters import (LumpedParameters, Steel, WellSection, axial_drag_bracket,
                         block_properties, torsional_drag_factor)

GRAVITY_M_S2 = 9.81


def chain_stiffness(k: np.ndarray) -> np.ndarray:
    """Tridiagonal stiffness of a fixed-free spring chain: spring i joins block i-1 and i,
    spring 1 joins block 1 to the (moving) top boundary."""
    k = np.asarray(k, dtype=float)
    n = k.size
    out = np.diag(k.copy())
    out[:-1, :-1] += np.diag(k[1:])
    idx = np.arange(n - 1)
    out[idx, idx + 1] = -k[1:]
    out[idx + 1, idx] = -k[1:]
    return out


@dataclass(frozen=True)
class SecondOrderSystem:
    """M q'' + D q' + K q = forces, in SI."""
    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray

    def eigenfrequencies_rad_s(self) -> np.ndarray:
        """Undamped natural frequencies, ascending."""
        m, k = self.mass, self.stiffness
        if np.count_nonzero(m - np.diag(np.diag(m))) == 0 \
                and np.count_nonzero(np.triu(k, 2)) == 0:
            # lumped chain: M^-1/2 K M^-1/2 is symmetric tridiagonal
            r = 1.0 / np.sqrt(np.diag(m))
            lam = eigvalsh_tridiagonal(np.diag(k) * r * r, np.diag(k, 1) * r[:-1] * r[1:])
        else:
            lam = eigh(k, m, eigvals_only=True)
        return np.sqrt(lam)


def axial_system(sec: WellSection, n: int, with_bha: bool = False,
                 steel: Steel = Steel()) -> SecondOrderSystem:
    """Axial M, D, K of Paper IV eqs. (1)-(3): m_i = rho A_i h, k_i = E A_i / h,
    d_i = 2 pi h mu / bracket(r_o,i / r_bh)."""
    b = block_properties(sec, n, with_bha)
    h = b.block_length_m
    mass = np.diag(steel.density_kg_m3 * b.area_m2 * h)
    drag = np.array([2.0 * math.pi * h * sec.mud_viscosity_pa_s
                     / axial_drag_bracket(r / sec.hole_radius_m) for r in b.outer_radius_m])
    return SecondOrderSystem(mass, np.diag(drag),
                             chain_stiffness(steel.youngs_modulus_pa * b.area_m2 / h))


def torsional_system(sec: WellSection, n: int, with_bha: bool = False,
                     steel: Steel = Steel()) -> SecondOrderSystem:
    """Torsional J, C, K of Paper IV eqs. (4)-(6): J_i = rho h I_i, kappa_i = G I_i / h,
    c_i = 2 pi r_bh^2 h mu (a^4 + a^2)/(1 - a^2)."""
    b = block_properties(sec, n, with_bha)
    h = b.block_length_m
    inertia = np.diag(steel.density_kg_m3 * b.polar_moment_m4 * h)
    drag = np.array([2.0 * math.pi * sec.hole_radius_m ** 2 * h * sec.mud_viscosity_pa_s
                     * torsional_drag_factor(r / sec.hole_radius_m) for r in b.outer_radius_m])
    return SecondOrderSystem(inertia, np.diag(drag),
                             chain_stiffness(steel.shear_modulus_pa * b.polar_moment_m4 / h))


def buoyancy_factor(sec: WellSection, steel: Steel = Steel()) -> float:
    """F_b = 1 - rho_mud / rho_steel."""
    return 1.0 - sec.mud_density_kg_m3 / steel.density_kg_m3


def buoyed_weight_n(p: LumpedParameters) -> float:
    """Weight in mud of the lumped string, sum rho A_i h g F_b: the hook load off bottom."""
    mass_kg = p.steel.density_kg_m3 * float(np.sum(p.a)) * p.a_hat_m2 \
        * p.section.string_length_m / p.n
    return mass_kg * GRAVITY_M_S2 * buoyancy_factor(p.section, p.steel)


def continuum_fixed_free_rad_s(wave_speed_m_s: float, length_m: float, modes: int) -> np.ndarray:
    """Natural frequencies of a uniform rod fixed at the top, free at the bottom:
    omega_k = (2k - 1) pi c / (2 L) (thesis eq. (2.42))."""
    k = np.arange(1, modes + 1)
    return (2 * k - 1) * math.pi * wave_speed_m_s / (2.0 * length_m)


def uniform_chain_rad_s(wave_speed_m_s: float, length_m: float, n: int) -> np.ndarray:
    """Closed form of the n-mass uniform fixed-free chain:
    omega_k = (2 c / h) sin((2k - 1) pi / (2 (2n + 1))), h = L / n."""
    k = np.arange(1, n + 1)
    h = length_m / n
    return 2.0 * wave_speed_m_s / h * np.sin((2 * k - 1) * math.pi / (2.0 * (2 * n + 1)))


@dataclass(frozen=True)
class SteadyState:
    """Drilling steady state of Paper IV section 2.4 at block speed V0 and top-drive speed
    Omega0, all SI. Positions are the static offsets y* and phi* of eqs. (16) and (19), in
    suspended-string coordinates (eq. (12)), at t = 0."""
    depth_of_cut_m: float
    delay_s: float
    wob_n: float
    tob_nm: float
    axial_offset_m: np.ndarray
    angle_offset_rad: np.ndarray


def steady_state(p: LumpedParameters, block_speed_m_s: float,
                 top_drive_rad_s: float) -> SteadyState:
    """Analytic steady state (15)-(19) of the SI model with the bit-rock law of section 2.3."""
    sec, n, br = p.section, p.n, p.bit_rock
    axial = axial_system(sec, n, p.with_bha, p.steel)
    tors = torsional_system(sec, n, p.with_bha, p.steel)
    nb, rb = br.n_blades, sec.bit_radius_m
    k_c = nb * rb * br.cutting_face_ratio * br.specific_energy_pa
    k_f = nb * rb * br.wear_flat_length_m * br.contact_stress_pa
    t_c = nb * rb ** 2 * br.specific_energy_pa / 2.0
    t_f = rb * br.friction_coefficient * br.wear_flat_distribution * k_f / 2.0
    delay = 2.0 * math.pi / (nb * top_drive_rad_s)
    d0 = block_speed_m_s * delay
    wob = k_c * d0 + k_f
    tob = t_c * d0 + t_f
    t2 = np.zeros(n)
    t2[-1] = 1.0
    # (15) at t = 0: K y* = -D V0 - t2 W0 ; (18) at t = 0: K phi* = -C Omega0 - t2 T0
    y_star = np.linalg.solve(axial.stiffness, -axial.damping @ np.full(n, block_speed_m_s)
                             - t2 * wob)
    phi_star = np.linalg.solve(tors.stiffness, -tors.damping @ np.full(n, top_drive_rad_s)
                               - t2 * tob)
    return SteadyState(d0, delay, wob, tob, y_star, phi_star)


def scaled_axial_matrices(p: LumpedParameters) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A1, d_hat A1 and n^2 c_bar^2 A2 of eq. (24)."""
    a1 = np.diag(p.a)
    return a1, p.d_hat * a1, p.stiffness_factor * chain_stiffness(p.a)


def scaled_torsional_matrices(p: LumpedParameters) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """L1, c_hat L1 and n^2 L2 of eq. (26)."""
    l1 = np.diag(p.l)
    return l1, p.c_hat * l1, p.n ** 2 * chain_stiffness(p.l)


def scaled_axial_eigenfrequencies(p: LumpedParameters) -> np.ndarray:
    """omega_j = sqrt(n^2 c_bar^2 lambda_j) of (31), scaled time units, descending."""
    a1, _, k = scaled_axial_matrices(p)
    return np.sqrt(eigh(k, a1, eigvals_only=True))[::-1]
