"""Quasi-steady surge and swab of the estimation model: what the annulus does when the
string moves at a constant speed, with the friction correction theta the UKF estimates.

At a constant string velocity v_s (positive up) the volumes of the estimation model are
steady, so its mass balances (drill_core.hydraulics.hydraulic_rates) give the flows in
closed form from the bit flow q_b: each annulus volume i passes on what comes from below
less its displacement A_d,i v_s, and the choke passes the top volume's outflow plus the
back-pressure pump's flow. The bit flow itself stays put while the string moves with the
mud pump on pressure control: the string's friction and the bit's loss are functions of
the flow relative to the pipe, q_d + A_I v_s, which is the bit flow, so the pump's flow q_d
gives way by A_I v_s instead. The annular friction of each path is the estimation model's
law at those flows and v_s. The BHP at the fixed BHP depth differs from the choke pressure
by the mud column between them plus that friction; surge (v_s < 0) and swab (v_s > 0) are
its change against the string at rest.

Plain numpy; used by the automated-MPD controller (feedforward of the planned motion and
its trip-speed envelope).
"""
from __future__ import annotations

import numpy as np

from drill_core.backend import NUMPY
from drill_core.estimation_model import EstimationModel, path_friction


class SurgeSwabModel:
    """Steady flows, friction and BHP change of an estimation model at a string speed."""

    def __init__(self, em: EstimationModel):
        self.em = em
        g, w = em.wm.geometry, em.wm.well
        self.column_pa = w.mud.density_kgm3 * w.gravity_mps2 \
            * (g.node_depth_m[-1] - g.node_depth_m[0])
        self._displacement = np.asarray(g.displacement_area_m2, dtype=float)
        self._string_area = float(g.string_top_inner_area_m2)

    def bit_flow_m3s(self, string_flow_m3s: float, velocity_mps: float) -> float:
        """Bit flow of a state: the string flow q_d plus the mud the moving string carries."""
        return string_flow_m3s + self._string_area * velocity_mps

    def path_flows_m3s(self, bit_flow_m3s: float, velocity_mps) -> np.ndarray:
        """Steady flows of annulus paths 2..n (path i carries volume i's inflow from below),
        one row per path; ``velocity_mps`` a speed or an array of speeds."""
        v = np.asarray(velocity_mps, dtype=float)
        flows = []
        flow = bit_flow_m3s + 0.0 * v
        for i in range(self.em.n - 1, 0, -1):        # volume i (0-based) passes up to path i + 1
            flow = flow - self._displacement[i] * v
            flows.append(flow)
        return np.array(flows[::-1])

    def choke_flow_m3s(self, bit_flow_m3s: float, bpp_flow_m3s: float,
                       velocity_mps: float) -> float:
        """Steady choke flow: the top volume's outflow plus the back-pressure pump's flow."""
        top = self.path_flows_m3s(bit_flow_m3s, velocity_mps)[0] \
            - self._displacement[0] * velocity_mps
        return float(top + bpp_flow_m3s)

    def friction_pa(self, theta, bit_flow_m3s: float, velocity_mps):
        """Total steady annular friction of paths 2..n [Pa] with friction parameters theta
        (a float, or an array for an array of speeds)."""
        v = np.asarray(velocity_mps, dtype=float)
        flows = self.path_flows_m3s(bit_flow_m3s, v)
        total = np.asarray(sum(path_friction(NUMPY, self.em, k, flows[k], v, theta[k])
                               for k in range(self.em.n - 1)), dtype=float)
        return total if total.ndim else float(total)

    def bhp_change_pa(self, theta, bit_flow_m3s: float, velocity_mps: float) -> float:
        """Steady surge (> 0) or swab (< 0) of the BHP against the string at rest [Pa]."""
        return self.friction_pa(theta, bit_flow_m3s, velocity_mps) \
            - self.friction_pa(theta, bit_flow_m3s, 0.0)

    def choke_dp_for_bhp(self, bhp_pa: float, theta, bit_flow_m3s: float,
                         velocity_mps, downstream_pa: float, density_offset_kgm3: float = 0.0):
        """Steady choke dp [Pa] that puts the BHP at ``bhp_pa`` at this motion and flow (per
        speed for an array of speeds), the mud ``density_offset_kgm3`` heavier than the
        model's (the estimate's density offset)."""
        column = self.column_pa * (1.0 + density_offset_kgm3 / self.em.wm.well.mud.density_kgm3)
        return bhp_pa - column - self.friction_pa(theta, bit_flow_m3s, velocity_mps) \
            - downstream_pa
