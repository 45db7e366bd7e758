"""The well's initial operating point: at rest and circulating steadily, in closed form.

Design knowledge of the well, not a measurement: the truth plant starts from it, the
actuators start at its inputs and the advisors hold its commands until they act. Nodes
get it once from their context (``drill_ros.context``), built from the scenario's
``initial`` section.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.input_layout import U_PUMP_PRESSURE
from drill_core.scenario import Initial
from drill_core.units import LPM_PER_M3S

# The benches' operating point (drill_plant, drill_estimator and drill_nmpc bench modules):
# Case 2's start, config/scenarios/case2.yaml.
BENCH_POINT = Initial(circulation_m3s=1000.0 / LPM_PER_M3S, choke_dp_pa=2.0e6, bpp_flow_m3s=0.0)


@dataclass(frozen=True)
class OperatingPoint:
    """A consistent steady state at rest and the inputs that hold it (SI)."""
    annulus_pressure_pa: np.ndarray   # p_1..p_n [Pa]
    annulus_flow_m3s: np.ndarray      # q_2..q_n [m^3/s]
    string_pressure_pa: float         # p_I [Pa]
    string_flow_m3s: float            # q_d [m^3/s]
    inputs: np.ndarray                # [block m, choke opening 1, bpp flow m^3/s, stand-pipe Pa]
    choke_flow_m3s: float             # [m^3/s]

    @property
    def spp_pa(self) -> float:
        return float(self.inputs[U_PUMP_PRESSURE])


def operating_point(wm: hy.WellModel, circulation_m3s: float, choke_dp_pa: float,
                    bpp_flow_m3s: float) -> OperatingPoint:
    """The U-tube balance at a circulation rate: all annulus flows equal the bit flow,
    p_1 = p_0 + choke dp, each node adds its hydrostatic head and friction, the bit (its
    height over the bottom node less that column) adds the bit/BHA loss, the string top
    the string's friction less its column. Circulation 0: the mud pump is off (string top
    at atmosphere)."""
    g, w = wm.geometry, wm.well
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    flows = np.full(wm.n - 1, float(circulation_m3s))
    friction = hy.annulus_friction(np, wm, flows, 0.0)
    pressures = np.zeros(wm.n)
    pressure = w.choke_downstream_pressure_pa + choke_dp_pa
    pressures[0] = pressure
    for i in range(2, wm.n + 1):
        pressure += rho_g * (g.node_depth_m[i - 1] - g.node_depth_m[i - 2]) + friction[i - 2]
        pressures[i - 1] = pressure
    if circulation_m3s > 0.0:
        a = 0.5 * w.mud.density_kgm3 / w.bit_nozzle_coefficient_m2 ** 2
        bit_dp = w.bha_loss_coefficient_pa_s_m3 * circulation_m3s + a * circulation_m3s ** 2
        string_pressure = pressure - rho_g * g.bit_above_bhp_node_m + bit_dp
        pump = string_pressure - rho_g * g.bit_depth_m \
            + float(hy.string_friction(np, wm, circulation_m3s, 0.0))
    else:
        pump = 0.0
        string_pressure = rho_g * g.bit_depth_m
    choke_flow = circulation_m3s + bpp_flow_m3s
    opening = hy.choke_opening_for_flow(wm, choke_flow, choke_dp_pa)
    return OperatingPoint(pressures, flows, float(string_pressure), float(circulation_m3s),
                          np.array([g.static_stretch_m, opening, bpp_flow_m3s, pump]),
                          choke_flow)


def initial_operating_point(wm: hy.WellModel, initial: Initial) -> OperatingPoint:
    """The operating point of a scenario's ``initial`` section."""
    return operating_point(wm, initial.circulation_m3s, initial.choke_dp_pa, initial.bpp_flow_m3s)
