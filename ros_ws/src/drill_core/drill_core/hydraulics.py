"""Wellbore hydraulics and hoisting equations shared by the truth plant and the
estimation model (docs/design.md §3; paper eqs. 22-36, hydrostatics included).

State convention: annulus pressures p_1 (surface, choke) .. p_n (bottom), annulus
flows q_2 .. q_n positive upward, string flow q_d positive downward, string
bottom pressure p_I, string position x_s and velocity v_s positive upward.
All pressures are gauge [Pa]. Functions take an array namespace ``xp`` so the
same code runs on numpy rows and CasADi symbols; the only difference between the
plant and the estimation model is the annular friction passed in.
"""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.config import RigConfig, Well
from drill_core.rheology import Fluid, annulus_fluid, path_pressure_loss, string_fluid
from drill_core.well import WellGeometry, build_geometry


@dataclass(frozen=True)
class WellModel:
    """The well description plus what is derived from it, built once."""
    well: Well
    geometry: WellGeometry
    string_fluid: Fluid
    annulus_fluid: Fluid
    regularisation_mps: float      # yield-jump smoothing velocity
    choke_regularisation_pa: float

    @property
    def n(self) -> int:
        return self.geometry.n


def build_well_model(well: Well, regularisation_mps: float, choke_regularisation_pa: float,
                     pulled_m: float = 0.0) -> WellModel:
    """The model of ``well`` with its string tripped out by ``pulled_m`` (drill_core.well)."""
    return WellModel(well, build_geometry(well, pulled_m), string_fluid(well.mud, well.turbulence),
                     annulus_fluid(well.mud, well.turbulence), regularisation_mps,
                     choke_regularisation_pa)


def rig_well_model(config: RigConfig, pulled_m: float = 0.0, well: Well | None = None) -> WellModel:
    """The well model of ``config`` (its well, or ``well`` in its place) with the plant's
    yield and choke regularisation, its string tripped out by ``pulled_m``."""
    return build_well_model(config.well if well is None else well,
                            config.plant.yield_regularisation_velocity_mps,
                            config.plant.choke_regularisation_pa, pulled_m)


def hydrostatic_pa(wm: WellModel, depth_m: float) -> float:
    """rho g D."""
    return wm.well.mud.density_kgm3 * wm.well.gravity_mps2 * depth_m


def choke_flow(wm: WellModel, opening, dp_pa):
    """q_c = u_c C_c sqrt(2|dp|/rho) sign(dp), smoothed below the regularisation pressure."""
    w = wm.well
    root = dp_pa / (dp_pa * dp_pa + wm.choke_regularisation_pa ** 2) ** 0.25
    return opening * w.choke_coefficient_m2 * (2.0 / w.mud.density_kgm3) ** 0.5 * root


def choke_opening_for_flow(wm: WellModel, flow_m3s: float, dp_pa: float) -> float:
    """Inverse of :func:`choke_flow` for a positive differential pressure (0: no flow wanted)."""
    if flow_m3s == 0.0:
        return 0.0
    return flow_m3s / choke_flow(wm, 1.0, dp_pa)


def bit_pressure_drop(geometry: WellGeometry, string_pressure_pa, bhp_pa, rho_g, position_m):
    """p_I - (p_n - rho g (h_bit + x_s)): the string's bottom pressure over the annulus at
    the bit [Pa]; the bit sits h_bit (stands pulled) plus x_s above the BHP node (rho_g:
    mud density times g [Pa/m])."""
    return string_pressure_pa - (bhp_pa - rho_g * (geometry.bit_above_bhp_node_m + position_m))


def bit_flow(xp, wm: WellModel, dp_pa):
    """Flow through check valve + BHA: 0 if dp <= 0, else root of dp = K_b q + rho/2 (q/K_v)^2."""
    w = wm.well
    a = 0.5 * w.mud.density_kgm3 / w.bit_nozzle_coefficient_m2 ** 2
    kb = w.bha_loss_coefficient_pa_s_m3
    dp_pos = xp.fmax(dp_pa, 0.0)
    return 2.0 * dp_pos / (kb + xp.sqrt(kb * kb + 4.0 * a * dp_pos))


def string_friction(xp, wm: WellModel, string_flow_m3s, string_velocity_mps):
    """Frictional loss down the drill string [Pa] (known first-principles model, paper f_2).

    The string column is lumped incompressible, so the flow relative to the moving pipe is
    the same in every section: q_rel = q_d + A_I v_s (A_I at the top, as in the p_I balance),
    giving wall-relative velocity q_rel / A_section (not q_d / A_section + v_s, which leaves
    spurious friction where the inner diameter changes while the mud moves with the pipe).
    """
    relative_flow = string_flow_m3s + wm.geometry.string_top_inner_area_m2 * string_velocity_mps
    return path_pressure_loss(xp, relative_flow, 0.0, wm.string_fluid,
                              wm.geometry.string_sections, wm.regularisation_mps)


def annulus_friction(xp, wm: WellModel, flows_m3s, string_velocity_mps):
    """Herschel-Bulkley frictional loss [Pa] of annulus paths 2..n (truth model)."""
    return [path_pressure_loss(xp, q, string_velocity_mps, wm.annulus_fluid, path,
                               wm.regularisation_mps)
            for q, path in zip(flows_m3s, wm.geometry.annulus_paths)]


def formation_flows(xp, formation, bhp_pa, pore_pressure_pa, fracture_pressure_pa):
    """(influx, loss) [m^3/s] across the open hole at bottom-hole pressure ``bhp_pa``:
    liquid influx PI (p_pore - p_n) below pore pressure, losses II (p_n - p_frac) above
    fracture pressure, each zero inside the window (formation: config.Formation)."""
    influx = formation.productivity_index_m3_s_pa * xp.fmax(pore_pressure_pa - bhp_pa, 0.0)
    loss = formation.injectivity_index_m3_s_pa * xp.fmax(bhp_pa - fracture_pressure_pa, 0.0)
    return influx, loss


def annulus_compliance_m3_per_pa(wm: WellModel) -> float:
    """The mud the annulus takes up per pascal its pressure rises [m^3/Pa]: its volume over
    the mud's bulk modulus (so a BHP held from rising at dp/dt asks that much more flow out
    than in, times dp/dt)."""
    return float(sum(wm.geometry.annulus_volume_m3)) / wm.well.mud.bulk_modulus_pa


def bottom_inflow_rate(wm: WellModel, inflow_m3s):
    """dp_n/dt [Pa/s] of an extra inflow into the bottom annulus volume (formation flow in
    the plant, the unmeasured influx state of NMPC2's estimation model)."""
    return wm.well.mud.bulk_modulus_pa / wm.geometry.annulus_volume_m3[-1] * inflow_m3s


def line_tension(geometry: WellGeometry, damping_n_s_m: float, position_m, velocity_mps,
                 block_position_m):
    """T = -k (x_s - u_b) - c_eq v_s: the hoisting line's pull on the string [N] (k = k_eq
    with the whole string)."""
    return (-geometry.axial_stiffness_n_m * (position_m - block_position_m)
            - damping_n_s_m * velocity_mps)


def elevator_pull(geometry: WellGeometry, damping_n_s_m: float, position_m, velocity_mps,
                  block_position_m, latched=1.0):
    """The elevator's pull on the string [N]: the line's tension (:func:`line_tension`)
    times ``latched`` (1: the elevator holds the string, 0: unlatched, no pull)."""
    return latched * line_tension(geometry, damping_n_s_m, position_m, velocity_mps,
                                  block_position_m)


SLIPS_GRIP_TIME_S = 0.05   # set slips take a sinking string's speed out with this time constant


def slips_hold(slips_set, velocity_mps, net_force_n):
    """1 where set slips (``slips_set`` 1) hold the string: it is not rising and the line
    does not lift it (``net_force_n`` = T - W <= 0); 0 elsewhere (numbers or CasADi)."""
    return slips_set * (velocity_mps <= 0.0) * (net_force_n <= 0.0)


def hoisting_acceleration(wm: WellModel, position_m, velocity_mps, block_position_m,
                          latched=1.0, slips_set=0.0, xp=None):
    """m a = T - m g F_b (paper eq. 35, T: :func:`elevator_pull`, ``latched`` 1: the elevator
    holds the string, 0: unlatched). Given ``xp`` the slips act too: where
    :func:`slips_hold`, the string's speed decays to rest within SLIPS_GRIP_TIME_S instead."""
    w, g = wm.well, wm.geometry
    free = elevator_pull(g, w.hoist_damping_n_s_m, position_m, velocity_mps, block_position_m,
                         latched) / g.string_mass_kg \
        - w.gravity_mps2 * g.buoyancy_factor
    if xp is None:
        return free
    held = slips_hold(slips_set, velocity_mps, free)
    return xp.if_else(held > 0.5, -velocity_mps / SLIPS_GRIP_TIME_S, free)


@dataclass(frozen=True)
class HydraulicRates:
    """Time derivatives of the hydraulic states plus the algebraic bit flow."""
    pressure: list        # dp_i/dt, i = 1..n [Pa/s]
    flow: list            # dq_i/dt, i = 2..n [m^3/s^2]
    string_flow: object   # dq_d/dt [m^3/s^2]
    string_pressure: object  # dp_I/dt [Pa/s]
    bit_flow: object      # q_bit [m^3/s]


def hydraulic_rates(xp, wm: WellModel, pressures, flows, string_flow_m3s, string_pressure_pa,
                    position_m, velocity_mps, choke_flow_m3s, bpp_flow_m3s, pump_pressure_pa,
                    friction_pa, string_friction_law=None,
                    density_offset_kgm3=0.0, string_friction_factor=1.0,
                    bulk_modulus_factor=1.0) -> HydraulicRates:
    """Mass and momentum balances of annulus and drill string (docs/design.md §3).

    ``friction_pa`` is the annular friction of paths 2..n (HB in the plant, the
    configured law in the estimation model); ``string_friction_law(xp, wm, q_d, v_s)`` the
    string's (default :func:`string_friction`; the NMPC passes its tabulated copy);
    ``density_offset_kgm3`` is added to the mud's density in the hydrostatic columns (the
    estimation model's density offset state) and the string's friction is scaled by
    ``string_friction_factor`` (its string friction factor state) and the mud's bulk
    modulus, annulus and string, by ``bulk_modulus_factor`` (its compressibility state).
    The bit rises with the string, so the string column is D_bit - x_s high and the
    annulus pressure at the bit is p_n - rho g (h_bit + x_s) (:func:`bit_pressure_drop`).
    """
    w, g = wm.well, wm.geometry
    n = g.n
    beta = w.mud.bulk_modulus_pa * bulk_modulus_factor
    rho_g = (w.mud.density_kgm3 + density_offset_kgm3) * w.gravity_mps2
    v_s = velocity_mps
    q_bit = bit_flow(xp, wm, bit_pressure_drop(g, string_pressure_pa, pressures[n - 1], rho_g,
                                               position_m))

    inflow_from_below = list(flows) + [q_bit]     # into volume i from i+1 (bit for volume n)
    outflow_above = [choke_flow_m3s - bpp_flow_m3s] + list(flows)  # out of volume i upward
    dp = [beta / g.annulus_volume_m3[i]
          * (inflow_from_below[i] - outflow_above[i] - g.displacement_area_m2[i] * v_s)
          for i in range(n)]
    dq = [(pressures[i] - pressures[i - 1]
           - rho_g * (g.node_depth_m[i] - g.node_depth_m[i - 1]) - friction_pa[i - 1])
          / g.annulus_inertance_kg_m4[i - 1]
          for i in range(1, n)]
    dp_string = beta / g.string_volume_m3 * (string_flow_m3s - q_bit
                                              + g.string_top_inner_area_m2 * v_s)
    dq_string = (pump_pressure_pa - string_pressure_pa + rho_g * (g.bit_depth_m - position_m)
                 - string_friction_factor
                 * (string_friction_law or string_friction)(xp, wm, string_flow_m3s, v_s)) \
        / g.string_inertance_kg_m4
    return HydraulicRates(dp, dq, dq_string, dp_string, q_bit)
