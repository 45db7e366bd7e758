"""The inputs the actuators' tick classes take in tests (drill_plant.actuator_tick): a
machine command and a measurement at an operating point."""
from __future__ import annotations

import math
from types import SimpleNamespace

from drill_protection.tick import MachineCommand


def command(op, **fields) -> MachineCommand:
    """A machine command at the operating point ``op`` with ``fields`` changed (SI)."""
    base = dict(block_position_ref_m=0.0, choke_flow_ref_m3s=float(op.choke_flow_m3s),
                bpp_flow_m3s=0.0, spp_pa=2.0e7, mud_pump_on=True, choke_manual=False,
                choke_opening_ref=0.0, choke_pressure_control=False, choke_dp_ref_pa=0.0,
                choke_dp_ref_rate_pa_s=0.0, bhp_ref_pa=math.nan, bhp_window_low_pa=math.nan,
                bhp_window_high_pa=math.nan, trip_speed_limit_in_mps=math.nan,
                trip_speed_limit_out_mps=math.nan, emergency_stop=False,
                emergency_bhp_pa=math.nan)
    return MachineCommand(**{**base, **fields})


def measurement(op):
    """The measurement the actuators read, at the operating point ``op``."""
    return SimpleNamespace(block_position_m=0.0, choke_dp_pa=2.0e6,
                           bhp_pa=6.85e7, return_flow_m3s=float(op.choke_flow_m3s))
