"""Well, string and bit-rock data of drilling mode, and the lumped parameters derived from them.

Sources: Tengesdal (2021), Paper IV: Table 1 (six well sections), section 4 (bit-rock values),
section 2.4 (steel wave speeds), section 2.5 (time scale and scaled equations (23)-(26)),
Tables 2 and 3 (derived parameters for n = 2 and n = 6). Everything here is SI; the scaled
("hatted") quantities are dimensionless except ``wear_flat_depth_m`` and lengths, which the
paper keeps in metres (it scales time only).

Choices the paper leaves open, fixed here and checked against its printed tables:

* steel: E = 200 GPa, G = 79.3 GPa, rho = 7850 kg/m3. They give c_s = 5048 m/s and
  c_t = 3178 m/s (the paper rounds to 5050 and 3180), t* = 0.0629 s (36") and 0.716 s (12 1/4"),
  and n^2 c_bar^2 = 10.09 (n = 2) and 90.79 (n = 6) as printed;
* the number of blades n_b = 6: the paper does not print it, but n_b * alpha = 119.0 and 460.7
  (Table 2) fix it;
* the bit radius is the hole radius;
* cross-section areas are the ones printed in Table 1 (the collar areas there are smaller
  than their printed diameters give, e.g. 0.0375 m2 for a 10" x 3" collar whose annulus is
  0.0461 m2); polar second moments come from the printed diameters. This is the only
  combination that reproduces Table 3's n_b*alpha = 926.5 and torque gain 4380;
* a string "with BHA" gives the lowest max(1, round(n * l_dc / L)) blocks collar properties
  (one collar block for the 12 1/4" section with n = 6, as in Table 3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

INCH_M = 0.0254


@dataclass(frozen=True)
class Steel:
    """Drill-string material (Paper IV section 2.4)."""
    youngs_modulus_pa: float = 200.0e9
    shear_modulus_pa: float = 79.3e9
    density_kg_m3: float = 7850.0

    @property
    def axial_wave_speed_m_s(self) -> float:
        return math.sqrt(self.youngs_modulus_pa / self.density_kg_m3)

    @property
    def torsional_wave_speed_m_s(self) -> float:
        return math.sqrt(self.shear_modulus_pa / self.density_kg_m3)


@dataclass(frozen=True)
class BitRock:
    """Drag-bit and rock values of Paper IV section 4 (Richard et al. 2007 law)."""
    contact_stress_pa: float = 45.0e6        # sigma-bar, mean wear-flat contact stress
    specific_energy_pa: float = 45.0e6       # epsilon, intrinsic specific energy
    wear_flat_length_m: float = 0.001        # l_w
    friction_coefficient: float = 0.3        # mu_f
    cutting_face_ratio: float = 0.65         # zeta
    wear_flat_distribution: float = 1.0      # gamma
    n_blades: int = 6                        # n_b (from Table 2, see module docstring)


@dataclass(frozen=True)
class WellSection:
    """One column of Paper IV Table 1, in SI."""
    name: str
    hole_diameter_m: float
    string_length_m: float
    dp_od_m: float
    dp_id_m: float
    dp_area_m2: float
    dc_od_m: float
    dc_id_m: float
    dc_area_m2: float
    dc_length_m: float
    mud_viscosity_pa_s: float
    mud_density_kg_m3: float

    @property
    def hole_radius_m(self) -> float:
        return 0.5 * self.hole_diameter_m

    @property
    def bit_radius_m(self) -> float:
        return self.hole_radius_m

    def with_viscosity(self, mud_viscosity_pa_s: float) -> "WellSection":
        return replace(self, mud_viscosity_pa_s=float(mud_viscosity_pa_s))


def _section(name, hole_in, dsl_m, dc_od_in, dc_id_in, dc_area_m2, l_dc_m, mu, rho_m):
    return WellSection(name=name, hole_diameter_m=hole_in * INCH_M, string_length_m=dsl_m,
                       dp_od_m=5.0 * INCH_M, dp_id_m=4.276 * INCH_M, dp_area_m2=0.0034,
                       dc_od_m=dc_od_in * INCH_M, dc_id_m=dc_id_in * INCH_M,
                       dc_area_m2=dc_area_m2, dc_length_m=l_dc_m,
                       mud_viscosity_pa_s=mu, mud_density_kg_m3=rho_m)


# Paper IV Table 1, section by section (hole 36" ... 6").
SECTIONS: dict[str, WellSection] = {
    "36in": _section("36in", 36.0, 200.0, 11.25, 3.25, 0.0406, 24.0, 0.0011, 1025.0),
    "26in": _section("26in", 26.0, 650.0, 11.25, 3.25, 0.0406, 45.0, 0.0011, 1025.0),
    "17.5in": _section("17.5in", 17.5, 1350.0, 11.25, 3.75, 0.0406, 53.0, 0.03, 1400.0),
    "12.25in": _section("12.25in", 12.25, 2275.0, 10.0, 3.0, 0.0375, 100.0, 0.03, 1600.0),
    "8.5in": _section("8.5in", 8.5, 3700.0, 6.5, 2.25, 0.0344, 170.0, 0.03, 1800.0),
    "6in": _section("6in", 6.0, 4370.0, 3.75, 1.5, 0.0188, 170.0, 0.03, 1100.0),
}


def section(name: str) -> WellSection:
    """A Table 1 section by name ('36in', '26in', '17.5in', '12.25in', '8.5in', '6in')."""
    try:
        return SECTIONS[name]
    except KeyError:
        raise KeyError(f"unknown well section {name!r}; known: {sorted(SECTIONS)}") from None


def polar_moment_m4(od_m: float, id_m: float) -> float:
    """Polar second moment of area of a tube, pi (r_o^4 - r_i^4) / 2."""
    return math.pi * ((0.5 * od_m) ** 4 - (0.5 * id_m) ** 4) / 2.0


def axial_drag_bracket(radius_ratio: float) -> float:
    """((1 + a^2)/(1 - a^2)) ln(1/a) - 1 of the Couette drag (3) and (25), a = r_o / r_bh."""
    a2 = radius_ratio ** 2
    return (1.0 + a2) / (1.0 - a2) * math.log(1.0 / radius_ratio) - 1.0


def torsional_drag_factor(radius_ratio: float) -> float:
    """(a^4 + a^2)/(1 - a^2) of the torsional skin drag (6)."""
    a2 = radius_ratio ** 2
    return (a2 * a2 + a2) / (1.0 - a2)


def collar_blocks(sec: WellSection, n: int, with_bha: bool) -> int:
    """How many of the n blocks (counted from the bit) carry collar properties."""
    if not with_bha:
        return 0
    return min(n, max(1, round(n * sec.dc_length_m / sec.string_length_m)))


@dataclass(frozen=True)
class BlockProperties:
    """Per-block geometry of an n-block string, top (1) to bit (n)."""
    area_m2: np.ndarray
    polar_moment_m4: np.ndarray
    outer_radius_m: np.ndarray
    block_length_m: float


def block_properties(sec: WellSection, n: int, with_bha: bool = False) -> BlockProperties:
    if n < 1:
        raise ValueError("n must be at least 1")
    n_dc = collar_blocks(sec, n, with_bha)
    is_dc = np.arange(n) >= n - n_dc
    area = np.where(is_dc, sec.dc_area_m2, sec.dp_area_m2)
    inertia = np.where(is_dc, polar_moment_m4(sec.dc_od_m, sec.dc_id_m),
                       polar_moment_m4(sec.dp_od_m, sec.dp_id_m))
    radius = np.where(is_dc, 0.5 * sec.dc_od_m, 0.5 * sec.dp_od_m)
    return BlockProperties(area.astype(float), inertia.astype(float), radius.astype(float),
                           sec.string_length_m / n)


@dataclass(frozen=True)
class LumpedParameters:
    """Scaled parameters of the n-block model, equations (24) and (26) of Paper IV.

    Time is scaled by t* = L / c_t; lengths stay in metres and angles in radians.
    """
    section: WellSection
    n: int
    with_bha: bool
    steel: Steel
    bit_rock: BitRock
    t_star_s: float                 # t* = L / c_t
    c_bar: float                    # c_s / c_t
    a: np.ndarray = field(repr=False)   # A_i / a_hat (diagonal of A1)
    l: np.ndarray = field(repr=False)   # I_i / l_hat (diagonal of L1)
    a_hat_m2: float = 0.0           # geometric mean block area
    l_hat_m4: float = 0.0           # geometric mean block polar moment
    d_hat: float = 0.0              # axial proportional damping, (25)
    c_hat: float = 0.0              # torsional proportional damping (after (26))
    alpha: float = 0.0              # n L r_b zeta eps / (G a_hat)
    wear_flat_depth_m: float = 0.0  # lambda = l_w sigma / (zeta eps), a length
    beta: float = 0.0               # mu_f gamma zeta
    torque_gain: float = 0.0        # a_hat r_b alpha / (2 l_hat zeta)

    @property
    def nb_alpha(self) -> float:
        return self.bit_rock.n_blades * self.alpha

    @property
    def stiffness_factor(self) -> float:
        """n^2 c_bar^2 of (24)."""
        return (self.n * self.c_bar) ** 2

    @property
    def force_scale_n(self) -> float:
        """Newtons per unit of scaled axial force: G a_hat / (n L)."""
        return self.steel.shear_modulus_pa * self.a_hat_m2 / (self.n * self.section.string_length_m)

    @property
    def torque_scale_nm(self) -> float:
        """Newton-metres per unit of scaled torque: G l_hat / (n L)."""
        return self.steel.shear_modulus_pa * self.l_hat_m4 / (self.n * self.section.string_length_m)

    def scaled_speed(self, rad_s: float) -> float:
        """omega_0 = Omega_0 t* (rad per unit scaled time)."""
        return rad_s * self.t_star_s

    def scaled_rate(self, m_s: float) -> float:
        """v_0 = V_0 t* (m per unit scaled time)."""
        return m_s * self.t_star_s

    def table_row(self) -> dict[str, float]:
        """The columns of Paper IV Tables 2 and 3."""
        return {"d_hat": self.d_hat, "c_hat": self.c_hat, "nb_alpha": self.nb_alpha,
                "lambda": self.wear_flat_depth_m, "beta": self.beta,
                "n2_cbar2": self.stiffness_factor, "torque_gain": self.torque_gain}


def derive(sec: WellSection | str, n: int, with_bha: bool = False, *,
           mud_viscosity_pa_s: float | None = None, steel: Steel = Steel(),
           bit_rock: BitRock = BitRock()) -> LumpedParameters:
    """Derive the scaled lumped parameters of (24)-(26) from Table 1 data."""
    if isinstance(sec, str):
        sec = section(sec)
    if mud_viscosity_pa_s is not None:
        sec = sec.with_viscosity(mud_viscosity_pa_s)
    blocks = block_properties(sec, n, with_bha)
    length = sec.string_length_m
    shear = steel.shear_modulus_pa
    c_t = steel.torsional_wave_speed_m_s
    a_hat = float(np.exp(np.mean(np.log(blocks.area_m2))))
    l_hat = float(np.exp(np.mean(np.log(blocks.polar_moment_m4))))
    ratio_top = blocks.outer_radius_m[0] / sec.hole_radius_m
    mu = sec.mud_viscosity_pa_s
    # proportional damping: the top block's coefficient per unit mass, (25) and after (26)
    d_hat = 2.0 * math.pi * mu * length * c_t / (shear * blocks.area_m2[0]) \
        / axial_drag_bracket(ratio_top)
    c_hat = 2.0 * math.pi * sec.hole_radius_m ** 2 * mu * length * c_t \
        / (shear * blocks.polar_moment_m4[0]) * torsional_drag_factor(ratio_top)
    br = bit_rock
    alpha = n * length * sec.bit_radius_m * br.cutting_face_ratio * br.specific_energy_pa \
        / (shear * a_hat)
    lam = br.wear_flat_length_m * br.contact_stress_pa / (br.cutting_face_ratio
                                                          * br.specific_energy_pa)
    beta = br.friction_coefficient * br.wear_flat_distribution * br.cutting_face_ratio
    torque_gain = a_hat * sec.bit_radius_m * alpha / (2.0 * l_hat * br.cutting_face_ratio)
    return LumpedParameters(
        section=sec, n=n, with_bha=with_bha, steel=steel, bit_rock=br,
        t_star_s=length / c_t, c_bar=steel.axial_wave_speed_m_s / c_t,
        a=blocks.area_m2 / a_hat, l=blocks.polar_moment_m4 / l_hat,
        a_hat_m2=a_hat, l_hat_m4=l_hat, d_hat=d_hat, c_hat=c_hat, alpha=alpha,
        wear_flat_depth_m=lam, beta=beta, torque_gain=torque_gain)


def rpm_to_rad_s(rpm: float) -> float:
    return rpm * 2.0 * math.pi / 60.0


def rad_s_to_rpm(rad_s: float) -> float:
    return rad_s * 60.0 / (2.0 * math.pi)
