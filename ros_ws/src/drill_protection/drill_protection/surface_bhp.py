"""The BHP read from the surface (plain Python): the mud column, the measured choke dp and
the steady model's annular friction at the measured flow up the annulus (the return flow
less the back-pressure pump's) and string speed. The protection's backup for a BHP gauge
it cannot read, and the BHP the well will have once circulation's friction is gone (the
column plus the choke dp: drill_protection.pump_trip)."""
from __future__ import annotations

import math

import numpy as np

from drill_core import hydraulics as hy


class SurfaceBhp:
    """The surface's view of the BHP for one well model."""

    def __init__(self, wm: hy.WellModel):
        self.wm = wm
        self.column_pa = hy.hydrostatic_pa(wm, wm.geometry.node_depth_m[-1]) \
            + wm.well.choke_downstream_pressure_pa   # the BHP without friction, less the choke dp

    def friction_pa(self, annulus_flow_m3s: float, string_velocity_mps: float) -> float:
        """The annular friction [Pa] at a flow up the annulus [m^3/s] and a string speed, up
        [m/s] (NaN when either is unmeasured)."""
        if not (math.isfinite(annulus_flow_m3s) and math.isfinite(string_velocity_mps)):
            return math.nan
        flows = [np.array([annulus_flow_m3s])] * (self.wm.n - 1)
        return float(np.sum(hy.annulus_friction(np, self.wm, flows,
                                                np.array([string_velocity_mps]))))

    def bhp_pa(self, choke_dp_pa: float, annulus_flow_m3s: float,
               string_velocity_mps: float) -> float:
        """The BHP [Pa]: the column, the choke dp and the friction (NaN when one is
        unmeasured)."""
        return self.column_pa + choke_dp_pa + self.friction_pa(annulus_flow_m3s,
                                                              string_velocity_mps)
