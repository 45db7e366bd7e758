"""Well geometry derived once from the typed well description (docs/design.md §3).

Lumping (documented in docs/model.md): annulus segment i is control volume i with
pressure p_i. Node 1 sits at the surface (the choke sees p_1), node n at the full
string's bit depth (the BHP node), interior nodes at segment mid-depths. Flow q_i
(i = 2..n) runs over the path between nodes i-1 and i. Tool joints are smeared over
the pipe length by their length fraction.

A string tripped out by ``pulled_m`` (whole stands racked back) is the same string
with its top section that much shorter: the bit sits ``pulled_m`` above the BHP node,
the hole below it is open, and mass, volumes, friction paths and the axial stiffness
follow; the nodes stay where they are, so the pressure states carry over a connection.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drill_core.config import Well


@dataclass(frozen=True)
class FlowSection:
    """A stretch of a flow path with constant cross-section."""
    length_m: float
    flow_area_m2: float
    hydraulic_diameter_m: float   # pipe: inner diameter; annulus: d_hole - d_string
    clinging: float               # clinging constant K_c (annulus); 0 inside the pipe
    annulus: bool


@dataclass(frozen=True)
class WellGeometry:
    """Everything the hydraulic model needs about the well, in SI units."""
    n: int                                          # annulus segments
    node_depth_m: tuple[float, ...]                 # D_1 .. D_n
    annulus_volume_m3: tuple[float, ...]            # V_1 .. V_n (fluid volume)
    annulus_inertance_kg_m4: tuple[float, ...]      # M_2 .. M_n
    annulus_paths: tuple[tuple[FlowSection, ...], ...]  # sections of paths 2..n
    displacement_area_m2: tuple[float, ...]         # dV_i/dt = displacement_area_i * v_s
    main_flow_area_m2: tuple[float, ...]            # A_f of the main section of paths 2..n
    main_clinging: tuple[float, ...]                # K_c of the main section of paths 2..n
    string_volume_m3: float                         # V_I
    string_inertance_kg_m4: float                   # M_I
    string_sections: tuple[FlowSection, ...]        # inside the string, top to bit
    string_top_inner_area_m2: float                 # A_I: inner area where the string leaves the well
    string_outer_area_at_top_m2: float              # outer area where the string leaves the well
    bit_depth_m: float
    well_depth_m: float
    string_mass_kg: float
    buoyancy_factor: float                          # F_b = 1 - rho_m / rho_s
    static_stretch_m: float                         # m g F_b / k
    bit_above_bhp_node_m: float                     # the bit's height over node n with x_s = 0
    axial_stiffness_n_m: float                      # k: hoist + string at this string length


def equivalent_density_kgm3(pressure_pa: float, depth_m: float, gravity_mps2: float) -> float:
    """The density of a static mud column that gives ``pressure_pa`` (gauge) at the
    vertical depth ``depth_m``: ECD (circulating) or ESD (static) [kg/m^3]."""
    return pressure_pa / (gravity_mps2 * depth_m)


def annulus_pressure_at_depth_pa(node_depth_m, pressures_pa, depth_m: float) -> float:
    """The annulus pressure at the vertical depth ``depth_m`` between the model's nodes
    (``node_depth_m`` D_1..D_n, ``pressures_pa`` p_1..p_n): linear between the two nodes
    around it, as the hydrostatic and frictional gradients along one path are uniform."""
    if not node_depth_m[0] <= depth_m <= node_depth_m[-1]:
        raise ValueError(f"depth {depth_m:g} m outside the nodes' {node_depth_m[0]:g}.."
                         f"{node_depth_m[-1]:g} m")
    return float(np.interp(depth_m, node_depth_m, pressures_pa))


def circle_area(diameter_m: float) -> float:
    return math.pi / 4.0 * diameter_m ** 2


def clinging_constant(diameter_ratio: float) -> float:
    """Laminar clinging constant K_c = 1/(2 ln(1/a)) - a^2/(1 - a^2), a = d_pipe/d_hole (eq. 47)."""
    a = diameter_ratio
    return 1.0 / (2.0 * math.log(1.0 / a)) - a * a / (1.0 - a * a)


def _variants(well: Well, pulled_m: float = 0.0):
    """Per string section: depth interval and its (weight, outer d, inner d) variants;
    the top section ``pulled_m`` shorter."""
    top = 0.0
    out = []
    for index, s in enumerate(well.string):
        bottom = top + s.length_m - (pulled_m if index == 0 else 0.0)
        variants = [(1.0, s.outer_diameter_m, s.inner_diameter_m)]
        if s.tool_joint_length_m > 0.0:
            f = s.tool_joint_length_m / s.tool_joint_spacing_m
            variants = [(1.0 - f, s.outer_diameter_m, s.inner_diameter_m),
                        (f, s.tool_joint_outer_diameter_m, s.tool_joint_inner_diameter_m)]
        out.append((top, bottom, tuple(variants)))
        top = bottom
    return out


def _pieces(sections, a: float, b: float, holes=()):
    """Pieces of the depth interval [a, b]: (length, variants, hole diameter); variants
    empty below the bit. ``holes``: (top, bottom, diameter) of each annulus segment (the
    pieces are cut at their bounds too; without: diameter NaN)."""
    bounds = [t for t, _, _ in sections] + [u for _, u, _ in sections] \
        + [t for t, _, _ in holes] + [u for _, u, _ in holes]
    cuts = sorted({a, b, *[d for d in bounds if a < d < b]})
    out = []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        mid = 0.5 * (lo + hi)
        variants = next((v for t, u, v in sections if t <= mid < u), ())
        hole = next((d for t, u, d in holes if t <= mid < u), math.nan)
        out.append((hi - lo, variants, hole))
    return out


def _outer_area_at(sections, depth: float) -> float:
    variants = next((v for t, u, v in sections if t <= depth < u), ())
    return sum(w * circle_area(od) for w, od, _ in variants)


def _merged(holes):
    """(top, bottom, diameter) intervals with neighbours of one diameter joined."""
    out = [holes[0]]
    for top, bottom, d in holes[1:]:
        if d == out[-1][2]:
            out[-1] = (out[-1][0], bottom, d)
        else:
            out.append((top, bottom, d))
    return tuple(out)


def _annulus_sections(pieces) -> tuple[FlowSection, ...]:
    out = []
    for length, variants, d_hole in pieces:
        for w, od, _ in (variants or ((1.0, 0.0, 0.0),)):
            out.append(FlowSection(
                length_m=length * w,
                flow_area_m2=circle_area(d_hole) - circle_area(od),
                hydraulic_diameter_m=d_hole - od,
                clinging=clinging_constant(od / d_hole) if od > 0.0 else 0.0,
                annulus=True))
    return tuple(out)


def _axial_compliance(sections) -> float:
    """Sum of L / A_steel over the string [1/m]: its stretch per unit force times E."""
    return sum((bottom - top) * w / (circle_area(od) - circle_area(idia))
               for top, bottom, variants in sections for w, od, idia in variants)


def build_geometry(well: Well, pulled_m: float = 0.0) -> WellGeometry:
    """Derive volumes, inertances, friction paths and displacement terms from ``well``,
    with the string tripped out by ``pulled_m`` (0 <= pulled_m < the top section's length).

    The configured k_eq is the hoisting system's stiffness with the whole string; a
    shorter string is stiffer in the ratio of the strings' axial compliances (sum of
    L / A_steel), the only part of k_eq that changes with the length."""
    top_length = well.string[0].length_m
    if not 0.0 <= pulled_m < top_length:
        raise ValueError(f"pulled_m = {pulled_m} m: allowed 0 <= pulled_m < {top_length} m "
                         f"(the length of the top string section '{well.string[0].name}')")
    rho = well.mud.density_kgm3
    full_sections = _variants(well)
    sections = _variants(well, pulled_m)
    bit_depth = sections[-1][1]
    bhp_node_depth = full_sections[-1][1]
    bounds = [0.0]
    for length in well.segment_lengths_m:
        bounds.append(bounds[-1] + length)
    n = len(well.segment_lengths_m)
    depths = [0.0] + [0.5 * (bounds[i] + bounds[i + 1]) for i in range(1, n - 1)] \
        + [bhp_node_depth]
    if any(d1 >= d2 for d1, d2 in zip(depths[:-1], depths[1:])):
        raise ValueError(f"node depths {depths} are not increasing: the bit must lie below the "
                         "middle of the second-deepest segment")

    holes = _merged(tuple(zip(bounds[:-1], bounds[1:], well.hole_diameters_m())))
    volumes = []
    displacement = []
    for i in range(n):
        a, b = bounds[i], bounds[i + 1]
        steel_outer = sum(length * sum(w * circle_area(od) for w, od, _ in v)
                          for length, v, _ in _pieces(sections, a, b))
        hole = next(d for t, u, d in holes if t <= 0.5 * (a + b) < u)
        volumes.append(circle_area(hole) * (b - a) - steel_outer)
        displacement.append(_outer_area_at(sections, a) - _outer_area_at(sections, b))

    paths, inertances, main_area, main_kc = [], [], [], []
    for i in range(1, n):
        path = _annulus_sections(_pieces(sections, depths[i - 1], depths[i], holes))
        paths.append(path)
        inertances.append(rho * sum(s.length_m / s.flow_area_m2 for s in path))
        main = max(path, key=lambda s: s.length_m)
        main_area.append(main.flow_area_m2)
        main_kc.append(main.clinging)

    string_sections = []
    steel_mass = 0.0
    for top, bottom, variants in sections:
        for w, od, idia in variants:
            string_sections.append(FlowSection(
                length_m=(bottom - top) * w, flow_area_m2=circle_area(idia),
                hydraulic_diameter_m=idia, clinging=0.0, annulus=False))
            steel_mass += (bottom - top) * w * (circle_area(od) - circle_area(idia)) \
                * well.steel_density_kgm3
    top_variants = sections[0][2]
    buoyancy = 1.0 - rho / well.steel_density_kgm3
    stiffness = well.hoist_stiffness_n_m \
        * (_axial_compliance(full_sections) / _axial_compliance(sections))
    return WellGeometry(
        n=n,
        node_depth_m=tuple(depths),
        annulus_volume_m3=tuple(volumes),
        annulus_inertance_kg_m4=tuple(inertances),
        annulus_paths=tuple(paths),
        displacement_area_m2=tuple(displacement),
        main_flow_area_m2=tuple(main_area),
        main_clinging=tuple(main_kc),
        string_volume_m3=sum(s.length_m * s.flow_area_m2 for s in string_sections),
        string_inertance_kg_m4=rho * sum(s.length_m / s.flow_area_m2 for s in string_sections),
        string_sections=tuple(string_sections),
        string_top_inner_area_m2=sum(w * circle_area(i) for w, _, i in top_variants),
        string_outer_area_at_top_m2=sum(w * circle_area(o) for w, o, _ in top_variants),
        bit_depth_m=bit_depth,
        well_depth_m=bounds[-1],
        string_mass_kg=steel_mass,
        buoyancy_factor=buoyancy,
        static_stretch_m=steel_mass * well.gravity_mps2 * buoyancy / stiffness,
        bit_above_bhp_node_m=bhp_node_depth - bit_depth,
        axial_stiffness_n_m=stiffness,
    )
